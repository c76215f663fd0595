# Build helpers shared by every folder: warning sets, firmware flags, unit tests, fuzz targets, benchmarks.

# Warnings for all of our targets.
function(teamscan_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wnon-virtual-dtor -Wcast-align
                                           -Wunused -Woverloaded-virtual)
  if(TEAMSCAN_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()

# Firmware discipline (STYLE.md 5): drivers/ and onboard/ build without exceptions and RTTI and with
# strict conversion warnings. Apply to targets that run on the robot.
function(teamscan_firmware_flags target)
  teamscan_warnings(${target})
  target_compile_options(${target} PRIVATE $<$<COMPILE_LANGUAGE:CXX>:-fno-exceptions -fno-rtti>
                                           -Wconversion -Wsign-conversion -Wshadow -Wdouble-promotion)
endfunction()

# A library of ours: the repository root is the include root (#include "drivers/arcos/codec.hpp").
function(teamscan_library name)
  cmake_parse_arguments(ARG "FIRMWARE;INTERFACE" "" "SOURCES;DEPS" ${ARGN})
  set_property(GLOBAL APPEND PROPERTY TEAMSCAN_LIBRARIES ${name})  # cmake/ModuleGraph.cmake
  if(ARG_INTERFACE)
    add_library(${name} INTERFACE)
    target_include_directories(${name} INTERFACE ${TEAMSCAN_SOURCE_DIR} ${CMAKE_BINARY_DIR}/generated)
    target_link_libraries(${name} INTERFACE ${ARG_DEPS})
    return()
  endif()
  add_library(${name} STATIC ${ARG_SOURCES})
  target_include_directories(${name} PUBLIC ${TEAMSCAN_SOURCE_DIR} ${CMAKE_BINARY_DIR}/generated)
  target_link_libraries(${name} PUBLIC ${ARG_DEPS})
  if(ARG_FIRMWARE)
    teamscan_firmware_flags(${name})
  else()
    teamscan_warnings(${name})
  endif()
endfunction()

# add_unit_test(NAME SOURCES a.cpp b.cpp DEPS lib1 lib2 [LABELS unit|hil|e2e] [TIMEOUT s])
# Every test gets the loopback DDS config in its environment and the repository's test data folder
# compiled in (tests/support/real_data.hpp).
function(add_unit_test name)
  cmake_parse_arguments(ARG "" "TIMEOUT" "SOURCES;DEPS;LABELS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} GTest::gtest GTest::gmock GTest::gtest_main)
  target_include_directories(${name} PRIVATE ${TEAMSCAN_SOURCE_DIR})
  target_compile_definitions(${name} PRIVATE TEAMSCAN_TEST_DATA_DIR="${TEAMSCAN_SOURCE_DIR}/tests/data")
  teamscan_warnings(${name})
  if(NOT ARG_LABELS)
    set(ARG_LABELS unit)
  endif()
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 120)
  endif()
  add_test(NAME ${name} COMMAND ${name})
  set_tests_properties(${name} PROPERTIES
    LABELS "${ARG_LABELS}"
    TIMEOUT ${ARG_TIMEOUT}
    # A GoogleTest case that skips (GTEST_SKIP: no root, no device) makes ctest report the test as
    # skipped, never as passed.
    SKIP_REGULAR_EXPRESSION "\\[  SKIPPED \\]"
    ENVIRONMENT "CYCLONEDDS_URI=${TEAMSCAN_DDS_LOOPBACK_URI};TEAMSCAN_SOURCE_DIR=${TEAMSCAN_SOURCE_DIR};TEAMSCAN_BINARY_DIR=${CMAKE_BINARY_DIR}")
  # An e2e test runs the whole live system in real time (emulated devices paced at their baud rates,
  # the daemons stamping scans on arrival): it gets the machine to itself, not a core shared with a
  # CPU-bound test, so that its timing checks measure the software and not ctest's scheduling.
  if("e2e" IN_LIST ARG_LABELS)
    set_tests_properties(${name} PROPERTIES RUN_SERIAL TRUE)
  endif()
endfunction()

# add_fuzz_target(NAME SOURCE fuzz_x.cpp DEPS libs CORPUS dir)
# With TEAMSCAN_FUZZ (clang): a real libFuzzer binary. Always: a regression test that replays the
# checked-in corpus (plus generated seeds) through LLVMFuzzerTestOneInput under ctest (label fuzz).
function(add_fuzz_target name)
  cmake_parse_arguments(ARG "" "SOURCE;CORPUS" "DEPS" ${ARGN})
  add_executable(${name}_replay ${ARG_SOURCE} ${TEAMSCAN_SOURCE_DIR}/tests/fuzz/replay_main.cpp)
  target_link_libraries(${name}_replay PRIVATE ${ARG_DEPS})
  target_include_directories(${name}_replay PRIVATE ${TEAMSCAN_SOURCE_DIR})
  teamscan_warnings(${name}_replay)
  add_test(NAME ${name}_corpus COMMAND ${name}_replay ${ARG_CORPUS})
  set_tests_properties(${name}_corpus PROPERTIES LABELS "fuzz" TIMEOUT 300)
  if(TEAMSCAN_FUZZ)
    add_executable(${name} ${ARG_SOURCE})
    target_link_libraries(${name} PRIVATE ${ARG_DEPS})
    target_include_directories(${name} PRIVATE ${TEAMSCAN_SOURCE_DIR})
    target_compile_options(${name} PRIVATE -fsanitize=fuzzer,address,undefined)
    target_link_options(${name} PRIVATE -fsanitize=fuzzer,address,undefined)
  endif()
endfunction()

# add_teamscan_benchmark(NAME SOURCES ... DEPS ...): Google Benchmark binary; never a pass/fail test.
function(add_teamscan_benchmark name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  if(NOT TEAMSCAN_BENCH)
    return()
  endif()
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} benchmark::benchmark benchmark::benchmark_main)
  target_include_directories(${name} PRIVATE ${TEAMSCAN_SOURCE_DIR})
  target_compile_definitions(${name} PRIVATE TEAMSCAN_TEST_DATA_DIR="${TEAMSCAN_SOURCE_DIR}/tests/data")
  teamscan_warnings(${name})
endfunction()

# teamscan_npm_ci(STAMP_VAR DIR dir SOURCE_DIR src COMMENT text): `npm ci` of SOURCE_DIR's package.json and
# package-lock.json into DIR (node_modules is never committed; nothing else is fetched). STAMP_VAR: the
# file the command makes (DIR/node_modules/.package-lock.json), for DEPENDS.
function(teamscan_npm_ci stamp_var)
  cmake_parse_arguments(ARG "" "DIR;SOURCE_DIR;COMMENT" "" ${ARGN})
  set(stamp ${ARG_DIR}/node_modules/.package-lock.json)
  add_custom_command(
    OUTPUT ${stamp}
    COMMAND ${CMAKE_COMMAND} -E make_directory ${ARG_DIR}
    COMMAND ${CMAKE_COMMAND} -E copy ${ARG_SOURCE_DIR}/package.json ${ARG_SOURCE_DIR}/package-lock.json ${ARG_DIR}
    COMMAND ${TEAMSCAN_NPM} ci --no-audit --no-fund --loglevel=error
    WORKING_DIRECTORY ${ARG_DIR}
    DEPENDS ${ARG_SOURCE_DIR}/package.json ${ARG_SOURCE_DIR}/package-lock.json
    COMMENT "${ARG_COMMENT}")
  set(${stamp_var} ${stamp} PARENT_SCOPE)
endfunction()
