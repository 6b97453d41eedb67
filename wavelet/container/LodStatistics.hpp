// Per-brick, per-level statistics a renderer's level of detail needs: the range of each level's
// approximation and its largest deviation from the full-resolution input, kept in the .vcz header.
#pragma once

#include "host/Volume.hpp"
#include "host/runtime/ClRuntime.hpp"
#include "wavelet/container/VczFormat.hpp"

#include <algorithm>
#include <cstddef>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace volcl {

/// Metadata key of the statistics (binary: see LodStatistics::serialise). Files without it are read as
/// before; renderers then treat every level above 0 as of unknown error.
inline constexpr std::string_view kVczLodKey = "volcl:lod";

/// One brick at one level: the range of its samples and the largest |approximation - input| over the
/// brick's full-resolution voxels, where the approximation at voxel x is the trilinear interpolation of the
/// level's samples at (x - origin) / 2^level, clamped to the brick's last sample (the brick renderer's rule,
/// host/render/bricks/BrickField.hpp). Level 0 of a lossy file holds the coding error itself. `faceMin` and
/// `faceMax` are the range of the samples on the brick's three low faces (x, y or z index 0): the only ones a
/// neighbour's trilinear cells read.
/// `rms` is the root mean square of the same deviation.
struct BrickLevelStats {
    float min = 0, max = 0, error = 0, rms = 0, faceMin = 0, faceMax = 0;
};

/// Statistics of every I frame: `frames[f]` is empty for P/B frames (they decode at level 0 only), else
/// brickCount * (levels + 1) entries, brick-major.
struct LodStatistics {
    int levels = 0;
    std::vector<std::vector<BrickLevelStats>> frames;

    const BrickLevelStats& at(std::size_t frame, std::size_t brick, int level) const {
        return frames[frame][brick * std::size_t(levels + 1) + std::size_t(level)];
    }
    bool has(std::size_t frame) const noexcept { return frame < frames.size() && !frames[frame].empty(); }
    /// Little-endian bytes: levels (u32), frame count (u32), per frame an entry count (u32) and 6 float32
    /// per entry (min, max, error, rms, faceMin, faceMax).
    std::string serialise() const;
    /// The statistics stored in `h`, if any. Throws IoError naming `name` when they do not match the header.
    static std::optional<LodStatistics> fromHeader(const VczHeader& h, const std::string& name);
};

/// The value of a brick's level-`level` approximation (`coarse`, `m` samples, x fastest) at every voxel of
/// its full-resolution extent `full`: trilinear between the coarse samples at voxel position / 2^level (the
/// last interval extended to the brick's end). This is the field the brick renderer samples and the level
/// whose deviation the statistics measure. Calls `fn(i, j, k, value)` with i fastest.
template <class Fn>
void forEachLevelValue(std::span<const float> coarse, Dims m, Dims full, int level, Fn&& fn) {
    const double scale = 1.0 / double(std::size_t(1) << level);
    auto axis = [&](std::size_t x, std::size_t n, std::size_t& i0, std::size_t& i1, double& f) {
        const double u = std::min(double(x) * scale, double(n - 1));
        i0 = std::min(std::size_t(u), n > 1 ? n - 2 : 0);
        i1 = std::min(i0 + 1, n - 1);
        f = u - double(i0);
    };
    auto at = [&](std::size_t i, std::size_t j, std::size_t k) { return double(coarse[(k * m.y + j) * m.x + i]); };
    for (std::size_t z = 0; z < full.z; ++z) {
        std::size_t z0, z1;
        double fz;
        axis(z, m.z, z0, z1, fz);
        for (std::size_t y = 0; y < full.y; ++y) {
            std::size_t y0, y1;
            double fy;
            axis(y, m.y, y0, y1, fy);
            for (std::size_t x = 0; x < full.x; ++x) {
                std::size_t x0, x1;
                double fx;
                axis(x, m.x, x0, x1, fx);
                auto lx = [&](std::size_t j, std::size_t k) { return at(x0, j, k) + fx * (at(x1, j, k) - at(x0, j, k)); };
                const double c0 = lx(y0, z0) + fy * (lx(y1, z0) - lx(y0, z0));
                const double c1 = lx(y0, z1) + fy * (lx(y1, z1) - lx(y0, z1));
                fn(x, y, z, c0 + fz * (c1 - c0));
            }
        }
    }
}

/// The statistics of one brick at `level` from its level-`level` samples (`samples`, dims `m`, x fastest)
/// and the input voxels of the brick (`input`, dims `full`, x fastest).
BrickLevelStats brickLevelStats(std::span<const float> samples, Dims m, std::span<const float> input,
                                Dims full, int level);

/// Measures the statistics of `vcz` against the frames it was encoded from (`inputs`, display order) and
/// returns the file with them in its header (payloads unchanged, offsets moved).
std::vector<std::byte> addLodStatistics(ComputeContext& cc, std::vector<std::byte> vcz,
                                        std::span<const Volume> inputs, const std::string& name);

} // namespace volcl
