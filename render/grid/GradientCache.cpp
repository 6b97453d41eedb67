// The gradient cache: device build (cl/render/gradient_cache.cl), host reference and decoder.
#include "render/grid/GradientCache.hpp"

#include "core/Volume.hpp"

#include <algorithm>
#include <bit>
#include <cmath>

namespace volcl {
namespace {

constexpr float kOctLevels = 4095.0f;   // GCACHE_OCT_LEVELS
constexpr std::uint32_t kExpBias = 112; // GCACHE_EXP_BIAS

} // namespace

std::uint32_t packGradient(float gx, float gy, float gz, float gMax) {
    const float l1 = std::fabs(gx) + std::fabs(gy) + std::fabs(gz);
    if (!(l1 > 0.0f) || !std::isfinite(l1)) return 0u;
    const float ratio = std::fmin(l1 / gMax, 1.0f);
    const std::uint32_t bits = std::bit_cast<std::uint32_t>(ratio) + (1u << 18);
    const int code = int(bits >> 19) - int(kExpBias << 4);
    if (code < 1) return 0u;
    float px = gx / l1, py = gy / l1;
    if (gz < 0.0f) {
        const float fx = (1.0f - std::fabs(py)) * (px >= 0.0f ? 1.0f : -1.0f);
        const float fy = (1.0f - std::fabs(px)) * (py >= 0.0f ? 1.0f : -1.0f);
        px = fx;
        py = fy;
    }
    const auto u = std::uint32_t(std::nearbyint((px * 0.5f + 0.5f) * kOctLevels));
    const auto v = std::uint32_t(std::nearbyint((py * 0.5f + 0.5f) * kOctLevels));
    return std::min(u, 4095u) | (std::min(v, 4095u) << 12) | (std::uint32_t(std::min(code, 255)) << 24);
}

namespace {

/// The raw differences v[n + step] - v[n - step] along each axis at node (x, y, z) of the lattice `v` (x
/// fastest, dims `d`), clamped to the lattice at its faces: the shared part of both cache forms' words.
std::array<float, 3> nodeDifferences(const std::vector<float>& v, const Dims& d, std::size_t x, std::size_t y,
                                     std::size_t z, std::size_t step) {
    const std::size_t nx = d.x, ny = d.y, nz = d.z, nxy = nx * ny, s = step;
    const std::size_t c = z * nxy + y * nx + x;
    return {v[c - x + std::min(x + s, nx - 1)] - v[c - x + (x >= s ? x - s : 0)],
            v[c - y * nx + std::min(y + s, ny - 1) * nx] - v[c - y * nx + (y >= s ? y - s : 0) * nx],
            v[c - z * nxy + std::min(z + s, nz - 1) * nxy] - v[c - z * nxy + (z >= s ? z - s : 0) * nxy]};
}

/// gcache_pack_exact of the integer central differences at voxel (x, y, z) (one-sided at the faces).
std::uint32_t exactWord(const std::vector<float>& v, const Dims& d, std::size_t x, std::size_t y,
                        std::size_t z) {
    const std::array<float, 3> g = nodeDifferences(v, d, x, y, z, 1);
    std::uint32_t word = 0;
    for (std::size_t a = 0; a < 3; ++a)
        word |= std::uint32_t(std::lround(g[a]) + 512) << (10 * a);
    return word;
}

} // namespace

std::uint32_t nodeGradientWord(const std::vector<float>& v, const Dims& d, const std::array<float, 3>& inv,
                               std::size_t x, std::size_t y, std::size_t z, float gradientMax,
                               std::size_t step) {
    const std::array<float, 3> g = nodeDifferences(v, d, x, y, z, step);
    const float h = 0.5f / float(step);
    return packGradient(g[0] * h * inv[0], g[1] * h * inv[1], g[2] * h * inv[2], gradientMax);
}

float gradientCacheScale(const std::array<double, 3>& spacing, const ValueRange& range) {
    // Each central difference is at most (max - min) / 2 per voxel step (one-sided ones are halved too).
    const double span = range.max > range.min ? range.max - range.min : 1.0;
    double l1 = 0.0;
    for (std::size_t a = 0; a < 3; ++a)
        l1 += 0.5 * span / spacing[a];
    return static_cast<float>(l1 * (1.0 + 1e-6)); // float rounding of the differences stays below it
}

GradientCacheFormat gradientCacheFormat(ScalarType type, double valueSpan) {
    // Integer types of at most 16 bits: their floats, and so the kernel's float differences, are exact.
    const bool integer = type == ScalarType::UInt8 || type == ScalarType::UInt16 || type == ScalarType::Int16;
    return integer && valueSpan <= 511.0 ? GradientCacheFormat::ExactDifferences
                                         : GradientCacheFormat::Octahedral;
}

int gradientCacheDefine(GradientCacheFormat format) {
    return format == GradientCacheFormat::ExactDifferences ? 3 : 1;
}

GradientCacheBuffer buildGradientCache(ComputeContext& cc, const cl::Buffer& voxels, int voxelType,
                                       const VolclGridParams& grid, GradientCacheFormat format) {
    KernelDefines d;
    d.set("VOXEL_TYPE", static_cast<long long>(voxelType));
    if (format == GradientCacheFormat::ExactDifferences) d.set("GCACHE_EXACT", 1LL);
    cl::Kernel k = cc.kernel("render/gradient_cache.cl", "gradient_cache_build", d);
    const std::size_t n = std::size_t(grid.dims[0]) * grid.dims[1] * grid.dims[2];
    GradientCacheBuffer out;
    out.format = format;
    out.words = cc.allocate<cl_uint>(n + 1);
    const cl_uint zero = 0; // the spare word: read with weight 0 by the blend's pair loads
    cc.queue().enqueueWriteBuffer(out.words.get(), CL_TRUE, n * sizeof(cl_uint), sizeof(cl_uint), &zero);
    setArgs(k, voxels, grid, out.words);
    out.buildMs = eventMilliseconds(cc.launch3d(k, grid.dims[0], grid.dims[1], grid.dims[2]));
    return out;
}

std::vector<std::uint32_t> gradientCacheReference(const Volume& volume, float gradientMax,
                                                  GradientCacheFormat format) {
    const bool exact = format == GradientCacheFormat::ExactDifferences;
    const Dims& d = volume.dims();
    const std::vector<float> v = volume.toFloat();
    const std::array<float, 3> inv = {static_cast<float>(1.0 / volume.spacing[0]),
                                      static_cast<float>(1.0 / volume.spacing[1]),
                                      static_cast<float>(1.0 / volume.spacing[2])};
    std::vector<std::uint32_t> out(d.count());
    std::size_t c = 0;
    for (std::size_t z = 0; z < d.z; ++z)
        for (std::size_t y = 0; y < d.y; ++y)
            for (std::size_t x = 0; x < d.x; ++x)
                out[c++] =
                    exact ? exactWord(v, d, x, y, z) : nodeGradientWord(v, d, inv, x, y, z, gradientMax);
    return out;
}

Vec3 unpackGradient(std::uint32_t word, float gradientMax) {
    const std::uint32_t code = word >> 24;
    if (code == 0) return {0, 0, 0};
    const double u = double(word & 0xFFFu) * (2.0 / kOctLevels) - 1.0;
    const double v = double((word >> 12) & 0xFFFu) * (2.0 / kOctLevels) - 1.0;
    const double m = double(std::bit_cast<float>((code + (kExpBias << 4)) << 19)) * gradientMax;
    const double z = 1.0 - std::fabs(u) - std::fabs(v), t = std::max(-z, 0.0);
    return {m * (u - std::copysign(t, u)), m * (v - std::copysign(t, v)), m * z};
}

Vec3 unpackExactGradient(std::uint32_t word, const Vec3& spacing) {
    const auto axis = [&](int shift, std::size_t a) {
        return (double((word >> shift) & 1023u) - 512.0) * 0.5 / spacing[a];
    };
    return {axis(0, 0), axis(10, 1), axis(20, 2)};
}

} // namespace volcl
