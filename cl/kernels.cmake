# Every OpenCL C file is listed here and embedded into the library as a string at build time (included
# from the top-level CMakeLists so the generating rule lives in the directory of the volcl target). A file
# is embedded under its path relative to cl/ ("common/shading.h"); `#include "x.h"` in a kernel resolves
# against the including file's folder first, then against cl/, as a C compiler with -I cl would.
set(VOLCL_KERNEL_FILES
  volcl_shared.h
  common/camera_rays.h
  common/shading.h
  common/iso_crossings.h
  common/tf_lookup.h
  common/grid_sample.h
  common/gradient_cache.h
  common/fog.h
  common/counter_rng.h
  common/light_volume.h
  common/labels.h
  phantoms/phantoms.cl
  common/copy.cl
  render/tf_sample.cl
  render/raymarch_iso.h
  render/raymarch_iso_sampled.h
  render/raymarch.cl
  render/gradient_cache.cl
  render/raymarch_plain.cl
  render/raymarch_channels.cl
  render/channels_shared.h
  render/preview_shared.h
  render/preview_table.h
  render/shearwarp.cl
  render/drc.cl
  render/pathtrace.cl
  render/light_volume.cl
  common/brick_sample.h
  common/brick_gradient_cache.h
  render/raymarch_bricks.cl
  render/light_volume_bricks.cl
  render/brick_gradient_cache.cl
  codec/lifting_common.h
  codec/lifting.cl
  codec/lifting_brick.cl
  preint/preint.cl
  mesh/mesh_cells.cl
  codec/motion.cl
  mesh/radix_sort.cl
  mesh/mesh_kbuffer_shared.h
  mesh/mesh_tile.h
  mesh/mesh_kbuffer.cl
  mesh/mesh_pt.cl
)
list(TRANSFORM VOLCL_KERNEL_FILES PREPEND ${PROJECT_SOURCE_DIR}/cl/ OUTPUT_VARIABLE _kernel_paths)
list(JOIN _kernel_paths "|" _kernel_paths_joined)
set(_generated ${PROJECT_BINARY_DIR}/generated/EmbeddedKernels.cpp)
add_custom_command(
  OUTPUT ${_generated}
  COMMAND ${CMAKE_COMMAND} -DOUTPUT=${_generated} "-DINPUTS=${_kernel_paths_joined}"
          -DBASE=${PROJECT_SOURCE_DIR}/cl
          -P ${PROJECT_SOURCE_DIR}/cmake/EmbedKernels.cmake
  DEPENDS ${_kernel_paths} ${PROJECT_SOURCE_DIR}/cmake/EmbedKernels.cmake
  COMMENT "Embedding OpenCL kernels"
  VERBATIM)
target_sources(volcl PRIVATE ${_generated})
