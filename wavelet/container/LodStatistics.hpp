// Per-brick, per-level statistics a renderer's level of detail needs: the range of each level's
// approximation and its largest deviation from the full-resolution input, kept in the .vcz header.
#pragma once

#include "core/Volume.hpp"
#include "core/runtime/ClRuntime.hpp"
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
/// render/bricks/BrickField.hpp). Level 0 of a lossy file holds the coding error itself. `faceMin` and
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
/// whose deviation the statistics measure. Calls `fn(j, k, row)` for every row (j, k) of `full`, `row`
/// holding its full.x values.
/// Evaluated separably (x, then y, then z) in the order a + f (b - a) of the full trilinear formula, so each
/// value is the same double the formula gives, at one interpolation per voxel instead of seven.
template <class Fn>
void forEachLevelValue(std::span<const float> coarse, Dims m, Dims full, int level, Fn&& fn) {
    struct Tap {
        std::size_t i0, i1;
        double f;
    };
    const double scale = 1.0 / double(std::size_t(1) << level);
    auto taps = [&](std::size_t count, std::size_t n) {
        std::vector<Tap> t(count);
        for (std::size_t x = 0; x < count; ++x) {
            const double u = std::min(double(x) * scale, double(n - 1));
            const std::size_t i0 = std::min(std::size_t(u), n > 1 ? n - 2 : 0);
            t[x] = {i0, std::min(i0 + 1, n - 1), u - double(i0)};
        }
        return t;
    };
    const std::vector<Tap> tx = taps(full.x, m.x), ty = taps(full.y, m.y), tz = taps(full.z, m.z);
    // Rows interpolated along x for every coarse (j, k), then planes interpolated along y for every coarse k.
    std::vector<double> rowX(m.y * m.z * full.x), planeXY(m.z * full.y * full.x);
    for (std::size_t r = 0; r < m.y * m.z; ++r) {
        const float* c = coarse.data() + r * m.x;
        double* out = rowX.data() + r * full.x;
        for (std::size_t x = 0; x < full.x; ++x) {
            const double a = c[tx[x].i0], b = c[tx[x].i1];
            out[x] = a + tx[x].f * (b - a);
        }
    }
    for (std::size_t k = 0; k < m.z; ++k)
        for (std::size_t y = 0; y < full.y; ++y) {
            const double* a = rowX.data() + (k * m.y + ty[y].i0) * full.x;
            const double* b = rowX.data() + (k * m.y + ty[y].i1) * full.x;
            const double f = ty[y].f;
            double* out = planeXY.data() + (k * full.y + y) * full.x;
            for (std::size_t x = 0; x < full.x; ++x)
                out[x] = a[x] + f * (b[x] - a[x]);
        }
    const std::size_t plane = full.y * full.x;
    std::vector<double> row(full.x);
    for (std::size_t z = 0; z < full.z; ++z) {
        const double f = tz[z].f;
        for (std::size_t y = 0; y < full.y; ++y) {
            const double* a = planeXY.data() + tz[z].i0 * plane + y * full.x;
            const double* b = planeXY.data() + tz[z].i1 * plane + y * full.x;
            for (std::size_t x = 0; x < full.x; ++x)
                row[x] = a[x] + f * (b[x] - a[x]);
            fn(y, z, std::span<const double>(row));
        }
    }
}

/// The statistics of one brick at `level` from its level-`level` samples (`samples`, dims `m`, x fastest)
/// and the input voxels of the brick (`input`, dims `full`, x fastest).
BrickLevelStats brickLevelStats(std::span<const float> samples, Dims m, std::span<const float> input,
                                Dims full, int level);

/// Measures the statistics of `vcz` against the frames it was encoded from (`inputs`, display order).
LodStatistics measureLodStatistics(ComputeContext& cc, const std::vector<std::byte>& vcz,
                                   std::span<const Volume> inputs, const std::string& name);

/// measureLodStatistics, returned as the file with them in its header (payloads unchanged, offsets moved).
std::vector<std::byte> addLodStatistics(ComputeContext& cc, std::vector<std::byte> vcz,
                                        std::span<const Volume> inputs, const std::string& name);

struct CodecOptions;
struct EncodeReport;
struct FrameReport;

/// Encodes `series` (encodeVolume for one frame, else encodeSeries) and adds the statistics. A --bpv target is
/// then a bound on the whole file: when the statistics push it over, the frames are coded again at a budget
/// smaller by what they took. Throws UsageError naming `name` when the statistics alone exceed the budget.
std::vector<std::byte> encodeWithLodStatistics(ComputeContext& cc, const TimeSeries& series,
                                               const CodecOptions& options, const std::string& name,
                                               EncodeReport* report = nullptr,
                                               std::vector<FrameReport>* frames = nullptr);

} // namespace volcl
