# cmake --install: the SDK a studio builds against (issue 17 item 7).
#   <prefix>/bin/nimbus                      the CLI
#   <prefix>/lib/libnimbus_c.so*             the C ABI (exports nimbus_* only)
#   <prefix>/include/nimbus/                 nimbus.h, nimbus.hpp, nimbus_volume_plugin.h
#   <prefix>/lib/cmake/nimbus/               find_package(nimbus): nimbus::nimbus (the C ABI),
#                                            nimbus::volume_plugin (headers for a procedural)
#   <prefix>/lib/pkgconfig/nimbus.pc         pkg-config nimbus (relocatable: ${pcfiledir})
#   <prefix>/share/nimbus/                   kernels/, shaders/, ocio/config.ocio,
#                                            compare/compare_charts.py: found at run
#                                            time next to bin/ or lib/ (src/core/DataFiles.h)
# Included from the top level after src/ and plugins/ (it names their targets).

install(TARGETS nimbus_cli RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(TARGETS nimbus_c nimbus_abi EXPORT nimbusTargets
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
        INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/nimbus)
set_target_properties(nimbus_abi PROPERTIES EXPORT_NAME volume_plugin)
set_target_properties(nimbus_c PROPERTIES EXPORT_NAME nimbus)
install(FILES ${PROJECT_SOURCE_DIR}/src/abi/nimbus.h ${PROJECT_SOURCE_DIR}/src/abi/nimbus.hpp
              ${PROJECT_SOURCE_DIR}/src/abi/nimbus_volume_plugin.h
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/nimbus)
install(EXPORT nimbusTargets NAMESPACE nimbus:: DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/nimbus)

include(CMakePackageConfigHelpers)
configure_package_config_file(${PROJECT_SOURCE_DIR}/src/abi/nimbusConfig.cmake.in
  ${PROJECT_BINARY_DIR}/nimbusConfig.cmake INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/nimbus)
write_basic_package_version_file(${PROJECT_BINARY_DIR}/nimbusConfigVersion.cmake COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/nimbusConfig.cmake ${PROJECT_BINARY_DIR}/nimbusConfigVersion.cmake
        DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/nimbus)
string(REGEX REPLACE "[^/]+" ".." NIMBUS_PC_TO_PREFIX "${CMAKE_INSTALL_LIBDIR}/pkgconfig")  # lib/pkgconfig -> ../..
configure_file(${PROJECT_SOURCE_DIR}/src/abi/nimbus.pc.in ${PROJECT_BINARY_DIR}/nimbus.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/nimbus.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)

install(DIRECTORY ${PROJECT_SOURCE_DIR}/kernels/ DESTINATION ${CMAKE_INSTALL_DATADIR}/nimbus/kernels)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/shaders/ DESTINATION ${CMAKE_INSTALL_DATADIR}/nimbus/shaders)
install(FILES ${PROJECT_SOURCE_DIR}/src/io/ocio/config.ocio DESTINATION ${CMAKE_INSTALL_DATADIR}/nimbus/ocio)
install(FILES ${PROJECT_SOURCE_DIR}/src/compare/compare_charts.py DESTINATION ${CMAKE_INSTALL_DATADIR}/nimbus/compare)
