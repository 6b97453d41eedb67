# Installs the library, its headers, the CLI and an exported CMake package (volcl::volcl).
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

install(TARGETS volcl volcl-cli EXPORT volclTargets
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
# Public headers keep their folder layout under include/volcl so `#include "host/Volume.hpp"` works
# the same inside the project and for consumers.
foreach(_dir host preintegration wavelet cl)
  install(DIRECTORY ${PROJECT_SOURCE_DIR}/${_dir}/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/volcl/${_dir}
          FILES_MATCHING PATTERN "*.hpp" PATTERN "*.h" PATTERN "cli" EXCLUDE)
endforeach()
# The OpenImageIO module is loaded from libvolcl's directory at run time (not linked, not exported).
install(TARGETS volcl_oiio LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
install(EXPORT volclTargets NAMESPACE volcl:: DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/volcl)
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/volclConfig.cmake.in
  ${PROJECT_BINARY_DIR}/volclConfig.cmake INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/volcl)
write_basic_package_version_file(${PROJECT_BINARY_DIR}/volclConfigVersion.cmake COMPATIBILITY SameMajorVersion)
install(FILES ${PROJECT_BINARY_DIR}/volclConfig.cmake ${PROJECT_BINARY_DIR}/volclConfigVersion.cmake
  DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/volcl)
