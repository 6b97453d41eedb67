// Lossless rate strategies: reversible integer lifting coded straight from the mapped batch, and the raw
// bit patterns of float voxels (byte planes + zstd, NaN and Inf kept).
#include "wavelet/rate/Strategies.hpp"

#include "core/runtime/ParallelFor.hpp"
#include "wavelet/BrickVoxels.hpp"
#include "wavelet/payload/BrickPayload.hpp"
#include "wavelet/transform/BrickTransform.hpp"

#include <limits>

namespace volcl::codec {

namespace {

class LosslessIntegerStrategy final : public RateStrategy {
public:
    LosslessIntegerStrategy(ComputeContext& cc, const CodecOptions& o) : cc_(cc), o_(o) {}

    FrameResult encodeFrame(const Volume& v, VczHeader& h, bool, const ResidualTarget*) override {
        LiftingTransform<std::int32_t> t(cc_, h.wavelet);
        FrameResult r;
        CodecProfile* prof = &r.report.profile;
        r.coded.payloads.resize(h.brickCount());
        // Coded straight from the mapped batch.
        forwardBricks<std::int32_t>(
            cc_, t, v, h, o_.threads, prof, r.report.transformMs, &r.coded.ranges, &CodecProfile::entropy,
            [&](std::size_t b, const std::int32_t* c, std::size_t pitch) {
                const Dims d = h.brickDims(b);
                r.coded.payloads[b] = buildPayload(h, d, {c, pitch * d.y * d.z}, {}, pitch);
            });
        r.report.psnr = std::numeric_limits<double>::infinity();
        return r;
    }

private:
    ComputeContext& cc_;
    const CodecOptions& o_;
};

class LosslessRawStrategy final : public RateStrategy {
public:
    explicit LosslessRawStrategy(const CodecOptions& o) : o_(o) {}

    FrameResult encodeFrame(const Volume& v, VczHeader& h, bool, const ResidualTarget*) override {
        FrameResult r;
        r.coded.payloads.resize(h.brickCount());
        timeStage(&r.report.profile, &CodecProfile::entropy, [&] {
            parallelFor(r.coded.payloads.size(), o_.threads, [&](std::size_t b) {
                const auto bits = brickVoxels<std::int32_t>(v, h, b);
                r.coded.payloads[b] = buildPayload(h, h.brickDims(b), bits, {});
            });
        });
        timeStage(&r.report.profile, &CodecProfile::assemble,
                  [&] { r.coded.ranges = brickRanges(v, h, o_.threads); });
        r.report.psnr = std::numeric_limits<double>::infinity();
        return r;
    }

private:
    const CodecOptions& o_;
};

} // namespace

std::unique_ptr<RateStrategy> makeLosslessIntegerStrategy(ComputeContext& cc, const CodecOptions& o) {
    return std::make_unique<LosslessIntegerStrategy>(cc, o);
}
std::unique_ptr<RateStrategy> makeLosslessRawStrategy(const CodecOptions& o) {
    return std::make_unique<LosslessRawStrategy>(o);
}

std::unique_ptr<RateStrategy> makeRateStrategy(ComputeContext& cc, const CodecOptions& o, const VczHeader& h,
                                               ValueRangeCache& ranges) {
    switch (h.transform) {
    case TransformKind::IntegerLifting:
        return makeLosslessIntegerStrategy(cc, o);
    case TransformKind::RawBits:
        return makeLosslessRawStrategy(o);
    case TransformKind::FloatLifting:
        break;
    }
    switch (h.rate) {
    case RateMode::MaxError:
    case RateMode::RelError:
    case RateMode::PwRelError:
        return makeBoundedStrategy(cc, o, ranges);
    case RateMode::Psnr:
        return makePsnrStrategy(cc, o, ranges);
    case RateMode::Bpv:
        return makeBpvStrategy(cc, o, ranges);
    case RateMode::Lossless:
        break;
    }
    throw Error("internal: no rate strategy for a lossless float-lifting header");
}

} // namespace volcl::codec
