// The lossy rate strategies' shared stages: one frame's coefficients held once, trials of quantiser steps
// (quantise, reconstruct like the decoder, measure), coded sizes, and the driver common to every lossy mode.
#pragma once

#include "wavelet/quantise/Corrections.hpp"
#include "wavelet/rate/RateStrategy.hpp"
#include "wavelet/transform/LiftingTransform.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

namespace volcl::codec {

struct ErrorStats {
    double sumSq = 0, maxErr = 0;
};

/// The error a voxel may keep: `absolute` plus `relative` times its magnitude, computed in double
/// (--max-error and --rel-error set the first, --pw-rel-error the second, so a zero must come back exactly).
/// A voxel beyond it is stored exactly. Built from a plain number as an absolute bound.
struct VoxelBound {
    double absolute = 0, relative = 0;
    VoxelBound(double absoluteBound) : absolute(absoluteBound) {} // NOLINT(google-explicit-constructor)
    VoxelBound(double absoluteBound, double relativeBound)
        : absolute(absoluteBound), relative(relativeBound) {}
    double at(double value) const noexcept { return absolute + relative * std::abs(value); }
};

/// A quantisation at the header's steps: the voxels to store exactly (with a bound) and the error of the
/// rest.
struct Trial {
    std::vector<std::vector<Correction>> corrections;
    ErrorStats err;
    std::vector<ErrorStats> bricks; ///< err per brick (empty when not reconstructed)
};

/// The payloads of every brick of a frame.
using BrickPayloads = std::vector<std::vector<std::uint8_t>>;

/// One lossy frame's forward-transformed coefficients and the trials a rate search runs on them.
class LossyFrame {
public:
    /// Transforms every brick of `v` (kernel time into `transformMs`, brick ranges into `ranges`).
    LossyFrame(ComputeContext& cc, const CodecOptions& o, const Volume& v, VczHeader& h,
               LiftingTransform<float>& t, const ValueRange& range, CodecProfile* prof, double& transformMs,
               std::vector<std::pair<double, double>>& ranges, const ResidualTarget* target = nullptr);

    /// Sets the header's steps for base step `delta`, raised where a subband's magnitudes would leave the
    /// coder's index range.
    void setDelta(double delta);
    double lastDelta() const noexcept { return lastDelta_; }
    /// Puts back the steps of an earlier trial (the one a search keeps).
    void setSteps(std::vector<double> steps) { h_.steps = std::move(steps); }
    /// The dead-zone edge (in steps) of later trials and of the coding (quantiseRow's `zeroBelow`).
    void setZeroBelow(double edge) noexcept { zeroBelow_ = edge; }
    double zeroBelow() const noexcept { return zeroBelow_; }
    /// Quantises with the header's steps, reconstructs like the decoder and measures the error; with
    /// `bound` it also lists the voxels to store exactly. With `reconstruct` false only the quantisation
    /// runs (the error is NaN). With `only`, just those bricks are reconstructed and measured (a sample
    /// for an estimate: the others' error and corrections stay empty, so such a trial is never coded).
    Trial trial(std::optional<VoxelBound> bound, bool reconstruct = true,
                const std::vector<std::size_t>* only = nullptr);
    /// File size of the frame coded with the trial's corrections; with `payloads` it keeps them.
    std::size_t codedBytes(const Trial& tr, BrickPayloads* payloads);
    /// PSNR over the frame's value range of a trial's error (over the voxels not stored exactly by
    /// setExact).
    double psnrOf(const Trial& tr) const;
    /// Voxels every trial stores exactly, brick by brick in dense order (a frame's NaN/Inf voxels, see
    /// splitNonFinite): listed in each trial's corrections, so coded sizes count them, and left out of
    /// its error. `exact` must outlive the frame.
    void setExact(const std::vector<std::vector<Correction>>* exact, std::size_t count) {
        exact_ = exact;
        exactCount_ = count;
    }

    const VczHeader& header() const noexcept { return h_; }
    /// The voxels the trials are measured against (a residual's frame, else the coded volume).
    const Volume& truth() const noexcept { return target_ ? *target_->frame : v_; }
    double range() const noexcept { return range_.max - range_.min; }
    /// The frame's finite value range (a residual's: its frame's).
    const ValueRange& valueRange() const noexcept { return range_; }
    /// True when the float transform overflowed on some coefficients (voxels near FLT_MAX): they code as 0.
    bool overflowed() const noexcept { return overflowed_; }
    /// Largest voxel magnitude of the frame.
    double maxMagnitude() const noexcept { return std::max(std::abs(range_.min), std::abs(range_.max)); }
    double voxels() const noexcept { return double(v_.voxelCount() - exactCount_); }

private:
    ComputeContext& cc_;
    const CodecOptions& o_;
    const Volume& v_;
    VczHeader& h_;
    LiftingTransform<float>& t_;
    const ValueRange& range_;
    CodecProfile* prof_;
    const ResidualTarget* target_;
    std::vector<std::vector<float>> coeffs_;
    std::vector<double> maxAbs_;
    double lastDelta_ = 0;
    double zeroBelow_ = 1;
    const std::vector<std::vector<Correction>>* exact_ = nullptr;
    std::size_t exactCount_ = 0;
    bool overflowed_ = false;
};

/// What a lossy search chose: the trial kept (its steps left in the header), its base step, and the
/// payloads when the search already coded them (else the driver codes the trial).
struct StepChoice {
    Trial best;
    double delta = 0;
    BrickPayloads payloads;
};

/// The driver of every lossy mode: checks, the direct fixed-step path, the forward transform, a fixed step
/// or the mode's search, the final coding and the report.
class LossyStrategy : public RateStrategy {
public:
    LossyStrategy(ComputeContext& cc, const CodecOptions& o, ValueRangeCache& ranges)
        : cc_(cc), o_(o), ranges_(ranges) {}
    FrameResult encodeFrame(const Volume& v, VczHeader& h, bool chooseStep,
                            const ResidualTarget* target) final;

protected:
    /// The bound the mode holds on every voxel of a frame whose finite values span `finite` (bounded modes).
    virtual std::optional<VoxelBound> voxelBound(const ValueRange& finite) const {
        (void)finite;
        return std::nullopt;
    }
    /// The mode's search for the steps that meet its target on `f`.
    virtual StepChoice search(LossyFrame& f) = 0;
    /// A frame coded at the header's steps (a later frame of a series): the mode may still tune what the
    /// decoder does not need to know, such as the dead-zone edge, starting from trial `c`.
    virtual void refine(LossyFrame&, StepChoice&, const ResidualTarget*) {}
    const CodecOptions& options() const noexcept { return o_; }

private:
    std::optional<FrameResult> encodeDirect(const Volume& v, VczHeader& h, LiftingTransform<float>& t,
                                            std::optional<double> delta);

    ComputeContext& cc_;
    const CodecOptions& o_;
    ValueRangeCache& ranges_;
};

} // namespace volcl::codec
