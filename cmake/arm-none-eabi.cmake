# cmake/arm-none-eabi.cmake - toolchain file for the Cortex-M targets (bare metal, GNU Arm
# Embedded toolchain from Debian: gcc-arm-none-eabi + libnewlib-arm-none-eabi).
#
#   cmake -S . -B build/cortex-m4f -G Ninja \
#         -DCMAKE_TOOLCHAIN_FILE=cmake/arm-none-eabi.cmake -DCAEKF_MCU=cortex-m4f
# or simply `cmake --preset cortex-m4f` / `cmake --preset cortex-m7`.
#
# CAEKF_MCU selects the core and the QEMU machine that runs the images:
#   cortex-m4f  -mcpu=cortex-m4 -mfpu=fpv4-sp-d16 -mfloat-abi=hard   qemu: mps2-an386
#   cortex-m7   -mcpu=cortex-m7 -mfpu=fpv5-d16    -mfloat-abi=hard   qemu: mps2-an500
#
# Every executable is an .elf image for that machine; CMAKE_CROSSCOMPILING_EMULATOR runs it
# through tools/qemu-run.sh (timeout, semihosting, the guest's exit status as our status), so
# add_test(NAME x COMMAND <target>) runs under QEMU. Startup code, linker script and the
# semihosting console come from cmake/Target.cmake (included by the top-level CMakeLists when
# CMAKE_CROSSCOMPILING).

set(CMAKE_SYSTEM_NAME Generic)
set(CMAKE_SYSTEM_PROCESSOR arm)

set(CAEKF_MCU "cortex-m4f" CACHE STRING "Cortex-M target: cortex-m4f or cortex-m7")
set_property(CACHE CAEKF_MCU PROPERTY STRINGS cortex-m4f cortex-m7)
# try_compile() projects re-read this file: hand them the choice.
list(APPEND CMAKE_TRY_COMPILE_PLATFORM_VARIABLES CAEKF_MCU)

set(_caekf_prefix "arm-none-eabi-")
find_program(CMAKE_C_COMPILER NAMES ${_caekf_prefix}gcc REQUIRED)
find_program(CMAKE_ASM_COMPILER NAMES ${_caekf_prefix}gcc REQUIRED)
# ar/ranlib/objcopy are found by CMake from the compiler's prefix; size and nm are ours.
find_program(CAEKF_ARM_SIZE NAMES ${_caekf_prefix}size)
find_program(CAEKF_ARM_NM NAMES ${_caekf_prefix}nm)

# No OS: configure checks build static libraries instead of linking executables.
set(CMAKE_TRY_COMPILE_TARGET_TYPE STATIC_LIBRARY)
set(CMAKE_EXECUTABLE_SUFFIX ".elf")
set(CMAKE_EXECUTABLE_SUFFIX_C ".elf")
set(CMAKE_EXECUTABLE_SUFFIX_ASM ".elf")

if(CAEKF_MCU STREQUAL "cortex-m4f")
    set(CAEKF_MCU_FLAGS "-mcpu=cortex-m4 -mthumb -mfpu=fpv4-sp-d16 -mfloat-abi=hard")
    set(CAEKF_QEMU_MACHINE "mps2-an386")
elseif(CAEKF_MCU STREQUAL "cortex-m7")
    set(CAEKF_MCU_FLAGS "-mcpu=cortex-m7 -mthumb -mfpu=fpv5-d16 -mfloat-abi=hard")
    set(CAEKF_QEMU_MACHINE "mps2-an500")
else()
    message(FATAL_ERROR "CAEKF_MCU='${CAEKF_MCU}': expected cortex-m4f or cortex-m7")
endif()

# -ffp-contract=off: no fused multiply-add behind the source's back, so the M7 (double, FPv5
#   has VFMA.F64) rounds exactly like the x86-64 host build.
# -fno-math-errno: sqrt() becomes VSQRT; results are unchanged (IEEE sqrt is exact-rounded).
# -fstack-usage + -fcallgraph-info=su: per-function stack (.su) and call graph (.ci) for
#   tools/mcu-stack.py (worst-case stack of the step path).
set(CMAKE_C_FLAGS_INIT
    "${CAEKF_MCU_FLAGS} -ffunction-sections -fdata-sections -ffp-contract=off -fno-math-errno -fstack-usage -fcallgraph-info=su")
set(CMAKE_ASM_FLAGS_INIT "${CAEKF_MCU_FLAGS}")
# nano newlib; our own startup (-nostartfiles: newlib's crt0 would move the stack outside the
# linker script's RAM); no heap (no _sbrk is provided: anything that needs malloc fails to link).
set(CMAKE_EXE_LINKER_FLAGS_INIT "--specs=nano.specs -nostartfiles -Wl,--gc-sections")

# The presets build MinSizeRel (-Os). CMake appends "-Os -DNDEBUG" / "-O3 -DNDEBUG" (Release)
# to these; debug info costs no target memory. tools/mcu-report.py also builds -O2 variants.
set(CMAKE_C_FLAGS_MINSIZEREL_INIT "-g")
set(CMAKE_C_FLAGS_RELEASE_INIT "-g")

# Run target executables under QEMU (ctest, add_test with a target name, CMake's own checks).
get_filename_component(_caekf_root "${CMAKE_CURRENT_LIST_DIR}/.." ABSOLUTE)
set(CMAKE_CROSSCOMPILING_EMULATOR "${_caekf_root}/tools/qemu-run.sh;--machine;${CAEKF_QEMU_MACHINE}")

set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)
unset(_caekf_prefix)
unset(_caekf_root)
