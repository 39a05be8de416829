# Replay.cmake (included by tests/target/CMakeLists.txt): the replay image and its checks.
#
# Needs host test data, like the unit tests do in the cross builds: made by the host tools this build makes
# (cmake/HostTools.cmake; or those of CAEKF_HOST_BUILD_DIR):
#   CAEKF_REPLAY_TRUTH_BIN   caekf-truth --bin record of the reference scenario (CAEKF_SCENARIO: any
#                            mechanism; its CSV's header gives the record's columns)
#   CAEKF_HOST_REPLAY        the host caekf-replay (double), for the reference trajectory
# Tests:
#   target_replay            runs the image, compares with the host: Cortex-M7 (double) every
#                            snapshot within 1e-9 relative; Cortex-M4F (float) each contact's final gamma
#                            within 0.5 % or, where CAEKF_REPLAY_FLOAT_SIGMA is set, within that many of the
#                            host estimate's standard deviations
#   target_replay.stack      the measured stack (painting) of caekf_init and of the steps is within
#                            CAEKF_STACK_BUDGET (512 B float, 1024 B double); reads target_replay's
#                            saved output                                          (label budget)
#   target_replay.icount     Cortex-M4F only: no step above CAEKF_ICOUNT_BUDGET (9646) instructions
#                            (tools/qemu-icount)                                   (label budget)

include("${PROJECT_SOURCE_DIR}/cmake/HostTools.cmake")
set(CAEKF_REPLAY_TRUTH_BIN "${CAEKF_HOST_TESTDATA_DIR}/paper_truth.bin")  # embedded in target_replay
set(CAEKF_REPLAY_TRUTH_CSV "${CAEKF_HOST_TESTDATA_DIR}/paper_truth.csv")  # input of the host caekf-replay
set(CAEKF_HOST_REPLAY "${CAEKF_HOST_REPLAY_TOOL}")  # host caekf-replay (double): the reference trajectory
# Goals (Cortex-M4F, -Os): <= 512 B of stack, <= 8000 instructions per step. The double build's stack
# budget is twice the float one. Tests labelled "budget" check them: `ctest -LE budget` skips them.
if(CAEKF_SCALAR STREQUAL "float")
    set(_stack_default 512)
else()
    set(_stack_default 1024)
endif()
set(CAEKF_STACK_BUDGET ${_stack_default} CACHE STRING "Stack budget of caekf_init/caekf_step in bytes")
# A float replay's final gammas against the double host's: 0.5 %, or (set) this many of the host estimate's
# standard deviations, for scenarios whose estimate stays uncertain enough that the float and the double run part
# by more than 0.5 % (tests/target/check_replay.py; the sized presets of CMakePresets.json that need it set it).
set(CAEKF_REPLAY_FLOAT_SIGMA "0" CACHE STRING "Float replay: a final gamma may lie within this many standard deviations")
# The reference run's max step: issue 10's 9,646 (the worst contact + constraint + max Newton step's 8,000 is
# tools/mcu-report.py's, which finds that step); a benchmark gate, left out of the MCU test presets (their filter
# excludes the label icount: `ctest --test-dir build/cortex-m4f -L icount` runs it).
set(CAEKF_ICOUNT_BUDGET 9646 CACHE STRING "Max instructions per caekf_step of the reference run (Cortex-M4F)")

find_package(Python3 COMPONENTS Interpreter)
if(NOT Python3_FOUND)
    message(WARNING "tests/target: no Python 3, target_replay is not built")
    return()
endif()
if(NOT EXISTS "${PROJECT_SOURCE_DIR}/firmware/core/CMakeLists.txt")
    message(STATUS "tests/target: no firmware/core yet, target_replay is not built")
    return()
endif()

set(_gen "${CMAKE_CURRENT_BINARY_DIR}/replay_data")
add_custom_command(
    OUTPUT "${_gen}/replay_inputs.bin" "${_gen}/replay_inputs.S"
    COMMAND "${Python3_EXECUTABLE}" "${_dir}/gen_replay_data.py"
            --truth-bin "${CAEKF_REPLAY_TRUTH_BIN}" --truth-csv "${CAEKF_REPLAY_TRUTH_CSV}"
            --scalar "${CAEKF_SCALAR}" --out-dir "${_gen}"
    DEPENDS "${_dir}/gen_replay_data.py" "${CAEKF_REPLAY_TRUTH_BIN}" "${CAEKF_REPLAY_TRUTH_CSV}"
    COMMENT "Embedding the reference scenario's inputs (${CAEKF_SCALAR}) for target_replay"
    VERBATIM)
set_source_files_properties("${_gen}/replay_inputs.S" PROPERTIES OBJECT_DEPENDS "${_gen}/replay_inputs.bin")
# The settings: the reference scenario's values and the presets (the generated fixture, CAEKF_FIXTURE_DIR).

# Two images: target_replay runs the switched-highq-constrained preset (the paper's heaviest step: contact
# + constraint), target_replay_default the recommended default estimator (no preset).
# A build sized for one configuration (CAEKF_MECHANISM_PRESET) runs that configuration's step method only:
# a preset's build has no default image (its defaults would be the preset's method, not the recommended
# estimator's), a build sized for the default (CAEKF_MECHANISM_PRESET=default) only the default image.
# The settings are CAEKF_SCENARIO's (the replayed truth is the reference scenario's record). This file is read
# before firmware/core defines CAEKF_MECHANISM_PRESET's cache entry: on a first configure without the option
# it is not defined yet, which counts as empty.
if(NOT CAEKF_MECHANISM_PRESET)
    set(_variants constrained default)
elseif(CAEKF_MECHANISM_PRESET STREQUAL "default")
    set(_variants default)
else()
    set(_variants constrained)
endif()
foreach(_variant IN LISTS _variants)
    if(_variant STREQUAL "constrained")
        set(_image target_replay)
        set(_preset_def "")
        set(_replay_args --experiment switched-highq-constrained)
    else()
        set(_image target_replay_default)
        set(_preset_def "REPLAY_PRESET=-1")
        set(_replay_args)
    endif()
    caekf_target_image(${_image}
        SOURCES "${_dir}/replay.c" "${_gen}/replay_inputs.S"
        LIBS caekf_core_names caekf_core
        INCLUDES "${_gen}" "${CAEKF_FIXTURE_DIR}"
        DEFINITIONS "CAEKF_REPLAY_MCU=\"${CAEKF_MCU}\"" ${_preset_def})
    add_dependencies(${_image} caekf_fixture_generated)
    if(_variant STREQUAL "default")
        # The constructed worst case of the default (tools/mcu-report.py): the full PSD test of P on every
        # step, so that the contact steps with the most Newton iterations pay for it as well.
        caekf_target_image(${_image}_worst
            SOURCES "${_dir}/replay.c" "${_gen}/replay_inputs.S"
            LIBS caekf_core_names caekf_core
            INCLUDES "${_gen}" "${CAEKF_FIXTURE_DIR}"
            DEFINITIONS "CAEKF_REPLAY_MCU=\"${CAEKF_MCU}\"" ${_preset_def} "REPLAY_PSD_CHECK_PERIOD=1")
        add_dependencies(${_image}_worst caekf_fixture_generated)
        add_test(NAME ${_image}_worst COMMAND ${_image}_worst)
        set_tests_properties(${_image}_worst PROPERTIES LABELS "target;replay" TIMEOUT 700
            PASS_REGULAR_EXPRESSION "replay: done")
    endif()

    if(TARGET caekf_host_tools OR (EXISTS "${CAEKF_HOST_REPLAY}" AND EXISTS "${CAEKF_REPLAY_TRUTH_CSV}"))
        set(_ref "${CMAKE_CURRENT_BINARY_DIR}/${_image}_host_reference.csv")
        add_custom_command(OUTPUT "${_ref}"
            COMMAND "${CAEKF_HOST_REPLAY}" --scenario "${CAEKF_SCENARIO}" --in "${CAEKF_REPLAY_TRUTH_CSV}"
                    ${_replay_args} --out "${_ref}"
            DEPENDS "${CAEKF_HOST_REPLAY}" "${CAEKF_REPLAY_TRUTH_CSV}" "${CAEKF_SCENARIO}"
            COMMENT "Host reference trajectory for ${_image} (caekf-replay, double)"
            VERBATIM)
        add_custom_target(${_image}_reference ALL DEPENDS "${_ref}")
        if(CAEKF_SCALAR STREQUAL "double")
            set(_mode double)
        else()
            set(_mode float)
        endif()
        add_test(NAME ${_image}
            COMMAND "${Python3_EXECUTABLE}" "${_dir}/check_replay.py" --mode ${_mode}
                    --float-sigma ${CAEKF_REPLAY_FLOAT_SIGMA} --reference "${_ref}" --output "${CMAKE_CURRENT_BINARY_DIR}/${_image}.out"
                    -- ${CAEKF_QEMU_RUN} --timeout 600 $<TARGET_FILE:${_image}>)
        set_tests_properties(${_image} PROPERTIES LABELS "target;replay" TIMEOUT 700
            FIXTURES_SETUP ${_image}_output)
        add_test(NAME ${_image}.stack
            COMMAND "${Python3_EXECUTABLE}" "${_dir}/check_replay.py" --stack-only
                    --from "${CMAKE_CURRENT_BINARY_DIR}/${_image}.out" --stack-budget ${CAEKF_STACK_BUDGET})
        set_tests_properties(${_image}.stack PROPERTIES LABELS "target;replay;stack;budget" TIMEOUT 30
            FIXTURES_REQUIRED ${_image}_output)
    else()
        message(WARNING "tests/target: no host caekf-replay/CSV in ${CAEKF_HOST_BUILD_DIR}: "
                        "${_image} runs without the comparison to the host")
        add_test(NAME ${_image} COMMAND ${_image})
        set_tests_properties(${_image} PROPERTIES LABELS "target;replay" TIMEOUT 700
            PASS_REGULAR_EXPRESSION "replay: done")
    endif()
endforeach()

if(CAEKF_MCU STREQUAL "cortex-m4f" AND TARGET qemu_icount_plugin AND TARGET target_replay)
    add_test(NAME target_replay.icount
        COMMAND "${Python3_EXECUTABLE}" "${CAEKF_ROOT_DIR}/tools/qemu-icount/icount-run.py"
                --machine "${CAEKF_QEMU_MACHINE}" --plugin "${CAEKF_ICOUNT_PLUGIN}" --quiet
                --max-budget ${CAEKF_ICOUNT_BUDGET} $<TARGET_FILE:target_replay>)
    set_tests_properties(target_replay.icount PROPERTIES LABELS "target;replay;icount;budget" TIMEOUT 700
        ENVIRONMENT "CAEKF_ARM_NM=${CAEKF_ARM_NM}")
endif()
