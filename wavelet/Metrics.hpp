// Error metrics between two volumes of the same grid (PSNR, RMSE, largest absolute difference).
#pragma once

#include "core/Volume.hpp"

namespace volcl {

/// PSNR of b against a in dB over a's value range (max - min); +inf when equal, NaN for a constant a
/// that differs from b. Throws UsageError when the grids differ.
double psnr(const Volume& a, const Volume& b);
/// Largest absolute voxel difference.
double maxAbsError(const Volume& a, const Volume& b);
/// Root mean square voxel difference.
double rmse(const Volume& a, const Volume& b);

} // namespace volcl
