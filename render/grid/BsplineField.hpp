// Cubic B-spline reconstruction of a grid: padded coefficients (prefiltered to interpolate, or the voxels
// themselves to smooth), the field's value and gradient in double, and its macrocell bounds.
#pragma once

#include "core/Volume.hpp"
#include "render/Bounds.hpp"
#include "render/Scene.hpp"
#include "render/grid/GridDetail.hpp"

#include <array>
#include <cstddef>
#include <vector>

namespace volcl {

/// Coefficients of a grid's cubic B-spline, x fastest, with a margin of one coefficient below and two
/// above each axis (mirror extension of the grid, the boundary the prefilter assumes), so an evaluation at
/// any point of the box reads its 4x4x4 neighbourhood without index clamps. This is the buffer
/// cl/common/grid_sample.h reads under FILTER_BSPLINE.
template <class T> struct BsplineCoefficients {
    std::array<std::size_t, 3> dims{};   ///< the grid's voxels per axis
    std::array<std::size_t, 3> padded{}; ///< dims + 3
    std::vector<T> c;
    std::size_t index(std::size_t i, std::size_t j, std::size_t k) const noexcept {
        return i + padded[0] * (j + padded[1] * k);
    }
};

/// Bytes bsplineCoefficients<T> allocates for `volume` (for the memory budget before the work starts).
std::size_t bsplineCoefficientBytes(const Volume& volume, std::size_t bytesPerCoefficient);

/// The coefficients for `filter` (Cubic: the interpolating spline, computed by the recursive prefilter of
/// Unser, Aldroubi and Eden in double per line; Bspline: the voxels themselves, a smoothing spline), of
/// the volume first smoothed by a Gaussian of `smoothing` voxels (0: none; truncated at 3 sigma, mirror
/// boundary). Throws UsageError for the linear filter or a smoothing outside [0, kMaxSmoothing].
template <class T>
BsplineCoefficients<T> bsplineCoefficients(const Volume& volume, ReconstructionFilter filter,
                                           double smoothing = 0.0);

/// Largest Gaussian smoothing (voxels) the cubic filters accept: a 3-sigma kernel of 49 taps.
constexpr double kMaxSmoothing = 8.0;

/// The volume smoothed by a Gaussian of `smoothing` voxels (as bsplineCoefficients applies it), as float
/// voxels on the same grid: what the linear filter reads when a scene asks for smoothing.
Volume smoothedVolume(const Volume& volume, double smoothing);

/// The spline at voxel coordinates p, clamped to the grid's box [0, n-1] as the trilinear sample is;
/// `gradient`, when given, receives the analytic derivative per voxel unit (zero along a one-voxel axis).
double bsplineValue(const BsplineCoefficients<double>& field, const Vec3& p, Vec3* gradient = nullptr);

/// Min/max of the field per macrocell of `edge` voxels (cell c covers voxels [c*edge, (c+1)*edge], as
/// grid_detail::buildMacrocells): the range of the coefficients that reach into it, which bounds the
/// spline (its weights are non-negative and sum to 1).
grid_detail::MacrocellGrid bsplineMacrocells(const BsplineCoefficients<float>& field, unsigned edge);

} // namespace volcl
