// The preview tiers' host side: the shear-warp factorisation, the run-length-encoded classified volume, the
// transfer-function tables, and the plain C++ references of the shear-warp and discrete ray casting kernels.
#pragma once

#include "cl/render/preview_shared.h"
#include "core/Volume.hpp"
#include "core/runtime/ClRuntime.hpp"
#include "host/image/ImageIo.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/Bounds.hpp"
#include "render/Scene.hpp"

#include <array>
#include <cstddef>
#include <vector>

namespace volcl::preview {

/// The shear-warp factorisation of an orthographic view of a grid (Lacroute and Levoy 1994): the principal
/// axis c (largest component of the view direction in voxel coordinates), slices k = 0 .. nc - 1 along it,
/// each shifted by (shearA k, shearB k) into the intermediate image, and the world distance a ray travels
/// between two slices. Throws UsageError for a perspective camera.
struct ShearWarpFactors {
    int c = 2, a = 0, b = 1;
    bool frontAtZero = true; ///< the ray meets slice 0 first
    int nc = 1, na = 1, nb = 1;
    double shearA = 0.0, shearB = 0.0, offA = 0.0, offB = 0.0;
    int width = 1, height = 1; ///< intermediate image
    double sliceDistance = 1.0;
};
ShearWarpFactors shearWarpFactors(const Volume& volume, const Camera& camera);
/// The kernel's parameter block for `f`, with the TF table's geometry.
VolclShearWarpParams shearWarpParams(const ShearWarpFactors& f, const VolclPreviewTable& table);

/// Which data values the TF makes transparent, in bins over the volume's value range: a range of values is
/// transparent when every bin it touches has tau = 0 everywhere (conservative: it may call a transparent range
/// visible, never the reverse).
class OpacityBins {
public:
    OpacityBins(const TransferFunction& tf, const ValueRange& range, int bins = 4096);
    bool visible(double lo, double hi) const;

private:
    double lo_ = 0.0, scale_ = 1.0;
    std::vector<std::size_t> prefix_; ///< visible bins below each index
};

/// The classified volume for principal axis c, run-length encoded per cell row: the cells (2 x 2 voxels of a
/// slice) whose values the TF makes transparent are left out; each run of visible cells keeps its two voxel
/// rows (n + 1 values each, as floats). Rebuilt when the TF changes; built per principal axis on demand.
struct RunEncoding {
    int c = 2;
    std::vector<cl_uint> rowRuns; ///< nc * (nb - 1) + 1 offsets into runs
    std::vector<cl_uint4> runs;   ///< (first cell, cells, data offset, 0)
    std::vector<float> data;
    std::size_t cells = 0, visibleCells = 0;
};
/// `values`: the volume's voxels as floats (x fastest).
RunEncoding encodeRuns(const std::vector<float>& values, const Dims& dims, int c, const OpacityBins& bins);

/// Table nodes of the preview tiers: enough that linear interpolation between nodes follows any TF closely.
constexpr int kTableNodes = 4096;
/// The TF at kTableNodes nodes over `range` (widened when constant): straight (r, g, b, tau), and its geometry.
std::vector<cl_float4> straightTable(const TransferFunction& tf, const ValueRange& range);
VolclPreviewTable tableGeometry(const ValueRange& range, double earlyTermination);
/// Associated (r a, g a, b a, a) per node for slabs of `distance` (a = 1 - exp(-tau distance)), then the same
/// for half of it (the end slices): the shear-warp kernel's two tables.
std::vector<cl_float4> slabTables(const std::vector<cl_float4>& straight, double distance);

/// The plain C++ references of the two kernels: same factorisation, encoding, tables and compositing, in
/// double precision. Scenes as the preview renderer accepts them (unshaded DVR without effects).
ImageBuffer shearWarpReference(const Volume& volume, const TransferFunction& tf, const Scene& scene);
ImageBuffer discreteRayCastReference(const Volume& volume, const TransferFunction& tf, const Scene& scene);

} // namespace volcl::preview
