# cmake/Unity.cmake - the Unity (ThrowTheSwitch) unit-test framework for the C tests.
#
# Usage from the top-level CMakeLists.txt (after project() and enable_testing()):
#
#   list(APPEND CMAKE_MODULE_PATH "${CMAKE_CURRENT_SOURCE_DIR}/cmake")
#   include(Unity)
#   caekf_add_unity_test(test_linalg
#       SOURCES tests/unit/test_linalg.c
#       LIBS    caekf_core)
#
# Provides the target `unity` (alias `Unity::unity`) with UNITY_INCLUDE_DOUBLE and
# UNITY_SUPPORT_64 as PUBLIC compile definitions, so tests may use
# TEST_ASSERT_EQUAL_DOUBLE, TEST_ASSERT_DOUBLE_WITHIN, TEST_ASSERT_EQUAL_INT64, ...
#
# Where Unity comes from, first match wins:
#   1. an installed Unity: find_package(unity CONFIG) (target unity::framework), used
#      only if it links a double assertion (it must have been built with doubles);
#      skip with -DCAEKF_UNITY_TRY_INSTALLED=OFF
#   2. -DUNITY_SOURCE_DIR=<dir containing src/unity.c>
#   3. <source dir>/.cache/unity, which tools/bootstrap.sh fills offline from Debian's
#      cjson source package (Unity 2.4.3, unmodified)
#   4. FetchContent of the pinned upstream release below (needs network; disable with
#      -DCAEKF_UNITY_ALLOW_FETCH=OFF or FETCHCONTENT_FULLY_DISCONNECTED=ON)
# Cases 2-4 compile src/unity.c here, with the project's flags (sanitizers, CPU,
# optimisation) but with warnings in Unity itself never fatal.

include_guard(GLOBAL)

set(CAEKF_UNITY_URL
    "https://github.com/ThrowTheSwitch/Unity/archive/refs/tags/v2.6.0.tar.gz")
set(CAEKF_UNITY_SHA256
    "aa4c9fb1ae5fc5242f914c65f3557e817e40cb37f04a31e5ff76d1ab89dbf674")

option(CAEKF_UNITY_TRY_INSTALLED "Use an installed Unity (find_package) if one is found" ON)
option(CAEKF_UNITY_ALLOW_FETCH "Download the pinned Unity release if no local copy exists" ON)
set(UNITY_SOURCE_DIR "" CACHE PATH "Folder containing Unity's src/unity.c (optional)")

# The directory this file lives in, captured now (inside functions CMAKE_CURRENT_LIST_DIR
# names the caller's file).
set(_CAEKF_UNITY_MODULE_DIR "${CMAKE_CURRENT_LIST_DIR}")

set(CAEKF_UNITY_ORIGIN "")

# --- 1. installed Unity ------------------------------------------------------------------
if(CAEKF_UNITY_TRY_INSTALLED AND NOT TARGET unity)
    find_package(unity CONFIG QUIET)
    if(unity_FOUND AND TARGET unity::framework)
        include(CheckCSourceCompiles)
        include(CMakePushCheckState)
        cmake_push_check_state(RESET)
        set(CMAKE_REQUIRED_LIBRARIES unity::framework)
        set(CMAKE_REQUIRED_DEFINITIONS -DUNITY_INCLUDE_DOUBLE -DUNITY_SUPPORT_64)
        set(CMAKE_REQUIRED_QUIET ON)
        check_c_source_compiles([=[
#include "unity.h"
void setUp(void) {}
void tearDown(void) {}
static void t(void) { TEST_ASSERT_EQUAL_DOUBLE(1.0, 1.0); }
int main(void) { UNITY_BEGIN(); RUN_TEST(t); return UNITY_END(); }
]=] CAEKF_INSTALLED_UNITY_HAS_DOUBLE)
        cmake_pop_check_state()
        if(CAEKF_INSTALLED_UNITY_HAS_DOUBLE)
            add_library(unity INTERFACE)
            target_link_libraries(unity INTERFACE unity::framework)
            target_compile_definitions(unity INTERFACE UNITY_INCLUDE_DOUBLE UNITY_SUPPORT_64)
            set(CAEKF_UNITY_ORIGIN "installed (${unity_DIR})")
        else()
            message(STATUS "Unity: installed copy at ${unity_DIR} lacks double support; not used")
        endif()
    endif()
endif()

# --- 2./3./4. build src/unity.c from a source tree ---------------------------------------
if(NOT TARGET unity)
    set(_caekf_unity_src "")
    if(UNITY_SOURCE_DIR)
        if(NOT EXISTS "${UNITY_SOURCE_DIR}/src/unity.c")
            message(FATAL_ERROR "UNITY_SOURCE_DIR=${UNITY_SOURCE_DIR} has no src/unity.c")
        endif()
        set(_caekf_unity_src "${UNITY_SOURCE_DIR}")
        set(CAEKF_UNITY_ORIGIN "UNITY_SOURCE_DIR (${UNITY_SOURCE_DIR})")
    else()
        foreach(_cand "${CMAKE_SOURCE_DIR}/.cache/unity" "${_CAEKF_UNITY_MODULE_DIR}/../.cache/unity")
            get_filename_component(_cand "${_cand}" ABSOLUTE)
            if(EXISTS "${_cand}/src/unity.c")
                set(_caekf_unity_src "${_cand}")
                set(CAEKF_UNITY_ORIGIN "bootstrap cache (${_cand})")
                break()
            endif()
        endforeach()
    endif()

    if(NOT _caekf_unity_src)
        if(NOT CAEKF_UNITY_ALLOW_FETCH OR FETCHCONTENT_FULLY_DISCONNECTED)
            message(FATAL_ERROR
                "Unity not found: run tools/bootstrap.sh (fills .cache/unity offline), "
                "or pass -DUNITY_SOURCE_DIR=<dir with src/unity.c>.")
        endif()
        message(STATUS "Unity: no local copy; downloading ${CAEKF_UNITY_URL} "
                       "(run tools/bootstrap.sh to work offline)")
        include(FetchContent)
        set(_caekf_unity_ts "")
        if(CMAKE_VERSION VERSION_GREATER_EQUAL 3.24)
            set(_caekf_unity_ts DOWNLOAD_EXTRACT_TIMESTAMP TRUE)
        endif()
        FetchContent_Declare(caekf_unity
            URL      "${CAEKF_UNITY_URL}"
            URL_HASH "SHA256=${CAEKF_UNITY_SHA256}"
            ${_caekf_unity_ts}
            # No CMakeLists.txt there: populate only; the target is built below.
            SOURCE_SUBDIR "caekf-populate-only")
        FetchContent_MakeAvailable(caekf_unity)
        set(_caekf_unity_src "${caekf_unity_SOURCE_DIR}")
        set(CAEKF_UNITY_ORIGIN "downloaded v2.6.0 (${_caekf_unity_src})")
    endif()

    add_library(unity STATIC "${_caekf_unity_src}/src/unity.c")
    # SYSTEM: Unity's headers never trigger the tests' warnings.
    target_include_directories(unity SYSTEM PUBLIC "${_caekf_unity_src}/src")
    target_compile_definitions(unity PUBLIC UNITY_INCLUDE_DOUBLE UNITY_SUPPORT_64)
    set_target_properties(unity PROPERTIES
        C_STANDARD 99
        C_EXTENSIONS OFF
        C_CLANG_TIDY ""
        FOLDER "third_party")
    # Same flags as the tests (CMAKE_C_FLAGS*, sanitizers, CPU options all apply), except
    # that warnings in Unity are never errors: drop -Werror/-pedantic inherited from
    # add_compile_options(), then override whatever CMAKE_C_FLAGS may carry.
    get_target_property(_caekf_unity_opts unity COMPILE_OPTIONS)
    if(_caekf_unity_opts)
        list(FILTER _caekf_unity_opts EXCLUDE REGEX "^-Werror|^-W?pedantic|^-pedantic-errors$|^/WX$")
        set_property(TARGET unity PROPERTY COMPILE_OPTIONS "${_caekf_unity_opts}")
    endif()
    if(CMAKE_C_COMPILER_ID MATCHES "GNU|Clang")
        target_compile_options(unity PRIVATE -Wno-error -Wno-pedantic -w)
    elseif(MSVC)
        target_compile_options(unity PRIVATE /WX- /W0)
    endif()
    unset(_caekf_unity_opts)
    unset(_caekf_unity_src)
endif()

if(NOT TARGET Unity::unity)
    add_library(Unity::unity ALIAS unity)
endif()
message(STATUS "Unity: ${CAEKF_UNITY_ORIGIN}")

# caekf_add_unity_test(<name>
#     SOURCES <file>...            test sources (the file with main() included)
#     [LIBS <target-or-lib>...]    linked PRIVATE, besides Unity
#     [INCLUDES <dir>...]          extra PRIVATE include directories
#     [DEFINITIONS <def>...]       extra PRIVATE compile definitions
#     [LABELS <label>...]          ctest labels (always also "unit")
#     [TIMEOUT <seconds>]          ctest timeout (default 60)
#     [ARGS <arg>...])             command-line arguments for the test executable
# Builds executable <name> and registers it as ctest test <name>. add_test() with a
# target name runs it through CMAKE_CROSSCOMPILING_EMULATOR (e.g. QEMU) when set.
function(caekf_add_unity_test name)
    cmake_parse_arguments(PARSE_ARGV 1 ARG "" "TIMEOUT" "SOURCES;LIBS;INCLUDES;DEFINITIONS;LABELS;ARGS")
    if(ARG_UNPARSED_ARGUMENTS)
        message(FATAL_ERROR "caekf_add_unity_test(${name}): unknown arguments: ${ARG_UNPARSED_ARGUMENTS}")
    endif()
    if(NOT ARG_SOURCES)
        message(FATAL_ERROR "caekf_add_unity_test(${name}): SOURCES is required")
    endif()
    if(NOT ARG_TIMEOUT)
        set(ARG_TIMEOUT 60)
    endif()
    add_executable(${name} ${ARG_SOURCES})
    target_link_libraries(${name} PRIVATE ${ARG_LIBS} Unity::unity)
    if(ARG_INCLUDES)
        target_include_directories(${name} PRIVATE ${ARG_INCLUDES})
    endif()
    if(ARG_DEFINITIONS)
        target_compile_definitions(${name} PRIVATE ${ARG_DEFINITIONS})
    endif()
    add_test(NAME ${name} COMMAND ${name} ${ARG_ARGS})
    set_tests_properties(${name} PROPERTIES
        LABELS "unit;${ARG_LABELS}"
        TIMEOUT ${ARG_TIMEOUT}
        # Unity prints "N Tests M Failures" and exits with the failure count; a crash
        # before that line must not pass either.
        FAIL_REGULAR_EXPRESSION "[1-9][0-9]* Failures")
endfunction()
