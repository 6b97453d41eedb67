// The gradient cache of the grid ray marcher: built on the device per volume, its C++ reference and decoder.
#pragma once

#include "cl/volcl_shared.h"
#include "core/Volume.hpp"
#include "core/runtime/ClRuntime.hpp"
#include "render/Bounds.hpp"
#include "render/VecMath.hpp"

#include <array>
#include <cstdint>
#include <vector>

namespace volcl {

/// Bytes per voxel of the cache: one 32-bit word in either form (GradientCacheFormat, cl/common/gradient_cache.h).
constexpr std::size_t kGradientCacheBytesPerVoxel = 4;

/// How the words hold a gradient (cl/common/gradient_cache.h).
enum class GradientCacheFormat {
    Octahedral,       ///< 12+12-bit octahedral direction and an 8-bit minifloat norm (any voxel type)
    ExactDifferences, ///< the three integer voxel differences, 10 bits each (integer voxels spanning <= 511)
};

/// ExactDifferences for integer voxels whose values span at most 511 (every difference then fits, so the cache
/// holds the central differences exactly), else Octahedral. `valueSpan`: the volume's max - min.
GradientCacheFormat gradientCacheFormat(ScalarType type, double valueSpan);

/// GRADIENT_CACHE of the trilinear blend for a format (1 octahedral, 3 exact); the nearest voxel's is 2.
int gradientCacheDefine(GradientCacheFormat format);

/// The cache on the device: one word per voxel plus the spare word the trilinear blend's pair loads read.
struct GradientCacheBuffer {
    DeviceBuffer<cl_uint> words;
    double buildMs = 0.0; ///< kernel time of the build
    GradientCacheFormat format = GradientCacheFormat::Octahedral;
};

/// Builds the cache with cl/render/gradient_cache.cl from `voxels` (the volume in its stored type,
/// VOXEL_TYPE `voxelType`); `grid` carries the dims, spacing and gradientMax.
GradientCacheBuffer buildGradientCache(ComputeContext& cc, const cl::Buffer& voxels, int voxelType,
                                       const VolclGridParams& grid,
                                       GradientCacheFormat format = GradientCacheFormat::Octahedral);

/// The kernel's words computed on the host with the same float operations (bit for bit with the kernel
/// when both round alike); no spare word.
std::vector<std::uint32_t>
gradientCacheReference(const Volume& volume, float gradientMax,
                       GradientCacheFormat format = GradientCacheFormat::Octahedral);

/// gcache_pack of cl/common/gradient_cache.h, operation for operation: world gradient g packed against
/// `gradientMax`.
std::uint32_t packGradient(float gx, float gy, float gz, float gradientMax);

/// The word of node (x, y, z) of the float lattice `v` (x fastest, dims `d`): its central-difference world
/// gradient over `step` nodes, one-sided (halved) at the lattice's faces, packed (the kernels' gradient_cache_build
/// and brick_node_gradient). `inv`: 1 / spacing per axis, as float.
std::uint32_t nodeGradientWord(const std::vector<float>& v, const Dims& d, const std::array<float, 3>& inv,
                               std::size_t x, std::size_t y, std::size_t z, float gradientMax,
                               std::size_t step = 1);

/// The cache's scale (VolclGridParams::gradientMax): a bound on the L1 norm of every node's central-difference
/// world gradient, from the value range and spacing.
float gradientCacheScale(const std::array<double, 3>& spacing, const ValueRange& range);

/// One word decoded to the world gradient it stands for (zero for the flat code).
Vec3 unpackGradient(std::uint32_t word, float gradientMax);

/// One word of the exact form decoded to its world gradient on a grid of `spacing`.
Vec3 unpackExactGradient(std::uint32_t word, const Vec3& spacing);

} // namespace volcl
