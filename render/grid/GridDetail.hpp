// Internals of the grid renderer and its reference: value range, macrocells, corner copy, kernel parameters.
#pragma once

#include "cl/volcl_shared.h"
#include "host/tf/TransferFunction.hpp"
#include "render/Bounds.hpp"
#include "render/EffectPlan.hpp"
#include "render/Scene.hpp"

#include <cstddef>
#include <vector>

namespace volcl {
class Volume;
}

namespace volcl::grid_detail {

/// Smallest and largest finite voxel value.
ValueRange valueRange(const Volume& volume);

/// Voxels that are NaN or +/-Inf (0 for integer volumes).
std::size_t nonFiniteCount(const Volume& volume);

/// Min/max per macrocell; cell c covers voxels [c*edge, (c+1)*edge] (shared faces, so every trilinear cell
/// inside it is covered).
struct MacrocellGrid {
    unsigned edge = 8; ///< set by buildMacrocells from the device profile's rayMarch.macrocellEdge
    unsigned nx = 1, ny = 1, nz = 1;
    std::vector<float> min, max;          ///< of the cell's finite voxels (min > max: none is finite)
    std::vector<unsigned char> nonFinite; ///< 1 where the cell holds a NaN/Inf voxel
};
MacrocellGrid buildMacrocells(const Volume& volume, unsigned edge);
/// The grid of `factor`^3 merged cells (edge * factor voxels): each coarse cell's bounds are those of the fine
/// cells it covers, so emptiness stays exact (the coarse cell is empty only where all of them are).
MacrocellGrid coarsenMacrocells(const MacrocellGrid& fine, unsigned factor);

/// 1 for cells where nothing can be seen: tau = 0 over the cell's value range (widened to the table nodes a
/// pre-integration lookup would touch when tableNodes > 0) and no iso-value crossed. `isoOnly`: only
/// iso-surfaces are drawn, so tau does not matter.
/// `nanVisible`: the NaN colour has opacity, so a cell holding a NaN/Inf voxel is never empty.
std::vector<unsigned char> emptyMacrocells(const MacrocellGrid& grid, const TransferFunction& tf,
                                           const std::vector<double>& isoValues, bool isoOnly, int tableNodes,
                                           bool nanVisible = false);

/// Most voxels a uint8 volume may have for the 8-bytes-per-cell copy (cellCorners): 64 Mi voxels, 512 MiB.
constexpr std::size_t kMaxCornerVoxels = std::size_t(1) << 26;

/// For a uint8 volume: the 8 corner values of the trilinear cell at every voxel (x, y, z), in the order
/// (x, y, z), (x+1, y, z), (x, y+1, z), (x+1, y+1, z), then the same at z+1, neighbours clamped to the grid,
/// so the packet kernel fetches a cell with one 8-byte load (CORNER_VOXELS in cl/common/grid_sample.h). Cells
/// are stored in 4x4x4 bricks (brick-major, then z, y, x inside the brick) for cache locality along any ray.
std::vector<unsigned char> cellCorners(const Volume& volume);

/// [a, b] widened to the pre-integration table nodes a lookup of values in [a, b] blends (the domain clamps;
/// tableNodes <= 1: unchanged).
ValueRange tableNodeSpan(const TransferFunction& tf, double a, double b, int tableNodes);

/// Largest tau over [a, b] (exact for the piecewise-linear TF).
double maxExtinctionOver(const TransferFunction& tf, double a, double b);

/// Trilinear interpolation of node-centred values (x fastest, n nodes per axis) at voxel coordinates p,
/// clamped to the grid, with the kernels' cell choice and lerp order (cl/common/grid_sample.h).
double trilinear(const std::vector<float>& values, const std::array<std::size_t, 3>& n, const Vec3& p);

/// Gradient magnitude below which a sample has no defined normal.
double gradientThreshold(const Volume& volume);

/// The grid's geometry and macrocell layout.
VolclGridParams gridParams(const Volume& volume, const MacrocellGrid& grid);
/// The whole parameter block of the grid kernels (cl/render/raymarch.cl); `range` is the volume's value range.
VolclGridRenderParams makeParams(const Scene& scene, const Camera& camera, const Volume& volume,
                                 const ValueRange& range, const TransferFunction& tf, const EffectPlan& plan,
                                 const MacrocellGrid& grid, std::size_t knotCount, int tableLengths);

} // namespace volcl::grid_detail
