// Per frame of a compressed-brick render: which bricks the rays can reach, which the transfer function
// hides, and the level each remaining brick is drawn at (render.lod), from the .vcz index alone.
#pragma once

#include "host/tf/TransferFunction.hpp"
#include "render/Scene.hpp"
#include "render/grid/GridDetail.hpp"
#include "wavelet/container/LodStatistics.hpp"
#include "wavelet/container/VczFormat.hpp"

#include <cstddef>
#include <vector>

namespace volcl {

/// What the level choice sees of the scene.
struct BrickView {
    Camera camera;
    int width = 512, height = 512;
    LodMode lod = LodMode::Full;
    double lodError = 0.0;
    std::vector<double> isoValues;
    bool isoOnly = false;
    int tableNodes = 0; ///< pre-integration table nodes (0: point sampling)
    /// Clipping planes of the scene: a brick (grown by the voxel its neighbours' cells reach into) wholly on
    /// the cut side of one is out of the working set, so a clipped region renders with a cache sized for it.
    std::vector<ClipPlane> clipPlanes;
    /// Per brick: 1 when it holds NaN/Inf voxels (empty: none does); with `nanVisible` (the NaN colour has
    /// opacity) the macrocells over such bricks are never empty.
    std::vector<char> nonFinite;
    bool nanVisible = false;
};

/// One frame's bricks. `level[b]` is the level brick b is drawn at, -1 when it is not decoded (no ray reaches
/// it, or the transfer function hides everything it takes part in). `range` is each brick's value range at
/// its chosen level; `standIn` the value a brick that is not decoded reads as (the minimum of its low faces,
/// which every macrocell touching the brick includes in its range).
struct BrickSelection {
    std::vector<int> level;
    std::vector<ValueRange> range;
    std::vector<float> standIn;
    std::vector<double> error;        ///< estimated screen-space error at the chosen level
    grid_detail::MacrocellGrid macro; ///< macrocells over the bricks' ranges (the kernel's skipping)
    std::vector<unsigned char> empty; ///< per macrocell: nothing visible (emptyMacrocells)
    std::size_t reachable = 0, hidden = 0;
};

/// The TF's sensitivity over data values [a, b] for one voxel of world length `h`: the largest change of a
/// segment's opacity, plus of its associated colour, per data unit (infinite across a step of the TF).
double tfSensitivity(const TransferFunction& tf, double a, double b, double h);

/// Estimated screen-space error of brick `b` at `level`: data error (the index's statistics, plus the
/// file's max-error bound) x TF sensitivity over the hull of the brick's level-0 and level-`level` ranges
/// (widened by the coding bound and to the pre-integration table's nodes) x projected size, in pixels, of one
/// level-`level` cell. Level 0 of a lossless file is 0.
double brickError(const VczHeader& h, const LodStatistics* stats, std::size_t frame, std::size_t b, int level,
                  const TransferFunction& tf, const BrickView& view);

/// True when the world box of brick `b` (grown by one voxel) meets the view volume of `view`'s camera.
bool brickReachable(const VczHeader& h, std::size_t b, const BrickView& view);

/// Pixels covered by the bounding rectangle of brick b's projected box (clipped to the image; the whole
/// image when the brick reaches the eye's plane).
double brickPixels(const VczHeader& h, std::size_t b, const BrickView& view);

/// Levels per brick for `view` (all 0 for LodMode::Full; coarser where the estimated error stays at or
/// below lodError for LodMode::Auto; `maxLevel` caps them, 0 for frames that decode at level 0 only), then
/// macrocells and the working set. `forced`, when not empty, gives levels to use instead of choosing.
BrickSelection selectBricks(const VczHeader& h, const LodStatistics* stats, std::size_t frame, int maxLevel,
                            const TransferFunction& tf, const BrickView& view,
                            const std::vector<int>& forced = {});

/// Samples per axis of brick `b` at `level`.
Dims brickSamples(const VczHeader& h, std::size_t b, int level);

} // namespace volcl
