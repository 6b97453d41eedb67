# Installs the library (versioned SONAME), the curated public headers, the CLI and an exported CMake package.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)
include(${CMAKE_CURRENT_LIST_DIR}/PublicHeaders.cmake)

# 0.x releases may change the ABI with every minor version, so the SONAME carries MAJOR.MINOR.
set_target_properties(volcl PROPERTIES VERSION ${PROJECT_VERSION}
                                       SOVERSION ${PROJECT_VERSION_MAJOR}.${PROJECT_VERSION_MINOR})
# The installed volcl finds libvolcl relative to itself, so an installed tree runs from any prefix without
# LD_LIBRARY_PATH (the linker writes it as RUNPATH). libvolcl needs none: its own dependencies are system
# libraries, and it opens the OpenImageIO module by its full path beside itself (dladdr), which finds
# libvolcl already loaded. (An INSTALL_RPATH on libvolcl would also make CMake pad its build-tree RUNPATH
# with empty entries, which the loader reads as the current directory.)
file(RELATIVE_PATH _volcl_bin_to_lib ${CMAKE_INSTALL_FULL_BINDIR} ${CMAKE_INSTALL_FULL_LIBDIR})
set_target_properties(volcl-cli PROPERTIES INSTALL_RPATH "$ORIGIN/${_volcl_bin_to_lib}")
target_link_options(volcl-cli PRIVATE -Wl,--enable-new-dtags)

install(TARGETS volcl volcl-cli EXPORT volclTargets
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
# The OpenImageIO and OpenVDB modules are loaded from libvolcl's directory at run time (not linked, not exported).
install(TARGETS volcl_oiio volcl_vdb LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
# The OpenVDB reader program is started from there too (host/io/VdbReader.hpp).
install(TARGETS volcl_vdb_reader RUNTIME DESTINATION ${CMAKE_INSTALL_LIBDIR})
install(EXPORT volclTargets NAMESPACE volcl:: DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/volcl)
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/volclConfig.cmake.in
  ${PROJECT_BINARY_DIR}/volclConfig.cmake INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/volcl)
write_basic_package_version_file(${PROJECT_BINARY_DIR}/volclConfigVersion.cmake COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/volclConfig.cmake ${PROJECT_BINARY_DIR}/volclConfigVersion.cmake
  DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/volcl)
