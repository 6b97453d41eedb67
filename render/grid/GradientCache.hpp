// The gradient cache of the grid ray marcher: built on the device per volume, its C++ reference and decoder.
#pragma once

#include "cl/volcl_shared.h"
#include "core/runtime/ClRuntime.hpp"
#include "render/VecMath.hpp"

#include <cstdint>
#include <vector>

namespace volcl {

class Volume;

/// Bytes per voxel of the cache: one word, 2x12-bit octahedral direction and an 8-bit minifloat L1 norm
/// (cl/common/gradient_cache.h).
constexpr std::size_t kGradientCacheBytesPerVoxel = 4;

/// The cache on the device: one word per voxel plus the spare word the trilinear blend's pair loads read.
struct GradientCacheBuffer {
    DeviceBuffer<cl_uint> words;
    double buildMs = 0.0; ///< kernel time of the build
};

/// Builds the cache with cl/render/gradient_cache.cl from `voxels` (the volume in its stored type,
/// VOXEL_TYPE `voxelType`); `grid` carries the dims, spacing and gradientMax.
GradientCacheBuffer buildGradientCache(ComputeContext& cc, const cl::Buffer& voxels, int voxelType,
                                       const VolclGridParams& grid);

/// The kernel's words computed on the host with the same float operations (bit for bit with the kernel
/// when both round alike); no spare word.
std::vector<std::uint32_t> gradientCacheReference(const Volume& volume, float gradientMax);

/// One word decoded to the world gradient it stands for (zero for the flat code).
Vec3 unpackGradient(std::uint32_t word, float gradientMax);

} // namespace volcl
