# ctest install_find_package: installs the build tree BUILD_DIR into a temporary prefix, builds the
# example firmware (this folder) against it with find_package(caekf), and runs it.
#   cmake -DBUILD_DIR=... -DWORK_DIR=... -DGENERATOR=... -DC_COMPILER=... [-DC_FLAGS=... -DLINKER_FLAGS=...]
#         -P run.cmake   (the flags: the build's, e.g. the sanitizers of host-asan)
foreach(v BUILD_DIR WORK_DIR GENERATOR C_COMPILER)
    if(NOT DEFINED ${v})
        message(FATAL_ERROR "run.cmake: ${v} is required")
    endif()
endforeach()
file(REMOVE_RECURSE "${WORK_DIR}")
set(prefix "${WORK_DIR}/prefix")
function(run)
    execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
    if(NOT rc EQUAL 0)
        message(FATAL_ERROR "failed (${rc}): ${ARGN}\n${out}")
    endif()
    message(STATUS "${out}")
endfunction()
run("${CMAKE_COMMAND}" --install "${BUILD_DIR}" --prefix "${prefix}")
foreach(f include/caekf/caekf.h include/caekf/caekf_settings_schema.h include/caekf/caekf_app.h
          include/caekf/caekf_proto.h lib/cmake/caekf/caekfConfig.cmake lib/cmake/caekf/caekfConfigVersion.cmake)
    if(NOT EXISTS "${prefix}/${f}")
        message(FATAL_ERROR "not installed: ${f}")
    endif()
endforeach()
run("${CMAKE_COMMAND}" -S "${CMAKE_CURRENT_LIST_DIR}" -B "${WORK_DIR}/build" -G "${GENERATOR}"
    "-DCMAKE_PREFIX_PATH=${prefix}" -DCMAKE_BUILD_TYPE=Release "-DCMAKE_C_COMPILER=${C_COMPILER}"
    "-DCMAKE_C_FLAGS=${C_FLAGS}" "-DCMAKE_EXE_LINKER_FLAGS=${LINKER_FLAGS}")
run("${CMAKE_COMMAND}" --build "${WORK_DIR}/build")
run("${WORK_DIR}/build/example_firmware")
file(REMOVE_RECURSE "${WORK_DIR}")
