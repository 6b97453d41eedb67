// Global sub-voxel translation of a reference frame: the separable Keys-cubic shift (plain C++, shared by the
// codec's global-shift prediction and the synthetic translated series) and its estimation between two frames.
#pragma once

#include "core/Volume.hpp"

#include <array>
#include <cstdint>
#include <vector>

namespace volcl {

/// Shifts `v` (x fastest, dims `d`) in place along `axis` (0 x, 1 y, 2 z) by `shift` voxels: afterwards
/// v(i) holds the old v(i - shift), sampled with the Keys cubic (a = -1/2), clamp-to-edge. Lines along the
/// axis are independent and run on up to `threads` host threads; every voxel's sum is formed in the same
/// order whatever the thread count, so the result does not depend on it.
void keysShiftAxis(std::vector<double>& v, Dims d, int axis, double shift, unsigned threads = 1);

/// `v` moved by `shift` voxels (x, y, z): out(p) = v(p - shift), Keys cubic per axis in x, y, z order,
/// clamp-to-edge; Float32 (not rounded to the voxel type).
Volume cubicShifted(const Volume& v, std::array<double, 3> shift, unsigned threads = 1);

/// A global translation as the motion data stores it: int16 components in 1/kGlobalShiftUnits voxel.
inline constexpr int kGlobalShiftUnits = 32;
/// Largest stored component magnitude in voxels (larger motion is left to the block vectors).
inline constexpr int kGlobalShiftMaxVoxels = 16;
struct GlobalShift {
    std::int16_t x = 0, y = 0, z = 0; ///< content moves by (x, y, z) / kGlobalShiftUnits voxels
    bool zero() const noexcept { return x == 0 && y == 0 && z == 0; }
    std::array<double, 3> voxels() const noexcept {
        return {double(x) / kGlobalShiftUnits, double(y) / kGlobalShiftUnits, double(z) / kGlobalShiftUnits};
    }
    bool operator==(const GlobalShift&) const = default;
};

/// The translation s that best predicts `current` by cubicShifted(reference, s): Gauss-Newton (Lucas-Kanade)
/// steps on the squared difference, started at `start` voxels, each step re-warping the reference, then
/// rounded to the stored units and clamped to kGlobalShiftMaxVoxels. Frames must share dims; values are
/// compared as they are (float).
GlobalShift estimateGlobalShift(const Volume& current, const Volume& reference, std::array<double, 3> start,
                                unsigned threads = 1);

} // namespace volcl
