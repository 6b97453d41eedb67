// The rate stage: rate control as a strategy that drives the transform, quantise and payload stages for one
// frame, one strategy per mode (lossless, max-error, psnr, bpv).
#pragma once

#include "core/runtime/ClRuntime.hpp"
#include "wavelet/Codec.hpp"
#include "wavelet/RangeScan.hpp"
#include "wavelet/container/FrameAssembly.hpp"

#include <memory>

namespace volcl::codec {

/// One coded frame and what its encoding measured.
struct FrameResult {
    CodedFrame coded;
    EncodeReport report;
    /// Per brick, the sum of squared errors and the largest error the report's figures add up (empty when
    /// the rate control did not reconstruct the frame).
    std::vector<std::pair<double, double>> brickErrors;
};

/// A predicted frame's residual is coded against the frame it reconstructs: error bounds and PSNR are
/// measured on predictedVoxel(prediction, decoded residual) against `frame`, and voxels stored exactly
/// hold the frame's values (the decoder applies them after adding the prediction).
struct ResidualTarget {
    const Volume* frame = nullptr;
    const Volume* prediction = nullptr; ///< Float32
};

class RateStrategy {
public:
    virtual ~RateStrategy() = default;
    /// Codes the signal of one frame (what the predictor hands on: the frame itself for an I frame) with
    /// the header's transform and entropy settings. With `chooseStep` the mode's search sets h.steps (the
    /// first frame of a file); without, the header's steps are kept (later frames share one header).
    /// `target` is set when `v` is a residual (lossless strategies need nothing of it: residuals are exact).
    virtual FrameResult encodeFrame(const Volume& v, VczHeader& h, bool chooseStep,
                                    const ResidualTarget* target) = 0;
};

/// The strategy for the header's mode: lossless integer lifting, lossless raw bits (float voxels),
/// max-error, psnr or bpv. `ranges` caches the value range of the frame being coded.
std::unique_ptr<RateStrategy> makeRateStrategy(ComputeContext& cc, const CodecOptions& o, const VczHeader& h,
                                               ValueRangeCache& ranges);

} // namespace volcl::codec
