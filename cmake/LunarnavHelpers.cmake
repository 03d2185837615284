# Helpers that give every target of the project the same shape:
#   lunarnav_add_library(NAME SRCS ... PUBLIC_DEPS ... PRIVATE_DEPS ...)
#   lunarnav_add_app(NAME SRCS ... DEPS ...)
#   lunarnav_add_test(NAME DIR dir SRCS ... DEPS ... [LABELS ...])
#   lunarnav_add_test_module(DIR SRCS ... DEPS ... [LABELS ...])
include_guard(GLOBAL)
include(CheckCXXCompilerFlag)

set(LUNARNAV_WARNING_FLAGS -Wall -Wextra -Wpedantic -Wno-unused-parameter)
if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND CMAKE_CXX_COMPILER_VERSION VERSION_GREATER_EQUAL 12)
  # False positives inside libstdc++'s std::string with GCC 12 (GCC bug 105329).
  list(APPEND LUNARNAV_WARNING_FLAGS -Wno-restrict)
endif()
if(LUNARNAV_WERROR)
  list(APPEND LUNARNAV_WARNING_FLAGS -Werror)
endif()

function(lunarnav_set_common_options target)
  target_compile_options(${target} PRIVATE ${LUNARNAV_WARNING_FLAGS})
  if(LUNARNAV_SANITIZE)
    # Undefined behaviour stops the program (a test fails), as an address error does.
    target_compile_options(${target} PRIVATE -fsanitize=address,undefined -fno-sanitize-recover=undefined
                                             -fno-omit-frame-pointer)
    target_link_options(${target} PRIVATE -fsanitize=address,undefined)
  endif()
  if(LUNARNAV_FUZZ)
    # Coverage for libFuzzer in every target; the fuzzers themselves link its main.
    target_compile_options(${target} PRIVATE -fsanitize=fuzzer-no-link)
  endif()
endfunction()

# Precompiled headers for the tools and the tests. Their sources parse the same third-party
# headers (nlohmann/json, OpenCV's core, Eigen, and CLI11 in the tools or GoogleTest in the
# tests: about 1 s each); each kind reuses one precompiled set, built once by an object
# library of its own with the flags of every target (lunarnav_pch_app, lunarnav_pch_test).
# Measured (fresh Release builds, 2 cores): the tests' compile time fell by a fifth, the
# tools' by 30 %, the libraries' by 3 % (their time is code generation), so the libraries
# are built without one: with GCC 12 a precompiled header lets libstdc++'s false positives
# through (-Warray-bounds, -Wstringop-overflow on std::string's copies, as if its headers
# were not system headers), and the product's code keeps those warnings. LUNARNAV_PCH=OFF
# builds without any.
option(LUNARNAV_PCH "Precompile the third-party headers most sources parse" ON)
set(LUNARNAV_PCH_HEADERS
    <algorithm> <array> <cmath> <cstdint> <cstdio> <filesystem> <fstream> <functional> <limits>
    <map> <memory> <optional> <sstream> <string> <string_view> <utility> <vector>
    <nlohmann/json.hpp> <opencv2/core.hpp> <Eigen/Core> <Eigen/Geometry>)

# The precompiled set KIND (app or test): the common headers and EXTRA ones.
function(lunarnav_add_pch KIND)
  if(NOT LUNARNAV_PCH)
    return()
  endif()
  cmake_parse_arguments(ARG "" "" "EXTRA;DEPS" ${ARGN})
  set(anchor ${PROJECT_BINARY_DIR}/lunarnav_pch_anchor.cc)
  if(NOT EXISTS ${anchor})
    file(WRITE ${anchor} "// The source of the precompiled-header targets (lunarnav_pch_*): empty.\n")
  endif()
  add_library(lunarnav_pch_${KIND} OBJECT ${anchor})
  target_link_libraries(lunarnav_pch_${KIND} PRIVATE opencv_core Eigen3::Eigen nlohmann_json::nlohmann_json ${ARG_DEPS})
  lunarnav_set_common_options(lunarnav_pch_${KIND})
  target_precompile_headers(lunarnav_pch_${KIND} PRIVATE ${LUNARNAV_PCH_HEADERS} ${ARG_EXTRA})
endfunction()

# `target` reuses the precompiled set KIND (and can find its headers without it).
function(lunarnav_use_pch target KIND)
  if(NOT LUNARNAV_PCH)
    return()
  endif()
  target_precompile_headers(${target} REUSE_FROM lunarnav_pch_${KIND})
  target_link_libraries(${target} PRIVATE Eigen3::Eigen nlohmann_json::nlohmann_json)
  target_include_directories(${target} SYSTEM PRIVATE ${OpenCV_INCLUDE_DIRS})
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND CMAKE_CXX_COMPILER_VERSION VERSION_GREATER_EQUAL 12)
    target_compile_options(${target} PRIVATE -Wno-array-bounds -Wno-stringop-overflow)
  endif()
endfunction()

# One library target per lib/ module: lunarnav_<NAME>, aliased lunarnav::<NAME>.
function(lunarnav_add_library NAME)
  cmake_parse_arguments(ARG "" "" "SRCS;PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  set(target lunarnav_${NAME})
  add_library(${target} STATIC ${ARG_SRCS})
  add_library(lunarnav::${NAME} ALIAS ${target})
  target_include_directories(${target} PUBLIC ${PROJECT_SOURCE_DIR}/lib ${PROJECT_BINARY_DIR}/lib)
  target_link_libraries(${target} PUBLIC ${ARG_PUBLIC_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
  lunarnav_set_common_options(${target})
endfunction()

# A command-line tool; the executable is named NAME (e.g. stereo-batch).
function(lunarnav_add_app NAME)
  cmake_parse_arguments(ARG "" "" "SRCS;DEPS" ${ARGN})
  add_executable(${NAME} ${ARG_SRCS})
  target_link_libraries(${NAME} PRIVATE ${ARG_DEPS})
  lunarnav_set_common_options(${NAME})
  set_target_properties(${NAME} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/bin)
  lunarnav_use_pch(${NAME} app)
endfunction()

# The environment every test runs in: where the test data and the tools are, and the
# sanitizer's options in the sanitized build.
function(lunarnav_test_environment OUT)
  set(environment "LUNARNAV_TESTDATA=${PROJECT_SOURCE_DIR}/testdata;LUNARNAV_BIN=${PROJECT_BINARY_DIR}/bin")
  if(LUNARNAV_SANITIZE)
    # LeakSanitizer's check at exit walks each thread's dynamic TLS; clang 14's runtime reads a
    # garbage range there after a dlopen'ed module with TLS (the OpenImageIO module, GDAL) and
    # its tracer dies ("Tracer caught signal 11": a tool exiting 1 now and then under load).
    # Not tracking __tls_get_addr leaves that walk out; leaks are still checked.
    string(APPEND environment ";ASAN_OPTIONS=intercept_tls_get_addr=0")
    # Leaks inside third-party libraries the project cannot free (each explained there).
    string(APPEND environment ";LSAN_OPTIONS=suppressions=${PROJECT_SOURCE_DIR}/tests/sanitizers/lsan.supp")
  endif()
  set(${OUT} "${environment}" PARENT_SCOPE)
endfunction()

function(lunarnav_test_executable exe)
  cmake_parse_arguments(ARG "" "" "SRCS;DEPS" ${ARGN})
  add_executable(${exe} ${ARG_SRCS})
  target_link_libraries(${exe} PRIVATE ${ARG_DEPS} lunarnav::testing GTest::gtest GTest::gmock)
  target_include_directories(${exe} PRIVATE ${PROJECT_SOURCE_DIR}/tests)
  lunarnav_set_common_options(${exe})
  lunarnav_use_pch(${exe} test)
endfunction()

# A GoogleTest program registered with CTest as DIR/NAME (e.g. integration/stereo_batch): for
# a program that must run alone (RUN_SERIAL) or with tools built first.
function(lunarnav_add_test NAME)
  cmake_parse_arguments(ARG "" "DIR" "SRCS;DEPS;LABELS" ${ARGN})
  string(REPLACE "/" "_" exe "${ARG_DIR}_${NAME}")
  lunarnav_test_executable(${exe} SRCS ${ARG_SRCS} DEPS ${ARG_DEPS})
  add_test(NAME ${ARG_DIR}/${NAME} COMMAND ${exe})
  lunarnav_test_environment(environment)
  set_tests_properties(${ARG_DIR}/${NAME} PROPERTIES ENVIRONMENT "${environment}" LABELS "${ARG_DIR};${ARG_LABELS}")
endfunction()

# The unit tests of one module (tests/DIR): one GoogleTest program, DIR_tests, of all their
# sources (one link instead of one per file); CTest lists each of its tests as
# DIR/Suite.Name, found when ctest runs (gtest_discover_tests, PRE_TEST: the build does not
# run the program), each run in its own process, labelled DIR, in the environment above.
include(GoogleTest)
function(lunarnav_add_test_module DIR)
  cmake_parse_arguments(ARG "" "" "SRCS;DEPS;LABELS" ${ARGN})
  set(exe ${DIR}_tests)
  lunarnav_test_executable(${exe} SRCS ${ARG_SRCS} DEPS ${ARG_DEPS})
  # (A sanitized program takes a while to list its tests on a loaded machine.)
  gtest_discover_tests(${exe} TEST_PREFIX "${DIR}/" TEST_LIST ${exe}_TESTS DISCOVERY_MODE PRE_TEST
                       DISCOVERY_TIMEOUT 300)
  # The properties are set by a script of their own, run after the discovery's: through
  # CMake 3.25 gtest_discover_tests' PROPERTIES split a list value (two ENVIRONMENT variables)
  # into separate arguments.
  lunarnav_test_environment(environment)
  set(labels "${DIR};${ARG_LABELS}")
  set(script ${CMAKE_CURRENT_BINARY_DIR}/${exe}_properties.cmake)
  file(GENERATE OUTPUT ${script} CONTENT "if(${exe}_TESTS)
  set_tests_properties(\${${exe}_TESTS} PROPERTIES ENVIRONMENT [==[${environment}]==] LABELS [==[${labels}]==])
endif()
")
  set_property(DIRECTORY APPEND PROPERTY TEST_INCLUDE_FILES ${script})
endfunction()
