# cmake/Target.cmake - Cortex-M specifics of the cross builds (presets cortex-m4f, cortex-m7).
#
# Included by the top-level CMakeLists.txt when CMAKE_CROSSCOMPILING (toolchain file
# cmake/arm-none-eabi.cmake), right after project(). It provides:
#
#   caekf_target_runtime   INTERFACE library every target executable links: the port's startup,
#                          vector table, semihosting console/exit and newlib stubs (object files,
#                          so they are always in the image), the MPS2 linker script for the
#                          machine, -lm. Include directory: firmware/port/cortex-m (caekf_port.h).
#   caekf_target_finalize(<exe>)
#                          makes <exe> a QEMU image: links caekf_target_runtime, writes <exe>.map,
#                          and registers the ctest test `<exe>.no_heap` (arm-none-eabi-nm: fails if
#                          malloc/free/_sbrk or friends are in the image). Idempotent.
#   CAEKF_QEMU_MACHINE     mps2-an386 (cortex-m4f) or mps2-an500 (cortex-m7)
#   CAEKF_QEMU_RUN         the emulator command list (tools/qemu-run.sh --machine ...)
#   CAEKF_TARGET_LINKER_SCRIPT
#   CAEKF_TARGET_TEST_FILE_IO  source implementing test_file_open/read/close over semihosting
#
# The port compiles with ${CAEKF_WARNINGS} if defined before the include (else -Wall -Wextra
# -Wpedantic -Werror).
#
# Every executable target of the build is finalized automatically at the end of the top-level
# CMakeLists (cmake_language(DEFER)), so caekf_add_unity_test() and plain add_executable() need no
# change; calling caekf_target_finalize() explicitly is allowed too. Unity is configured for the
# target at the same point: UNITY_OUTPUT_CHAR = caekf_console_putc (semihosting), so the Unity suites
# print through semihosting and their main()'s return value (the failure count) becomes QEMU's exit
# status. add_test(NAME t COMMAND <target>) runs under QEMU through CMAKE_CROSSCOMPILING_EMULATOR.
#
# It also adds the target-only images in tests/target/ (unless CAEKF_TARGET_IMAGES is OFF) and the
# TCG instruction-count plugin (tools/qemu-icount/, built with the host C compiler). The replay image
# links caekf_core by name: the top-level must define it (firmware/core) in the same build.

include_guard(GLOBAL)

if(NOT CMAKE_CROSSCOMPILING)
    message(FATAL_ERROR "cmake/Target.cmake is for the cross builds (toolchain cmake/arm-none-eabi.cmake)")
endif()

get_filename_component(CAEKF_ROOT_DIR "${CMAKE_CURRENT_LIST_DIR}/.." ABSOLUTE)
set(CAEKF_PORT_DIR "${CAEKF_ROOT_DIR}/firmware/port/cortex-m")

enable_language(ASM)

if(NOT CAEKF_QEMU_MACHINE)
    if(CAEKF_MCU STREQUAL "cortex-m7")
        set(CAEKF_QEMU_MACHINE "mps2-an500")
    else()
        set(CAEKF_QEMU_MACHINE "mps2-an386")
    endif()
endif()
set(CAEKF_TARGET_LINKER_SCRIPT "${CAEKF_PORT_DIR}/${CAEKF_QEMU_MACHINE}.ld")
set(CAEKF_QEMU_RUN "${CAEKF_ROOT_DIR}/tools/qemu-run.sh" --machine "${CAEKF_QEMU_MACHINE}")
if(NOT CMAKE_CROSSCOMPILING_EMULATOR)
    set(CMAKE_CROSSCOMPILING_EMULATOR ${CAEKF_QEMU_RUN})
endif()
find_program(CAEKF_ARM_NM NAMES arm-none-eabi-nm REQUIRED)
find_program(CAEKF_ARM_SIZE NAMES arm-none-eabi-size REQUIRED)
find_program(CAEKF_QEMU_SYSTEM_ARM NAMES qemu-system-arm)
if(NOT CAEKF_QEMU_SYSTEM_ARM)
    message(WARNING "qemu-system-arm not found: target tests will fail (tools/bootstrap.sh --arm installs it)")
endif()

# libm after everything else (the core uses sqrt/hypot).
set(CMAKE_C_STANDARD_LIBRARIES "${CMAKE_C_STANDARD_LIBRARIES} -lm")

# ---- the port -----------------------------------------------------------------------------------
add_library(caekf_target_port OBJECT
    "${CAEKF_PORT_DIR}/startup.S"
    "${CAEKF_PORT_DIR}/cm_start.c"
    "${CAEKF_PORT_DIR}/semihost.c"
    "${CAEKF_PORT_DIR}/syscalls.c"
    "${CAEKF_PORT_DIR}/stack.c")
target_include_directories(caekf_target_port PUBLIC "${CAEKF_PORT_DIR}")
set_target_properties(caekf_target_port PROPERTIES C_STANDARD 99 C_EXTENSIONS OFF)
if(DEFINED CAEKF_WARNINGS)
    set(_caekf_port_warnings ${CAEKF_WARNINGS})
else()
    set(_caekf_port_warnings -Wall -Wextra -Wpedantic -Werror)
endif()
target_compile_options(caekf_target_port PRIVATE $<$<COMPILE_LANGUAGE:C>:${_caekf_port_warnings}>)

add_library(caekf_target_runtime INTERFACE)
# The objects themselves (not an archive): the vector table and the newlib hooks must always be
# linked, whatever the link order of libc.
target_link_libraries(caekf_target_runtime INTERFACE
    caekf_target_port $<TARGET_OBJECTS:caekf_target_port>)
target_link_options(caekf_target_runtime INTERFACE
    "-T${CAEKF_TARGET_LINKER_SCRIPT}" "-L${CAEKF_PORT_DIR}")
set_property(TARGET caekf_target_runtime PROPERTY INTERFACE_LINK_DEPENDS
    "${CAEKF_TARGET_LINKER_SCRIPT};${CAEKF_PORT_DIR}/caekf_sections.ld")

# The unit tests' file access on the MCU (tests/unit/support/test_support.h): semihosting.
set(CAEKF_TARGET_TEST_FILE_IO "${CAEKF_ROOT_DIR}/tests/target/test_file_semihost.c")

# Symbols whose presence in an image means a heap.
set(CAEKF_HEAP_SYMBOLS malloc free calloc realloc _malloc_r _free_r _calloc_r _realloc_r
    _sbrk _sbrk_r __malloc_av_ __malloc_sbrk_base nano_malloc)

function(caekf_target_finalize exe)
    get_target_property(_done ${exe} CAEKF_TARGET_FINALIZED)
    if(_done)
        return()
    endif()
    set_target_properties(${exe} PROPERTIES CAEKF_TARGET_FINALIZED TRUE)
    target_link_libraries(${exe} PRIVATE caekf_target_runtime)
    target_link_options(${exe} PRIVATE "-Wl,-Map=$<TARGET_FILE:${exe}>.map")
    add_test(NAME ${exe}.no_heap
        COMMAND "${CMAKE_COMMAND}" "-DNM=${CAEKF_ARM_NM}" "-DIMAGE=$<TARGET_FILE:${exe}>"
                "-DSYMBOLS=${CAEKF_HEAP_SYMBOLS}"
                -P "${CAEKF_ROOT_DIR}/tests/target/check_no_heap.cmake")
    set_tests_properties(${exe}.no_heap PROPERTIES LABELS "target;no_heap" TIMEOUT 30)
endfunction()

# Called once at the end of the top-level CMakeLists: finalize every executable, configure Unity.
function(_caekf_target_finalize_dir dir)
    get_property(_targets DIRECTORY "${dir}" PROPERTY BUILDSYSTEM_TARGETS)
    foreach(_t IN LISTS _targets)
        get_target_property(_type ${_t} TYPE)
        if(_type STREQUAL "EXECUTABLE")
            caekf_target_finalize(${_t})
        endif()
    endforeach()
    get_property(_subdirs DIRECTORY "${dir}" PROPERTY SUBDIRECTORIES)
    foreach(_d IN LISTS _subdirs)
        _caekf_target_finalize_dir("${_d}")
    endforeach()
endfunction()

function(_caekf_target_finalize_all)
    if(TARGET unity)
        get_target_property(_type unity TYPE)
        if(NOT _type STREQUAL "INTERFACE_LIBRARY")
            # Unity's output through the semihosting console (no stdio, hence no heap).
            target_compile_definitions(unity PUBLIC
                "UNITY_OUTPUT_CHAR=caekf_console_putc"
                "UNITY_OUTPUT_CHAR_HEADER_DECLARATION=caekf_console_putc(int)")
        endif()
    endif()
    _caekf_target_finalize_dir("${CMAKE_SOURCE_DIR}")
endfunction()

# ---- instruction-count plugin (host shared object) and the target-only images ---------------------
# tests/target links caekf_core by name (defined later by firmware/core; resolved at generation).
option(CAEKF_TARGET_IMAGES "Build the target-only images and tests of tests/target/" ON)
if(CAEKF_TARGET_IMAGES)
    enable_testing() # before add_subdirectory: a directory's tests exist only if testing was enabled
    add_subdirectory("${CAEKF_ROOT_DIR}/tools/qemu-icount" "${CMAKE_BINARY_DIR}/tools/qemu-icount")
    add_subdirectory("${CAEKF_ROOT_DIR}/tests/target" "${CMAKE_BINARY_DIR}/tests/target")
endif()
add_subdirectory("${CAEKF_PORT_DIR}/can" "${CMAKE_BINARY_DIR}/firmware/port/cortex-m/can") # bxCAN, MCU HAL, caekf_fw images
cmake_language(DEFER DIRECTORY "${CMAKE_SOURCE_DIR}" CALL _caekf_target_finalize_all)
