# The settings schema and its generator (sim/src/caekf_sim/schema): every settings table, the scenario
# reader's keys, the presets and the test fixtures are generated from the one description at build time.
#
#   caekf_codegen(<target> c-core    <outdir> [<mechanism> [<preset>]]) core tables:
#                                                            caekf/caekf_settings_schema.h, ..., and the capacity
#                                                            (sized for <mechanism> if given; with <preset>, its
#                                                            step method fixed too)
#   caekf_codegen(<target> c-host    <outdir>)              scenario reader table and presets
#   caekf_codegen(<target> c-fixture <outdir> <scenario>)   a scenario's values for tests
#   caekf_codegen_dbc(<target> <outdir>)                    the C of the CAN database (caekf.dbc): the wire
#                                                            enumerations and the integer messages' structs in
#                                                            <outdir>/include (public), cantools' pack/unpack, those
#                                                            messages' codecs and the message table in <outdir>/src
#                                                            (sim/src/caekf_sim/codegen.py)
#
# <target> is a custom target that the consumers add as a dependency.
include_guard(GLOBAL)

get_filename_component(_caekf_repo "${CMAKE_CURRENT_LIST_DIR}/.." ABSOLUTE)
set(CAEKF_SCHEMA "${_caekf_repo}/sim/src/caekf_sim/schema/settings.toml")
set(CAEKF_CODEGEN "${_caekf_repo}/sim/src/caekf_sim/schema/codegen.py")
# The project's venv when bootstrap made one (it has tomli where Python < 3.11), else the system's.
if(EXISTS "${_caekf_repo}/.venv/bin/python")
    set(CAEKF_PYTHON "${_caekf_repo}/.venv/bin/python")
else()
    find_package(Python3 3.9 REQUIRED COMPONENTS Interpreter)
    set(CAEKF_PYTHON "${Python3_EXECUTABLE}")
endif()

function(caekf_codegen target kind outdir)
    set(deps "${CAEKF_SCHEMA}" "${CAEKF_CODEGEN}")
    set(args "")
    if(kind STREQUAL "c-core")
        set(outputs "${outdir}/caekf/caekf_settings_schema.h" "${outdir}/caekf_settings_table.c"
                    "${outdir}/caekf_settings_names.c" "${outdir}/caekf/caekf_capacity.h"
                    "${outdir}/caekf/caekf_settings_types.h" "${outdir}/caekf/caekf_status.h")
        if(ARGC GREATER 3 AND NOT "${ARGV3}" STREQUAL "")
            set(args "${ARGV3}")
            list(APPEND deps "${ARGV3}")
            if(ARGC GREATER 4 AND NOT "${ARGV4}" STREQUAL "")
                list(APPEND args "${ARGV4}")
            endif()
        endif()
    elseif(kind STREQUAL "c-host")
        set(outputs "${outdir}/caekf_scenario_schema.h" "${outdir}/caekf_scenario_schema.c")
    elseif(kind STREQUAL "c-fixture")
        set(args "${ARGV3}")
        list(APPEND deps "${ARGV3}")
        set(outputs "${outdir}/caekf_fixture_settings.h")
    else()
        message(FATAL_ERROR "caekf_codegen: unknown kind '${kind}'")
    endif()
    add_custom_command(
        OUTPUT ${outputs}
        COMMAND "${CAEKF_PYTHON}" "${CAEKF_CODEGEN}" ${kind} "${outdir}" ${args}
        DEPENDS ${deps}
        COMMENT "Generating ${kind} from the settings schema"
        VERBATIM)
    add_custom_target(${target} DEPENDS ${outputs})
endfunction()

# The DBC's generator needs cantools, which the project's venv has (tools/bootstrap.sh makes it).
set(CAEKF_DBC "${_caekf_repo}/firmware/protocol/caekf.dbc")
set(CAEKF_DBC_CODEGEN "${_caekf_repo}/sim/src/caekf_sim/codegen.py")

function(caekf_codegen_dbc target outdir)
    execute_process(COMMAND "${CAEKF_PYTHON}" -c "import cantools" RESULT_VARIABLE _rc OUTPUT_QUIET ERROR_QUIET)
    if(NOT _rc EQUAL 0)
        message(FATAL_ERROR "the CAN codec is generated from caekf.dbc by cantools, which ${CAEKF_PYTHON} lacks: "
                            "run tools/bootstrap.sh first (it makes .venv)")
    endif()
    set(outputs "${outdir}/src/caekf_can.c" "${outdir}/src/caekf_can.h" "${outdir}/src/caekf_proto_frames_table.h"
                "${outdir}/src/caekf_proto_messages.c" "${outdir}/include/caekf/caekf_proto_frames.h"
                "${outdir}/include/caekf/caekf_proto_messages.h")
    add_custom_command(
        OUTPUT ${outputs}
        COMMAND "${CAEKF_PYTHON}" "${CAEKF_DBC_CODEGEN}" "${outdir}" "${CAEKF_DBC}"
        DEPENDS "${CAEKF_DBC}" "${CAEKF_DBC_CODEGEN}"
        COMMENT "Generating the C of caekf.dbc"
        VERBATIM)
    add_custom_target(${target} DEPENDS ${outputs})
endfunction()
