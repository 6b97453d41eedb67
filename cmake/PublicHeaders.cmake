# The library's public headers: the list users may include as <volcl/...>, staged with their includes rewritten.
# Every header not listed here is internal and is not installed; tests/consumer fails when the installed tree
# holds any other header, or when a listed header does not compile on its own from the installed tree.
set(VOLCL_PUBLIC_HEADERS
  core/Error.hpp
  core/MemoryBudget.hpp
  core/Version.hpp
  core/Volume.hpp
  core/Channels.hpp
  core/ZeroedBytes.hpp
  host/image/ImageIo.hpp
  core/AtomicFile.hpp
  host/io/NiftiMetadata.hpp
  host/io/Series.hpp
  host/io/VolumeIo.hpp
  host/mesh/MeshGenerator.hpp
  host/mesh/MeshIo.hpp
  host/mesh/TetMesh.hpp
  host/phantoms/Phantoms.hpp
  render/Bounds.hpp
  render/CameraFraming.hpp
  render/EffectPlan.hpp
  render/Reference.hpp
  render/RenderInput.hpp
  render/RendererBase.hpp
  render/Scene.hpp
  render/VecMath.hpp
  render/VolumeRenderer.hpp
  render/SkipChoice.hpp
  render/grid/GridRenderer.hpp
  core/runtime/ClRuntime.hpp
  core/runtime/DeviceProfile.hpp
  core/runtime/HostMemoryPool.hpp
  core/runtime/Timing.hpp
  host/tf/BuiltinPresets.hpp
  host/tf/ColorSpaces.hpp
  host/tf/TransferFunction.hpp
  preintegration/PreintegrationTable.hpp
  wavelet/Codec.hpp
  wavelet/CodecTypes.hpp
  wavelet/DecodeAhead.hpp
  wavelet/Metrics.hpp
  wavelet/container/VczFormat.hpp
  wavelet/predict/MotionField.hpp
  wavelet/predict/MotionSearch.hpp
  wavelet/transform/LiftingTransform.hpp
  cl/volcl_shared.h)

# Inside the project headers include each other as "core/Volume.hpp" or "host/io/VolumeIo.hpp"; installed,
# they sit under include/volcl/ and include each other as <volcl/core/Volume.hpp> or <volcl/io/VolumeIo.hpp>
# (host/ only groups the data domains in the source tree), so a consumer's include path gains only the volcl/
# prefix. The staged copies are regenerated when a source header changes.
set(_volcl_staged)
set(_volcl_installed_headers)
foreach(_header IN LISTS VOLCL_PUBLIC_HEADERS)
  string(REGEX REPLACE "^host/" "" _installed ${_header})
  list(APPEND _volcl_installed_headers ${_installed})
  set(_out ${PROJECT_BINARY_DIR}/public-include/volcl/${_installed})
  add_custom_command(OUTPUT ${_out}
    COMMAND ${CMAKE_COMMAND} -DIN=${PROJECT_SOURCE_DIR}/${_header} -DOUT=${_out}
            -P ${PROJECT_SOURCE_DIR}/cmake/StagePublicHeader.cmake
    DEPENDS ${PROJECT_SOURCE_DIR}/${_header} ${PROJECT_SOURCE_DIR}/cmake/StagePublicHeader.cmake
    COMMENT "Staging public header volcl/${_header}" VERBATIM)
  list(APPEND _volcl_staged ${_out})
  get_filename_component(_dir ${_installed} DIRECTORY)
  install(FILES ${_out} DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/volcl/${_dir})
endforeach()
add_custom_target(volcl_public_headers ALL DEPENDS ${_volcl_staged})
add_dependencies(volcl volcl_public_headers) # building the library is enough for `cmake --install`
# The list for tests/consumer, which compares it with what `cmake --install` put under include/.
if(TARGET H5Zvolcl)
  list(APPEND _volcl_installed_headers plugins/hdf5/H5Zvolcl.h) # the HDF5 filter's C API (plugins/hdf5)
endif()
string(REPLACE ";" "\n" _volcl_list "${_volcl_installed_headers}")
file(WRITE ${PROJECT_BINARY_DIR}/volcl-public-headers.txt "${_volcl_list}\n")
