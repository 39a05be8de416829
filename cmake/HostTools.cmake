# Host tools for cross builds (the MCU presets): the unit suites and target_replay need test data that host
# programs make (caekf-truth's record, caekf-reference's double results) and the host caekf-replay as the
# reference trajectory. They are built here, with the host's compiler, as an external project inside this
# build folder (host-tools/), so an MCU preset configures and builds on a clean tree by itself: no other
# preset has to be built first, no fixed sibling folder.
#
# CAEKF_HOST_BUILD_DIR (optional): an existing host double build whose testdata/ and host/caekf-replay are used
# instead (nothing is built for the host then). The MCU presets of CMakePresets.json read it from the environment
# variable of the same name (unset: empty); tools/run-tests.sh points it at build/host-double for the presets that
# replay the paper's truth.
# Sets CAEKF_HOST_TESTDATA_DIR and CAEKF_HOST_REPLAY_TOOL; the target caekf_host_tools (when built here) is what
# depends on them.
include(ExternalProject) # included by tests/unit and tests/target: sets their variables, adds the target once

set(CAEKF_HOST_BUILD_DIR "" CACHE PATH
    "Existing host double build to take the test data and caekf-replay from (default: built in host-tools/)")
if(CAEKF_HOST_BUILD_DIR)
    set(_host_dir "${CAEKF_HOST_BUILD_DIR}")
else()
    set(_host_dir "${CMAKE_BINARY_DIR}/host-tools")
endif()
set(CAEKF_HOST_TESTDATA_DIR "${_host_dir}/testdata")
set(CAEKF_HOST_REPLAY_TOOL "${_host_dir}/host/caekf-replay")

if(NOT CAEKF_HOST_BUILD_DIR AND NOT TARGET caekf_host_tools)
    # The host-double preset's settings (CMakePresets.json); the toolchain file is not passed on, so the host's
    # default C compiler builds it. Only the targets the cross build needs are built.
    ExternalProject_Add(caekf_host_tools
        SOURCE_DIR "${PROJECT_SOURCE_DIR}"
        BINARY_DIR "${_host_dir}"
        CMAKE_ARGS -DCAEKF_SCALAR=double -DCMAKE_BUILD_TYPE=Release "-DCMAKE_C_FLAGS_RELEASE=-O2 -DNDEBUG"
                   -DCAEKF_WERROR=${CAEKF_WERROR} -DCAEKF_SCENARIO=${CAEKF_SCENARIO}
        BUILD_COMMAND ${CMAKE_COMMAND} --build <BINARY_DIR> --target caekf_testdata caekf-replay
        INSTALL_COMMAND ""
        TEST_COMMAND ""
        BUILD_ALWAYS ON # the host build decides what is stale (the scenario, the C sources)
        BUILD_BYPRODUCTS "${CAEKF_HOST_TESTDATA_DIR}/paper_truth.bin" "${CAEKF_HOST_TESTDATA_DIR}/paper_truth.csv"
                         "${CAEKF_HOST_TESTDATA_DIR}/reference_f64.h" "${CAEKF_HOST_REPLAY_TOOL}"
        USES_TERMINAL_BUILD ON)
endif()

# caekf_host_tools_depend(TARGET...): the targets wait for the host tools' outputs (a no-op with CAEKF_HOST_BUILD_DIR).
function(caekf_host_tools_depend)
    if(TARGET caekf_host_tools)
        foreach(t IN LISTS ARGN)
            add_dependencies(${t} caekf_host_tools)
        endforeach()
    endif()
endfunction()
