# The estimator core's sources, listed once: firmware/core/CMakeLists.txt builds them for the firmware and
# the host tools, sim/CMakeLists.txt (the Python binding) builds the same files into its two modules.
# CAEKF_GEN_CORE is where caekf_codegen(... c-core ...) wrote the schema's tables (cmake/CaekfCodegen.cmake).
set(CAEKF_CORE_SOURCES
    ${CMAKE_CURRENT_LIST_DIR}/caekf.c
    ${CMAKE_CURRENT_LIST_DIR}/caekf_filter.c
    ${CMAKE_CURRENT_LIST_DIR}/caekf_kernels.c
    ${CMAKE_CURRENT_LIST_DIR}/caekf_linalg.c
    ${CMAKE_CURRENT_LIST_DIR}/caekf_model.c
    ${CMAKE_CURRENT_LIST_DIR}/caekf_sensors.c
    ${CMAKE_CURRENT_LIST_DIR}/caekf_settings.c
    ${CAEKF_GEN_CORE}/caekf_settings_table.c)
# Names of statuses, flags, settings and keys, and the text of a refusal: for hosts, logs and tools, in a library of their
# own (<core>_names) so the estimator carries no strings. The text formats with snprintf, which would
# pull newlib's allocator into an MCU image: hosts only.
set(CAEKF_NAMES_SOURCES ${CAEKF_GEN_CORE}/caekf_settings_names.c)
if(NOT CMAKE_CROSSCOMPILING)
    list(APPEND CAEKF_NAMES_SOURCES ${CMAKE_CURRENT_LIST_DIR}/caekf_settings_text.c)
endif()
