# The tests' precompiled headers (tests/CMakeLists.txt says why). Each is compiled once, by a
# host target of its own that has the flags and definitions its users share, and reused by
# every test that is marked for it (clang and g++ refuse a precompiled header whose
# optimisation level or definitions differ from the including file's: the tests compiled at
# another level, STRATA_TESTS_OPTIMISED, parse their headers themselves).
#
# Only headers from outside the project: a test that forgets to include one of Strata's own
# headers must still fail to compile.
set(strata_test_headers
  <algorithm> <atomic> <chrono> <cmath> <cstdint> <filesystem> <fstream> <functional>
  <future> <limits> <map> <memory> <mutex> <optional> <random> <set> <span> <sstream>
  <string> <string_view> <thread> <vector>
  <Eigen/Core> <Eigen/Geometry> <gmock/gmock.h> <gtest/gtest.h>)
set(strata_server_test_headers
  ${strata_test_headers} <fmt/format.h> <grpcpp/grpcpp.h> <google/rpc/error_details.pb.h>
  <strata/v1/map_service.grpc.pb.h> <strata/v1/planner_service.grpc.pb.h>
  <strata/v1/traffic_service.grpc.pb.h>)

add_library(strata_test_headers OBJECT test_util/precompiled_headers.cpp)
target_link_libraries(strata_test_headers PRIVATE GTest::gmock Eigen3::Eigen)
target_precompile_headers(strata_test_headers PRIVATE ${strata_test_headers})
# What linking these libraries defines (FMT_SHARED, for one) must be defined for every user too:
# strata_use_test_headers links them to each.
set(strata_server_test_header_libraries GTest::gmock Eigen3::Eigen fmt::fmt gRPC::grpc++
    strata::proto)
if(TARGET strata::proto)
  add_library(strata_server_test_headers OBJECT test_util/precompiled_headers.cpp)
  target_link_libraries(strata_server_test_headers PRIVATE ${strata_server_test_header_libraries})
  target_precompile_headers(strata_server_test_headers PRIVATE ${strata_server_test_headers})
endif()

# strata_test_uses_server_headers(<target>...): these tests take the server's precompiled
# header (gRPC, protobuf, the API) instead of the plain one.
function(strata_test_uses_server_headers)
  set_property(TARGET ${ARGN} PROPERTY STRATA_SERVER_TEST_HEADERS ON)
endfunction()

# strata_use_test_headers(<tests to leave out>): every test made by strata_add_test or
# strata_add_client_test reuses its precompiled header. Called once, after the tests exist.
function(strata_use_test_headers excluded)
  get_property(tests GLOBAL PROPERTY STRATA_TEST_TARGETS)
  foreach(test ${tests})
    if(test IN_LIST excluded)
      continue()
    endif()
    get_target_property(server_headers ${test} STRATA_SERVER_TEST_HEADERS)
    if(server_headers)
      target_link_libraries(${test} PRIVATE ${strata_server_test_header_libraries})
      target_precompile_headers(${test} REUSE_FROM strata_server_test_headers)
    else()
      target_precompile_headers(${test} REUSE_FROM strata_test_headers)
    endif()
  endforeach()
endfunction()
