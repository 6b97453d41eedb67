// Block-matching motion estimation: options, integer search samples, the C++ reference and the OpenCL search.
#pragma once

#include "core/Volume.hpp"
#include "core/runtime/ClRuntime.hpp"
#include "wavelet/predict/MotionField.hpp"

#include <cstdint>
#include <vector>

namespace volcl {

enum class MotionCost : std::uint8_t { Sad, Ssd };
enum class MotionSearchMethod : std::uint8_t {
    Full,        ///< every integer vector in [-R, R]^3
    Hierarchical ///< the coarsest of up to two 2x-downsampled levels first, then +-1 refinement per level;
                 ///< coarse blocks match over at least 4^3 voxels (overlapping their neighbours)
};

/// Block matching parameters. Vectors never exceed `radius` voxels per axis (half-voxel vectors too).
struct MotionSearchOptions {
    std::size_t blockSize = 8; ///< power of two, 2..32
    int radius = 4;            ///< search radius R in voxels, 0..15
    MotionSearchMethod method = MotionSearchMethod::Full;
    MotionCost cost = MotionCost::Ssd;
    bool halfVoxel =
        true; ///< refine the best integer vector by +-1/2 voxel (trilinear samples of the reference)
};

/// Throws UsageError for a block size that is not a power of two in 2..32 or a radius outside 0..15.
void validate(const MotionSearchOptions& o);

/// Number of downsampled levels the hierarchical search uses (0: it degenerates to the full search).
int hierarchyLevels(const MotionSearchOptions& o) noexcept;

/// The exact integer samples the search compares: integer volumes as they are; float volumes mapped
/// linearly from the joint [min, max] of both frames onto 0..65535 and rounded (block matching needs
/// the order of costs, not their unit; integers make the kernel and the reference agree exactly).
/// `levels[0]` is full resolution; level l+1 averages 2x2x2 voxels of level l (rounded; an odd last
/// voxel is paired with itself).
struct MotionSearchSamples {
    std::vector<std::vector<std::int32_t>> current, reference;
    std::vector<Dims> dims;
};
/// Throws DataError when the frames differ in dims or hold NaN/Inf.
MotionSearchSamples prepareSearchSamples(const Volume& current, const Volume& reference, int levels);

/// What the search finds per block: the vector (half-voxel units) and its cost. Costs are in units of
/// (8 x sample)^1 for SAD and (8 x sample)^2 for SSD, so integer and half-voxel costs compare exactly.
struct MotionSearchResult {
    BlockGrid grid;
    std::vector<MotionVector> vectors;
    std::vector<std::uint64_t> costs;
};

/// Plain C++ reference (exact integer arithmetic). Rules shared with the kernel:
/// - the cost of a block sums over its voxels inside the volume (partial border blocks count fewer);
/// - the reference is sampled clamp-to-edge: a vector pointing outside repeats the border voxels;
/// - half-voxel samples are trilinear: the mean of the 1, 2, 4 or 8 voxels around the position;
/// - ties: lower cost, then smaller |x|+|y|+|z|, then smaller (z, y, x) in that order, so a constant
///   frame, or any block whose costs are all equal, gets the zero vector.
MotionSearchResult searchMotionReference(const MotionSearchSamples& s, const MotionSearchOptions& o);

/// Block matching in OpenCL (cl/codec/motion.cl), the same rules and results as the reference, bit for bit.
/// Example:
/// ```
/// volcl::MotionEstimator est(cc, {.blockSize = 8, .radius = 4});
/// volcl::MotionSearchResult r = est.search(cc, frame1, frame0);  // frame1 predicted from frame0
/// ```
class MotionEstimator {
public:
    MotionEstimator(ComputeContext& cc, const MotionSearchOptions& options);
    MotionSearchResult search(ComputeContext& cc, const Volume& current, const Volume& reference);
    MotionSearchResult search(ComputeContext& cc, const MotionSearchSamples& samples);
    /// Kernel time of the last search in milliseconds (profiling events; uploads excluded).
    double lastKernelMilliseconds() const noexcept { return kernelMs_; }
    const MotionSearchOptions& options() const noexcept { return options_; }

private:
    MotionSearchOptions options_;
    cl::Kernel searchKernel_, halfKernel_, reduceKernel_;
    double kernelMs_ = 0;
};

} // namespace volcl
