// Synthetic motion: a time series made by translating one volume by a constant sub-voxel step per frame.
#pragma once

#include "core/Volume.hpp"

#include <array>

namespace volcl {

/// Frame k is `base` moved by k * `shiftPerFrame` voxels (content at x moves to x + k s), resampled with the
/// separable Keys cubic (a = -1/2) and clamp-to-edge outside the volume; integer types are rounded and
/// clamped to their range. Frame 0 equals `base`. Used by the motion tests and benchmarks as a series
/// whose true motion is known.
TimeSeries translatedSeries(const Volume& base, std::size_t frames, std::array<double, 3> shiftPerFrame);

} // namespace volcl
