# The library's public headers: the list users may include as <volcl/...>, staged with their includes rewritten.
# Every header not listed here is internal and is not installed; tests/consumer fails when the installed tree
# holds any other header, or when a listed header does not compile on its own from the installed tree.
set(VOLCL_PUBLIC_HEADERS
  host/Error.hpp
  host/MemoryBudget.hpp
  host/Version.hpp
  host/Volume.hpp
  host/ZeroedBytes.hpp
  host/image/ImageIo.hpp
  host/io/AtomicFile.hpp
  host/io/NiftiMetadata.hpp
  host/io/Series.hpp
  host/io/VolumeIo.hpp
  host/mesh/MeshGenerator.hpp
  host/mesh/MeshIo.hpp
  host/mesh/TetMesh.hpp
  host/phantoms/Phantoms.hpp
  host/render/Bounds.hpp
  host/render/CameraFraming.hpp
  host/render/EffectPlan.hpp
  host/render/Reference.hpp
  host/render/RenderInput.hpp
  host/render/Renderer.hpp
  host/render/Scene.hpp
  host/render/VecMath.hpp
  host/render/VolumeRenderer.hpp
  host/render/grid/GridRenderer.hpp
  host/runtime/ClRuntime.hpp
  host/runtime/HostMemoryPool.hpp
  host/runtime/Timing.hpp
  host/tf/BuiltinPresets.hpp
  host/tf/ColorSpaces.hpp
  host/tf/TransferFunction.hpp
  preintegration/PreintegrationTable.hpp
  wavelet/Codec.hpp
  wavelet/CodecTypes.hpp
  wavelet/DecodeAhead.hpp
  wavelet/LiftingTransform.hpp
  wavelet/Metrics.hpp
  wavelet/VczFormat.hpp
  wavelet/container/VczFormat.hpp
  wavelet/predict/MotionField.hpp
  wavelet/predict/MotionSearch.hpp
  wavelet/transform/LiftingTransform.hpp
  cl/volcl_shared.h)

# Inside the project headers include each other as "host/Volume.hpp"; installed, they sit under
# include/volcl/ and include each other as <volcl/host/Volume.hpp>, so a consumer's include path gains only
# the volcl/ prefix. The staged copies are regenerated when a source header changes.
set(_volcl_staged)
foreach(_header IN LISTS VOLCL_PUBLIC_HEADERS)
  set(_out ${PROJECT_BINARY_DIR}/public-include/volcl/${_header})
  add_custom_command(OUTPUT ${_out}
    COMMAND ${CMAKE_COMMAND} -DIN=${PROJECT_SOURCE_DIR}/${_header} -DOUT=${_out}
            -P ${PROJECT_SOURCE_DIR}/cmake/StagePublicHeader.cmake
    DEPENDS ${PROJECT_SOURCE_DIR}/${_header} ${PROJECT_SOURCE_DIR}/cmake/StagePublicHeader.cmake
    COMMENT "Staging public header volcl/${_header}" VERBATIM)
  list(APPEND _volcl_staged ${_out})
  get_filename_component(_dir ${_header} DIRECTORY)
  install(FILES ${_out} DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/volcl/${_dir})
endforeach()
add_custom_target(volcl_public_headers ALL DEPENDS ${_volcl_staged})
add_dependencies(volcl volcl_public_headers) # building the library is enough for `cmake --install`
# The list for tests/consumer, which compares it with what `cmake --install` put under include/.
set(_volcl_installed_headers ${VOLCL_PUBLIC_HEADERS})
if(TARGET H5Zvolcl)
  list(APPEND _volcl_installed_headers plugins/hdf5/H5Zvolcl.h) # the HDF5 filter's C API (plugins/hdf5)
endif()
string(REPLACE ";" "\n" _volcl_list "${_volcl_installed_headers}")
file(WRITE ${PROJECT_BINARY_DIR}/volcl-public-headers.txt "${_volcl_list}\n")
