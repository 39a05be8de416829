# The estimator core's sources, listed once: firmware/core/CMakeLists.txt builds them for the firmware and
# the host tools, sim/CMakeLists.txt (the Python binding) builds the same files into its two modules.
set(CAEKF_CORE_SOURCES
    ${CMAKE_CURRENT_LIST_DIR}/caekf.c
    ${CMAKE_CURRENT_LIST_DIR}/caekf_filter.c
    ${CMAKE_CURRENT_LIST_DIR}/caekf_linalg.c
    ${CMAKE_CURRENT_LIST_DIR}/caekf_model.c
    ${CMAKE_CURRENT_LIST_DIR}/caekf_settings.c)
