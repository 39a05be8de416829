# cmake --install: the estimator core (libcaekf_core, its _names library), the protocol and app libraries,
# the public headers (the generated caekf/caekf_settings_schema.h included), the host tools, and a
# caekfConfig.cmake (+ version file) so that find_package(caekf) works for a user's firmware build.
# Targets are exported as caekf::core, caekf::core_names, caekf::protocol, caekf::app.
include_guard(GLOBAL)
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(CAEKF_INSTALL_CMAKEDIR "${CMAKE_INSTALL_LIBDIR}/cmake/caekf")
set(_caekf_installed caekf_core caekf_core_names)
set_target_properties(caekf_core PROPERTIES EXPORT_NAME core)
set_target_properties(caekf_core_names PROPERTIES EXPORT_NAME core_names)
foreach(t protocol app)
    if(TARGET caekf_${t})
        list(APPEND _caekf_installed caekf_${t})
        set_target_properties(caekf_${t} PROPERTIES EXPORT_NAME ${t})
    endif()
endforeach()
install(TARGETS ${_caekf_installed} EXPORT caekfTargets
        ARCHIVE DESTINATION "${CMAKE_INSTALL_LIBDIR}"
        LIBRARY DESTINATION "${CMAKE_INSTALL_LIBDIR}"
        INCLUDES DESTINATION "${CMAKE_INSTALL_INCLUDEDIR}")
install(DIRECTORY "${PROJECT_SOURCE_DIR}/firmware/include/caekf" "${PROJECT_BINARY_DIR}/generated/core/caekf" # generated: caekf_settings_schema.h, caekf_settings_types.h, caekf_status.h
        DESTINATION "${CMAKE_INSTALL_INCLUDEDIR}" FILES_MATCHING PATTERN "*.h")
foreach(dir firmware/protocol firmware/app)
    if(EXISTS "${PROJECT_SOURCE_DIR}/${dir}/include/caekf")
        install(DIRECTORY "${PROJECT_SOURCE_DIR}/${dir}/include/caekf"
                DESTINATION "${CMAKE_INSTALL_INCLUDEDIR}" FILES_MATCHING PATTERN "*.h")
    endif()
endforeach()
if(TARGET caekf_protocol) # generated from the DBC: caekf_proto_frames.h, caekf_proto_messages.h
    install(DIRECTORY "${PROJECT_BINARY_DIR}/generated/protocol/include/caekf" DESTINATION "${CMAKE_INSTALL_INCLUDEDIR}"
            FILES_MATCHING PATTERN "*.h")
endif()
if(EXISTS "${PROJECT_SOURCE_DIR}/firmware/protocol/caekf.dbc")
    install(FILES "${PROJECT_SOURCE_DIR}/firmware/protocol/caekf.dbc" DESTINATION "${CMAKE_INSTALL_DATADIR}/caekf")
endif()
foreach(tool caekf-replay caekf-bench caekf-truth caekf-reference)
    if(TARGET ${tool})
        install(TARGETS ${tool} RUNTIME DESTINATION "${CMAKE_INSTALL_BINDIR}")
    endif()
endforeach()

install(EXPORT caekfTargets NAMESPACE caekf:: DESTINATION "${CAEKF_INSTALL_CMAKEDIR}")
configure_package_config_file("${CMAKE_CURRENT_LIST_DIR}/caekfConfig.cmake.in"
                              "${PROJECT_BINARY_DIR}/caekfConfig.cmake"
                              INSTALL_DESTINATION "${CAEKF_INSTALL_CMAKEDIR}")
# 0.x: a minor version may break the API.
write_basic_package_version_file("${PROJECT_BINARY_DIR}/caekfConfigVersion.cmake"
                                 VERSION "${PROJECT_VERSION}" COMPATIBILITY SameMinorVersion)
install(FILES "${PROJECT_BINARY_DIR}/caekfConfig.cmake" "${PROJECT_BINARY_DIR}/caekfConfigVersion.cmake"
        DESTINATION "${CAEKF_INSTALL_CMAKEDIR}")
