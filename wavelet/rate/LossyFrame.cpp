// The lossy rate strategies' shared stages and their common driver.
#include "wavelet/rate/LossyFrame.hpp"

#include "core/Error.hpp"
#include "core/runtime/ParallelFor.hpp"
#include "wavelet/BrickVoxels.hpp"
#include "wavelet/payload/BrickPayload.hpp"
#include "wavelet/predict/Residual.hpp"
#include "wavelet/quantise/Quantiser.hpp"
#include "wavelet/transform/BrickTransform.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>

namespace volcl::codec {

LossyFrame::LossyFrame(ComputeContext& cc, const CodecOptions& o, const Volume& v, VczHeader& h,
                       LiftingTransform<float>& t, const ValueRange& range, CodecProfile* prof,
                       double& transformMs, std::vector<std::pair<double, double>>& ranges,
                       const ResidualTarget* target)
    : cc_(cc), o_(o), v_(v), h_(h), t_(t), range_(range), prof_(prof), target_(target),
      coeffs_(h.brickCount()) {
    const std::size_t nsub = 1 + 7 * std::size_t(h.levels);
    std::vector<std::int32_t> brickMax(h.brickCount() * nsub, 0);
    std::atomic<bool> overflowed = false;
    forwardBricks<float>(cc_, t, v, h, o_.threads, prof, transformMs, &ranges, &CodecProfile::gather,
                         [&](std::size_t b, const float* c, std::size_t pitch) {
                             coeffs_[b] = denseBrick(h.brickDims(b), c, pitch);
                             // Finite voxels near FLT_MAX overflow the float transform: such coefficients
                             // code as 0, and the voxels they leave wrong fail a trial's bound (stored
                             // exactly) or its PSNR.
                             for (float& x : coeffs_[b])
                                 if (!std::isfinite(x)) {
                                     x = 0;
                                     overflowed = true;
                                 }
                             subbandMaxAbs(h, h.brickDims(b), coeffs_[b].data(), h.brickDims(b).x,
                                           &brickMax[b * nsub]);
                         });
    maxAbs_ = mergeMaxima(brickMax, nsub);
    overflowed_ = overflowed;
}

void LossyFrame::setDelta(double delta) {
    lastDelta_ = delta;
    h_.steps = subbandSteps(h_.wavelet, h_.levels, delta);
    // Keeps quantisation indices inside the coder's range for data of huge dynamic range, and the
    // quantiser's reciprocal step finite for data of tiny magnitudes.
    for (std::size_t i = 0; i < h_.steps.size(); ++i)
        h_.steps[i] = std::max({h_.steps[i], maxAbs_[i] / (kMaxQuantIndex - 2), kMinStep});
}

Trial LossyFrame::trial(std::optional<VoxelBound> bound, bool reconstruct,
                        const std::vector<std::size_t>* only) {
    const Volume& v = v_;
    const VczHeader& h = h_;
    const std::vector<std::vector<float>>& coeffs = coeffs_;
    CodecProfile* prof = prof_;
    Trial tr;
    const std::size_t n = coeffs.size();
    tr.corrections.resize(n);
    ++(only ? prof->sampleTrials : prof->trials);
    if (!reconstruct) {
        tr.err.sumSq = tr.err.maxErr = std::numeric_limits<double>::quiet_NaN();
        if (exact_) tr.corrections = *exact_;
        return tr;
    }
    timeStage(prof, &CodecProfile::reconstruct, [&] {
        std::vector<ErrorStats> es(n);
        inverseBricks(
            cc_, t_, h, only ? *only : allBricks(h), 0, o_.threads, nullptr,
            {{&CodecProfile::reconstruct,
              [&](std::size_t b, float* dst, std::size_t pitch) {
                  requantiseInto(h, h.brickDims(b), coeffs[b].data(), dst, pitch, zeroBelow_);
              }}},
            &CodecProfile::reconstruct, [&](std::size_t b, const float* rec, std::size_t pitch) {
                const Dims o = h.brickOrigin(b), d = h.brickDims(b);
                double sumSq = 0, maxErr = 0;
                const std::vector<Correction>* exact = exact_ ? &(*exact_)[b] : nullptr;
                std::size_t nextExact = 0;
                // A residual is measured on the frame it reconstructs (prediction + decoded residual), and
                // its stored voxels hold the frame's values.
                const Volume& truth = target_ ? *target_->frame : v;
                const float* pred = target_ ? target_->prediction->values<float>().data() : nullptr;
                visitTyped(truth, [&](auto span) {
                    using V = std::remove_const_t<typename decltype(span)::element_type>;
                    for (std::size_t z = 0; z < d.z; ++z)
                        for (std::size_t y = 0; y < d.y; ++y) {
                            const std::size_t at = v.index(o.x, o.y + y, o.z + z);
                            const V* in = span.data() + at;
                            const float* p = pred ? pred + at : nullptr;
                            const float* r = rec + (z * d.y + y) * pitch;
                            for (std::size_t x = 0; x < d.x; ++x) {
                                const auto at = static_cast<std::uint32_t>((z * d.y + y) * d.x + x);
                                if (exact && nextExact < exact->size() && (*exact)[nextExact].index == at) {
                                    tr.corrections[b].push_back((*exact)[nextExact++]);
                                    continue;
                                }
                                const double orig = double(in[x]);
                                const V decoded = p ? predictedVoxel<V>(p[x], r[x]) : toVoxel<V>(r[x]);
                                // A prediction or reconstruction beyond float's range (Inf - Inf) is
                                // as wrong as can be: never NaN, which every bound would let through.
                                double e = std::abs(double(decoded) - orig);
                                if (std::isnan(e)) e = std::numeric_limits<double>::infinity();
                                if (bound && e > bound->at(orig)) {
                                    tr.corrections[b].push_back({at, orig});
                                    continue;
                                }
                                sumSq += e * e;
                                maxErr = std::max(maxErr, e);
                            }
                        }
                });
                es[b] = {sumSq, maxErr};
            });
        for (const auto& e : es) {
            tr.err.sumSq += e.sumSq;
            tr.err.maxErr = std::max(tr.err.maxErr, e.maxErr);
        }
        tr.bricks = std::move(es);
    });
    return tr;
}

// Quantises each brick into a per-thread index array (reused, cache-resident) and codes it.
std::size_t LossyFrame::codedBytes(const Trial& tr, BrickPayloads* payloads) {
    const VczHeader& h = h_;
    const std::vector<std::vector<float>>& coeffs = coeffs_;
    CodecProfile* prof = prof_;
    std::vector<std::vector<std::uint8_t>> p(coeffs.size());
    timeStage(prof, &CodecProfile::entropy, [&] {
        parallelFor(p.size(), o_.threads, [&](std::size_t b) {
            thread_local std::vector<std::int32_t> q;
            const Dims d = h.brickDims(b);
            q.resize(d.count());
            quantiseInto(h, d, coeffs[b].data(), d.x, q.data(), zeroBelow_);
            p[b] = buildPayload(h, d, q, tr.corrections[b]);
        });
    });
    // The preamble's varint sizes and steps form change with the trial. A single volume's is this trial's,
    // its brick ranges bounded by the voxel type's; a series frame's, whose later frames are not coded yet,
    // the bound for any payload sizes.
    std::size_t total = 0;
    if (h.frames.size() == 1) {
        VczHeader sized = h;
        sized.bricks.assign(1, std::vector<VczBrickEntry>(p.size()));
        for (std::size_t b = 0; b < p.size(); ++b)
            sized.bricks[0][b].size = p[b].size();
        total = vczPreambleBound(sized, true);
    } else {
        total = vczPreambleBound(h);
    }
    for (const auto& x : p)
        total += x.size();
    if (payloads) *payloads = std::move(p);
    return total;
}

double LossyFrame::psnrOf(const Trial& tr) const {
    const double mse = tr.err.sumSq / voxels(), r = range();
    return mse == 0 ? std::numeric_limits<double>::infinity() : 10 * std::log10(r * r / mse);
}

FrameResult LossyStrategy::encodeFrame(const Volume& v, VczHeader& h, bool chooseStep,
                                       const ResidualTarget* target) {
    // A residual's PSNR is the frame's, over the frame's value range.
    const ValueRange& st = ranges_.of(target ? *target->frame : v);
    // NaN/Inf voxels are stored exactly as corrections and the wavelet codes a smooth fill in their place.
    NonFiniteSplit split;
    if (st.nonFinite) {
        if (target)
            throw DataError("predicted frames need finite voxels (found NaN/Inf): use --motion none to code "
                            "every frame as an intra frame, or --lossless");
        split = splitNonFinite(v, h);
    }
    const Volume& coded = split.count ? split.filled : v;
    LiftingTransform<float> t(cc_, h.wavelet);
    if (o_.step && chooseStep && (!(*o_.step > 0) || !std::isfinite(*o_.step)))
        throw UsageError("the quantiser step must be a positive number");
    // The direct path codes no corrections: frames with NaN/Inf voxels take the trial path.
    const std::optional<VoxelBound> bound = voxelBound(st);
    if ((!chooseStep || o_.step) && !bound && !o_.measureError && !split.count)
        if (std::optional<FrameResult> r = encodeDirect(v, h, t, chooseStep ? o_.step : std::nullopt))
            return std::move(*r);
    FrameResult r;
    LossyFrame f(cc_, o_, coded, h, t, st, &r.report.profile, r.report.transformMs, r.coded.ranges, target);
    if (split.count) f.setExact(&split.exact, split.count);
    if (o_.step && chooseStep) {
        f.setDelta(*o_.step);
        chooseStep = false;
    }
    StepChoice c;
    if (!chooseStep) {
        c.delta = f.lastDelta();
        c.best = f.trial(bound, bound.has_value() || o_.measureError);
        refine(f, c, target);
    } else {
        c = search(f);
    }
    if (c.payloads.empty()) f.codedBytes(c.best, &c.payloads);
    r.coded.payloads = std::move(c.payloads);
    r.report.step = c.delta;
    std::size_t corr = 0;
    for (const auto& cs : c.best.corrections)
        corr += cs.size();
    r.report.corrections = corr;
    r.report.maxError = c.best.err.maxErr;
    r.report.psnr = f.psnrOf(c.best);
    for (const ErrorStats& e : c.best.bricks)
        r.brickErrors.emplace_back(e.sumSq, e.maxErr);
    return r;
}

// A fixed step whose error is not wanted (CodecOptions::step or a series frame reusing the first frame's
// steps, with measureError off and no bound): each brick is quantised and coded straight from the mapped
// batch, with no coefficient copy and no index array. `delta` sets the steps (else the header's are
// kept). Returns nothing, having coded in vain, when a subband's magnitudes need a larger step than
// `delta` gives (data of huge dynamic range; LossyFrame::setDelta raises such steps).
std::optional<FrameResult> LossyStrategy::encodeDirect(const Volume& v, VczHeader& h,
                                                       LiftingTransform<float>& t,
                                                       std::optional<double> delta) {
    if (delta) h.steps = subbandSteps(h.wavelet, h.levels, *delta);
    if (std::ranges::min(h.steps) < kMinStep) return std::nullopt; // LossyFrame::setDelta raises it
    FrameResult r;
    r.coded.payloads.resize(h.brickCount());
    const std::size_t nsub = 1 + 7 * std::size_t(h.levels);
    std::vector<std::int32_t> brickMax(h.brickCount() * nsub, 0);
    std::atomic<bool> nonFinite = false;
    forwardBricks<float>(
        cc_, t, v, h, o_.threads, &r.report.profile, r.report.transformMs, &r.coded.ranges,
        &CodecProfile::entropy, [&](std::size_t b, const float* c, std::size_t pitch) {
            const Dims d = h.brickDims(b);
            std::int32_t* m = &brickMax[b * nsub];
            subbandMaxAbs(h, d, c, pitch, m);
            // Inf/NaN coefficients (voxels near FLT_MAX) have no quantisation index:
            // LossyFrame zeroes them.
            if (std::any_of(m, m + nsub, [](std::int32_t bits) { return bits >= 0x7f800000; })) {
                nonFinite = true;
                return;
            }
            thread_local std::vector<std::int32_t> q;
            q.resize(d.count());
            quantiseInto(h, d, c, pitch, q.data());
            r.coded.payloads[b] = buildPayload(h, d, q, {});
        });
    if (nonFinite) return std::nullopt;
    const std::vector<double> maxAbs = mergeMaxima(brickMax, nsub);
    for (std::size_t i = 0; i < nsub; ++i)
        if (h.steps[i] < maxAbs[i] / (kMaxQuantIndex - 2)) return std::nullopt;
    ++r.report.profile.trials;
    r.report.step = delta.value_or(0.0);
    r.report.maxError = r.report.psnr = std::numeric_limits<double>::quiet_NaN();
    return r;
}

} // namespace volcl::codec
