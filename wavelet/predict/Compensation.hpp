// Overlapped block motion compensation (raised-cosine windows), per-block mode decision, C++ reference and
// OpenCL.
#pragma once

#include "core/Volume.hpp"
#include "core/runtime/ClRuntime.hpp"
#include "wavelet/predict/MotionField.hpp"

#include <array>
#include <optional>
#include <vector>

namespace volcl {

/// Overlap on each side of a block: a quarter of the block (8^3 blocks get 12^3 windows).
constexpr std::size_t overlapFor(std::size_t blockSize) noexcept {
    return blockSize / 4;
}

/// The 1D raised-cosine window of a block of `blockSize` voxels with `overlap` voxels on each side, at
/// window sample t in [0, blockSize + 2 overlap): 1 in the middle, 0.5 (1 - cos(pi (t + 1/2) / (2 overlap)))
/// on the rising edge and its mirror on the falling edge, so two neighbouring windows sum to exactly 1.
double overlapWindow(std::size_t blockSize, std::size_t overlap, std::size_t t) noexcept;

/// Per-axis blending weights over n voxels: voxel x is covered by block `first[x]` with weight `w0[x]`
/// and, when w1[x] > 0, by block first[x] + 1 with weight w1[x]. The weights are the windows divided by
/// their sum at x, so they sum to 1 everywhere, also at the volume's faces where a neighbour is missing.
struct AxisWeights {
    std::vector<int> first;
    std::vector<double> w0, w1;
};
AxisWeights axisWeights(std::size_t n, std::size_t blockSize);

/// Which modes the decision may choose.
struct ModeChoice {
    bool intra = true, zero = true, forward = true, backward = false, bidirectional = false;
};

/// Residual energy (sum of squared differences over the block's own voxels) of each mode's block
/// prediction, indexed by BlockMode; modes not in the choice get +inf.
using ModeCosts = std::array<double, kBlockModeCount>;

/// Builds a motion field from searched vectors: intra values (block means of `current`), per-block mode
/// costs and the cheapest mode. Ties go to the mode needing fewer side bits: Zero, Forward, Backward,
/// Bidirectional, Intra. The decision uses each block's own prediction on its voxels (not the windowed
/// blend, which depends on the neighbours' choices). `backward`/`reference1` only for B frames.
MotionField decideModesReference(const Volume& current, const Volume& reference0, const Volume* reference1,
                                 BlockGrid grid, const std::vector<MotionVector>& forward,
                                 const std::vector<MotionVector>* backward, ModeChoice choice,
                                 std::vector<ModeCosts>* costs = nullptr);

/// The mode with the lowest cost (ties as above).
BlockMode cheapestMode(const ModeCosts& c) noexcept;

/// Overlapped block motion compensation, plain C++ in double: voxel x's prediction is the windowed sum
/// of the predictions of the (up to 8) blocks whose windows cover it, each block predicting with its own
/// mode and vectors (half-voxel vectors: trilinear, clamp-to-edge). Returns Float32.
Volume compensateReference(const MotionField& field, const Volume& reference0, const Volume* reference1);

/// Mode decision and compensation in OpenCL (cl/codec/motion.cl), the same rules as the references above.
/// The kernels work in float: costs agree with the reference to a relative 1e-4, predictions to 1e-5 of
/// the reference frames' value range.
class MotionCompensator {
public:
    explicit MotionCompensator(ComputeContext& cc);
    MotionField decideModes(ComputeContext& cc, const Volume& current, const Volume& reference0,
                            const Volume* reference1, BlockGrid grid,
                            const std::vector<MotionVector>& forward,
                            const std::vector<MotionVector>* backward, ModeChoice choice,
                            std::vector<ModeCosts>* costs = nullptr);
    /// The prediction (Float32). The references are read in their own voxel type.
    Volume compensate(ComputeContext& cc, const MotionField& field, const Volume& reference0,
                      const Volume* reference1);
    /// The decoder's frame, of type `frameType`: the prediction rounded to that type (quantisedPrediction;
    /// with roundPrediction false it stays float) plus `residual` (Float32, the frame's dims), voxel by voxel
    /// as predictedVoxel (wavelet/predict/Residual.hpp), in one kernel pass for blocks of 8 or more. The
    /// references may be of another type than the frame (a Float32 reference moved by a global shift).
    Volume reconstruct(ComputeContext& cc, const MotionField& field, const Volume& reference0,
                       const Volume* reference1, const Volume& residual, ScalarType frameType,
                       bool roundPrediction = true);
    double lastKernelMilliseconds() const noexcept { return kernelMs_; }

private:
    /// The row compensation kernel for references of `type`, and the reconstruction kernel for references
    /// of `type`, frames of `frameType`, prediction rounded or not (each built on first use).
    cl::Kernel& compensateRows(ComputeContext& cc, ScalarType type);
    cl::Kernel& reconstructRows(ComputeContext& cc, ScalarType type, ScalarType frameType,
                                bool roundPrediction);

    cl::Kernel costsKernel_, compensateKernel_;
    std::array<std::optional<cl::Kernel>, 4> compensateRows_;   // indexed by ScalarType
    std::array<std::optional<cl::Kernel>, 32> reconstructRows_; // indexed by (type, frame type, rounding)
    double kernelMs_ = 0;
};

} // namespace volcl
