# forklift_add_test(NAME <name> LABEL <module> SOURCES <files...> LIBS <targets...>)
# One GoogleTest executable whose tests are registered with ctest under the module's label,
# so `ctest -L <module>` runs one module. Tests run from the source tree's data/; their temporary
# files (testing::TempDir()) go to this build's tests/tmp, so that two build trees tested at once
# never share one (their ports and DDS domains come from tests/support/ports.h).
# The same for the tests that are scripts (web pages, worker hosts): set as their ENVIRONMENT.
set(FORKLIFT_TEST_PASSWORD_COST FORKLIFT_PASSWORD_COST=test)

function(forklift_add_test)
  cmake_parse_arguments(T "" "NAME;LABEL;DISCOVER_FILTER" "SOURCES;LIBS" ${ARGN})
  # tests/support/test_environment.cc: the environment every test program's servers share.
  add_executable(${T_NAME} ${T_SOURCES} ${CMAKE_SOURCE_DIR}/tests/support/test_environment.cc)
  target_link_libraries(${T_NAME} PRIVATE ${T_LIBS} GTest::gtest GTest::gtest_main)
  target_include_directories(${T_NAME} PRIVATE ${CMAKE_SOURCE_DIR}/tests)
  list(LENGTH T_SOURCES n_sources)
  if(n_sources GREATER 2)  # GoogleTest's header parsed once per binary, not per file (not worth it for one or two)
    target_precompile_headers(${T_NAME} PRIVATE <gtest/gtest.h>)
  endif()
  target_compile_definitions(${T_NAME} PRIVATE FORKLIFT_DATA_DIR="${FORKLIFT_DATA_DIR}")
  set_target_properties(${T_NAME} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/tests)
  file(MAKE_DIRECTORY ${CMAKE_BINARY_DIR}/tests/tmp)
  if(NOT T_DISCOVER_FILTER)  # a gtest filter: the tests left out are registered by hand (fixtures)
    set(T_DISCOVER_FILTER "*")
  endif()
  gtest_discover_tests(${T_NAME} PROPERTIES LABELS ${T_LABEL} ENVIRONMENT TEST_TMPDIR=${CMAKE_BINARY_DIR}/tests/tmp
                       DISCOVERY_TIMEOUT 60 TEST_FILTER ${T_DISCOVER_FILTER})
endfunction()
