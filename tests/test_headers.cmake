# The tests' precompiled headers (tests/CMakeLists.txt says why), in the builds that have them
# (STRATA_PRECOMPILED_HEADERS, the top CMakeLists.txt). Each is compiled once, by a host target
# of its own that has the flags and definitions its users share, and reused by every test
# marked for it: clang refuses a precompiled header whose optimisation level, thread support
# or position independence differ from the including file's, or that defines a macro the file
# does not. The tests compiled at -O3 take a third one, compiled at -O3.
#
# Only headers from outside the project: a test that forgets one of Strata's own headers must
# still fail to compile.
set(strata_test_headers ${STRATA_STANDARD_HEADERS} <future> <limits> <random>
    <Eigen/Core> <Eigen/Geometry> <gmock/gmock.h> <gtest/gtest.h>)
set(strata_server_test_headers ${strata_test_headers} <fmt/format.h> ${STRATA_API_HEADERS})
# Linking these defines what the server's header is compiled with (FMT_SHARED, -pthread):
# strata_use_test_headers links them to each of its users too.
set(strata_server_test_header_libraries GTest::gmock Eigen3::Eigen fmt::fmt gRPC::grpc++
    strata::proto)

# strata_test_header_host(<host> <headers variable> <libraries>...): the target that compiles
# one precompiled header, with what linking <libraries> defines.
function(strata_test_header_host host headers)
  add_library(${host} OBJECT test_util/precompiled_headers.cpp)
  target_link_libraries(${host} PRIVATE ${ARGN})
  target_precompile_headers(${host} PRIVATE ${${headers}})
endfunction()

if(STRATA_PRECOMPILED_HEADERS)
  strata_test_header_host(strata_test_headers strata_test_headers GTest::gmock Eigen3::Eigen)
  if(STRATA_SANITIZE)  # Its tests: STRATA_TESTS_OPTIMISED (tests/CMakeLists.txt).
    strata_test_header_host(strata_optimised_test_headers strata_test_headers GTest::gmock
                            Eigen3::Eigen)
    target_compile_options(strata_optimised_test_headers PRIVATE -O3)
  endif()
  if(TARGET strata::proto)
    strata_test_header_host(strata_server_test_headers strata_server_test_headers
                            ${strata_server_test_header_libraries})
  endif()
endif()

# strata_test_uses_server_headers(<target>...): these tests take the server's precompiled
# header (gRPC, protobuf, the API) instead of the plain one.
function(strata_test_uses_server_headers)
  set_property(TARGET ${ARGN} PROPERTY STRATA_SERVER_TEST_HEADERS ON)
endfunction()

# strata_use_test_headers(<tests compiled at -O3> <tests to leave out>...): every other test
# made by strata_add_test or strata_add_client_test reuses its precompiled header. Called once,
# after the tests exist.
function(strata_use_test_headers optimised)
  if(NOT STRATA_PRECOMPILED_HEADERS)
    return()
  endif()
  get_property(tests GLOBAL PROPERTY STRATA_TEST_TARGETS)
  foreach(test ${tests})
    if(test IN_LIST ARGN)
      continue()
    endif()
    get_target_property(server_headers ${test} STRATA_SERVER_TEST_HEADERS)
    if(test IN_LIST optimised)
      target_precompile_headers(${test} REUSE_FROM strata_optimised_test_headers)
    elseif(server_headers)
      target_link_libraries(${test} PRIVATE ${strata_server_test_header_libraries})
      target_precompile_headers(${test} REUSE_FROM strata_server_test_headers)
    else()
      target_precompile_headers(${test} REUSE_FROM strata_test_headers)
    endif()
  endforeach()
endfunction()
