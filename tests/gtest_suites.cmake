# Run by CTest before the tests (a TEST_INCLUDE_FILES script; strata_add_test_suites in
# tests/CMakeLists.txt writes the call): lists the tests of one GoogleTest executable and
# registers one CTest test per suite, running that suite's tests in one process. A suite's
# tests share what SetUpTestSuite builds (an assessed map, a running server); one process per
# test would build it once per test, and start a sanitised executable each time.
#
# Inputs: STRATA_SUITES_EXECUTABLE, STRATA_SUITES_WORKING_DIRECTORY, STRATA_SUITES_TIMEOUT_S.
if(NOT EXISTS "${STRATA_SUITES_EXECUTABLE}")
  add_test("${STRATA_SUITES_EXECUTABLE}_NOT_BUILT" "${STRATA_SUITES_EXECUTABLE}")
  return()
endif()
execute_process(COMMAND "${STRATA_SUITES_EXECUTABLE}" --gtest_list_tests
                WORKING_DIRECTORY "${STRATA_SUITES_WORKING_DIRECTORY}"
                OUTPUT_VARIABLE listing RESULT_VARIABLE listed TIMEOUT 60)
if(NOT listed EQUAL 0)
  message(FATAL_ERROR "${STRATA_SUITES_EXECUTABLE} --gtest_list_tests failed (${listed}):\n${listing}")
endif()
set(all_skipped
    "\\[  PASSED  \\] 0 tests\\.\n\\[  SKIPPED \\] [0-9]+ tests?, listed below:\n(\\[  SKIPPED \\] [^\n]*\n)+$")
string(REPLACE "\n" ";" lines "${listing}")
foreach(line IN LISTS lines)
  # Suite lines start in the first column and end their name with a dot ("Suite." or
  # "Prefix/Suite.  # TypeParam = ..."); test lines are indented.
  if(line MATCHES "^([^ #][^ ]*)\\.")
    set(suite "${CMAKE_MATCH_1}")
    add_test("${suite}" "${STRATA_SUITES_EXECUTABLE}" "--gtest_filter=${suite}.*")
    set_tests_properties("${suite}" PROPERTIES
      WORKING_DIRECTORY "${STRATA_SUITES_WORKING_DIRECTORY}"
      TIMEOUT "${STRATA_SUITES_TIMEOUT_S}"
      # Skipped only when every test of the suite skipped; a suite with some passed stays
      # passed, and one with a failure failed.
      SKIP_REGULAR_EXPRESSION "${all_skipped}")
  endif()
endforeach()
