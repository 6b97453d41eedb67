// The codec pipeline: plans the header, then per frame runs the predict stage and the rate strategy that
// drives transform, quantise and payload stages, and assembles the container; decoding validates the
// request and runs the frame decoder's stages, then the predictor's reconstruction.
#include "wavelet/Codec.hpp"

#include "core/MappedFile.hpp"

#include "core/Error.hpp"
#include "core/MemoryBudget.hpp"
#include "core/runtime/Timing.hpp"
#include "wavelet/BrickVoxels.hpp"
#include "wavelet/Float64Layer.hpp"
#include "wavelet/FrameDecoder.hpp"
#include "wavelet/RangeScan.hpp"
#include "wavelet/StageTiming.hpp"
#include "wavelet/container/FrameAssembly.hpp"
#include "wavelet/payload/VoxelBrick.hpp"
#include "wavelet/predict/GopPlan.hpp"
#include "wavelet/predict/MotionPredictor.hpp"
#include "wavelet/predict/Predictor.hpp"
#include "wavelet/quantise/Corrections.hpp"
#include "wavelet/rate/RateStrategy.hpp"
#include "wavelet/transform/BrickTransform.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <string_view>

namespace volcl {

namespace {

// True when the bounded mode of `o` allows every voxel of the integer volume `v` an error below 1: an
// integer decode is then exact, which lossless coding gives for fewer bytes than stored corrections.
bool integerBoundBelowOne(const Volume& v, const CodecOptions& o) {
    if (o.rate == RateMode::MaxError) return o.target < 1.0;
    if (o.rate != RateMode::RelError && o.rate != RateMode::PwRelError) return false;
    const VolumeStats st = v.stats(1);
    const double scale = o.rate == RateMode::RelError ? st.max - st.min : std::max(-st.min, st.max);
    return o.target * scale < 1.0;
}

// The header of an encoding of volumes like `v` with options `o_`: refuses invalid options.
VczHeader planHeader(const Volume& v, const CodecOptions& o_) {
    if (v.empty()) throw UsageError("cannot encode an empty volume");
    if (v.type() == ScalarType::Float64) throw Error("internal: float64 frames reach the float32 pipeline");
    // Level 0 would be a brick with no transform, which the decoders do not take: refused, not written.
    if (o_.levels < 1 || o_.levels > 8) throw UsageError("--levels must be between 1 and 8");
    const std::size_t m = std::size_t(1) << o_.levels;
    for (std::size_t b : {o_.brick.x, o_.brick.y, o_.brick.z})
        if (b == 0 || b % m != 0 || b > 1024)
            throw UsageError("--brick must be a positive multiple of 2^levels (" + std::to_string(m) +
                             ") up to 1024");
    VczHeader h;
    h.dims = v.dims();
    h.type = v.type();
    h.spacing = v.spacing;
    h.origin = v.origin;
    h.levels = o_.levels;
    h.brick = o_.brick;
    h.entropy = o_.entropy;
    h.rate = o_.rate;
    h.rateTarget = o_.target;
    h.metadata = o_.metadata;
    addPlacementMetadata(h.metadata, v.direction, v.anatomical);
    const bool integer = v.type() != ScalarType::Float32;
    if (o_.rate == RateMode::Lossless) {
        h.wavelet = o_.wavelet.value_or(Wavelet::Cdf53);
        if (!hasIntegerForm(h.wavelet))
            throw UsageError("--lossless needs a reversible wavelet: cdf53, haar or cdf26");
        if (integer) {
            h.transform = TransformKind::IntegerLifting;
        } else {
            // Float voxels are kept bit for bit (NaN and Inf included): no transform, byte planes + zstd.
            h.transform = TransformKind::RawBits;
            h.entropy = EntropyMode::Fast;
            h.levels = 0;
        }
    } else {
        h.wavelet = o_.wavelet.value_or(Wavelet::Cdf97);
        h.transform = TransformKind::FloatLifting;
        if (!(o_.target > 0) || !std::isfinite(o_.target))
            throw UsageError("the rate target must be a positive number");
        if (o_.rate == RateMode::PwRelError && !(o_.target < 1))
            throw UsageError(
                "the point-wise relative bound must be below 1 (a bound of |x| would not keep signs)");
        if (integer && integerBoundBelowOne(v, o_)) {
            // An integer volume within |error| < 1 is the volume itself.
            h.rate = RateMode::Lossless;
            h.wavelet = o_.wavelet && hasIntegerForm(*o_.wavelet) ? *o_.wavelet : Wavelet::Cdf53;
            h.transform = TransformKind::IntegerLifting;
        }
    }
    h.frames.resize(1);
    return h;
}

// Encodes one volume through the `none` predictor and the rate strategy.
class Pipeline {
public:
    Pipeline(ComputeContext& cc, const CodecOptions& o, const VczHeader& h)
        : cc_(cc), ranges_(o.threads), predictor_(codec::makeNonePredictor()),
          rate_(codec::makeRateStrategy(cc, o, h, ranges_)) {}

    /// Codes frame `index` as an I frame; the rate search runs on the first frame, later frames reuse its
    /// steps (one header for the series).
    codec::FrameResult encodeFrame(const Volume& frame, std::size_t index, VczHeader& h) {
        const codec::Prediction p = predictor_->predict(cc_, frame, index, {});
        VczFrame& entry = h.frames[index];
        entry.type = p.type;
        entry.reference0 = p.reference0;
        entry.reference1 = p.reference1;
        return rate_->encodeFrame(*p.signal, h, index == 0, nullptr);
    }

    /// The volume's value range (scanned once, shared with the rate control).
    const codec::ValueRange& rangeOf(const Volume& v) { return ranges_.of(v); }
    codec::RateStrategy& rate() { return *rate_; }

private:
    ComputeContext& cc_;
    codec::ValueRangeCache ranges_;
    std::unique_ptr<codec::Predictor> predictor_;
    std::unique_ptr<codec::RateStrategy> rate_;
};

std::size_t codedSize(const codec::CodedFrame& c) {
    std::size_t n = c.aux.size();
    for (const auto& p : c.payloads)
        n += p.size();
    return n;
}

// Applies a predicted frame's exactly stored voxels to the reconstructed frame.
void applyFrameCorrections(const VczHeader& h, Volume& frame,
                           const std::vector<std::vector<codec::Correction>>& corrections) {
    codec::visitTyped(frame, [&](auto span) {
        for (std::size_t b = 0; b < corrections.size(); ++b)
            if (!corrections[b].empty())
                codec::applyCorrections(h, b, {0, 0, 0}, h.dims, span, h.dims, corrections[b]);
    });
}

// A P/B frame from its decoded residual (Float32, corrections deferred): the predictor adds the prediction
// from the reconstructed references, then the exactly stored voxels are applied. Motion-data errors name
// the frame.
Volume finishPredicted(ComputeContext& cc, const VczHeader& h, Volume residual, const VczFrame& entry,
                       std::size_t frame, std::span<const std::uint8_t> aux,
                       const codec::ReferenceFrames& refs,
                       const std::vector<std::vector<codec::Correction>>& corrections,
                       const std::string& name, CodecProfile* profile = nullptr) {
    try {
        codec::timeStage(profile, &CodecProfile::predict,
                         [&] { codec::predictorFor(entry)->reconstruct(cc, residual, entry, aux, refs); });
    } catch (const IoError& e) {
        throw IoError(name + ": frame " + std::to_string(frame) + ": " + e.what());
    }
    applyFrameCorrections(h, residual, corrections);
    return residual;
}

// The encoder's closed loop: the frame exactly as the decoder will reconstruct it from its coded bricks
// (a one-frame container decoded by the decoder's stages), so later frames predict from what the decoder
// has.
Volume reconstructCoded(ComputeContext& cc, const VczHeader& h, const codec::CodedFrame& coded,
                        const VczFrame& entry, std::size_t frame, const codec::ReferenceFrames& refs,
                        unsigned threads) {
    VczHeader one = h;
    one.frames.assign(1, VczFrame{});
    std::vector<codec::CodedFrame> frames{codec::CodedFrame{coded.payloads, coded.ranges, {}}};
    const std::vector<std::byte> bytes = codec::assembleVcz(one, frames);
    const bool predicted = entry.type != FrameType::I;
    Volume out(h.dims, predicted ? ScalarType::Float32 : h.type);
    out.spacing = h.spacing;
    out.origin = h.origin;
    std::vector<std::vector<codec::Correction>> corrections;
    codec::decodeFrameBricks(cc, bytes, one, 0, codec::allBricks(one), 0, threads, "encoder", nullptr,
                             {0, 0, 0}, h.dims, out, h.dims, !predicted, predicted ? &corrections : nullptr);
    if (!predicted) return out;
    return finishPredicted(cc, h, std::move(out), entry, frame, coded.aux, refs, corrections, "encoder");
}

// Adds frame f's bricks holding NaN/Inf voxels to the header's kVczNonFiniteKey entry (float frames that
// hold any: callers check the range scan first, so finite data pays nothing).
void noteNonFiniteBricks(VczHeader& h, const Volume& v, std::size_t f) {
    if (v.type() != ScalarType::Float32) return;
    const std::span<const float> in = v.values<float>();
    std::string list;
    for (std::size_t b = 0; b < h.brickCount(); ++b) {
        const Dims o = h.brickOrigin(b), d = h.brickDims(b);
        bool found = false;
        for (std::size_t z = 0; z < d.z && !found; ++z)
            for (std::size_t y = 0; y < d.y && !found; ++y) {
                const float* row = in.data() + v.index(o.x, o.y + y, o.z + z);
                for (std::size_t x = 0; x < d.x && !found; ++x)
                    found = !std::isfinite(row[x]);
            }
        if (found) list += (list.empty() ? "" : ",") + std::to_string(b);
    }
    if (list.empty()) return;
    std::string& entry = h.metadata[std::string(kVczNonFiniteKey)];
    entry += (entry.empty() ? "" : ";") + std::to_string(f) + ":" + list;
}

// PSNR over `frame`'s value range and the max error of `rec` against it.
void measureFrame(const Volume& frame, const Volume& rec, FrameReport& r) {
    r.psnr = psnr(frame, rec);
    r.maxError = maxAbsError(frame, rec);
}

} // namespace

namespace {

// The options of the lossless encoding of the same volume a lossy target is compared with.
CodecOptions losslessOptions(const CodecOptions& o) {
    CodecOptions exact = o;
    exact.rate = RateMode::Lossless;
    exact.target = 0;
    exact.wavelet.reset();
    exact.step.reset();
    return exact;
}

std::vector<std::byte> encodeVolumeWith(ComputeContext& cc, const Volume& volume, const CodecOptions& options,
                                        EncodeReport* report, codec::VoxelBrickTrials* voxelTrials);

} // namespace

namespace {

// Transform extent by content: volumes up to this many voxels are also coded with bricks of
// kExtentTrialBrick voxels per axis and the smaller file is kept. Measured (bench/results/codec/, --psnr
// 40 / 60, 64 -> 128 voxel bricks, 4 levels): hydrogen 998 -> 338 B and 3,706 -> 1,736 B, Isabel step 30
// 9,344 -> 7,382 B, walnut 108,115 -> 99,996 B; deeper transforms (5 or 6 levels) were no smaller. The
// limit keeps the second encode off large volumes, where it would cost seconds.
constexpr std::size_t kExtentTrialMaxVoxels = std::size_t(1) << 24;
constexpr std::size_t kExtentTrialBrick = 128;

// The larger brick an encode with `o` also tries on `v`, if any: only for default extents with a target
// that a smaller file serves better (not --bpv, which spends its budget, nor a fixed --step), and only when
// the volume spans more than one default brick.
std::optional<Dims> extentTrial(const Volume& v, const CodecOptions& o) {
    const CodecOptions defaults;
    if (!o.chooseExtent || o.brick != defaults.brick || o.levels != defaults.levels || o.step ||
        o.rate == RateMode::Bpv || v.voxelCount() > kExtentTrialMaxVoxels)
        return std::nullopt;
    const Dims d = v.dims();
    if (d.x <= o.brick.x && d.y <= o.brick.y && d.z <= o.brick.z) return std::nullopt;
    return Dims{kExtentTrialBrick, kExtentTrialBrick, kExtentTrialBrick};
}

} // namespace

namespace {

// The float32 layer's options for a float64 target: the same target (the float64 layer stores exactly what
// the layer leaves outside it, checked in double), every frame an I frame. Nullopt for a target the layer
// cannot be lossy at: it is then lossless.
std::optional<CodecOptions> float32LayerOptions(const CodecOptions& o) {
    CodecOptions layer = o;
    layer.motion = MotionMode::None;
    if (o.rate == RateMode::Lossless) return std::nullopt;
    if (o.rate == RateMode::Bpv || o.step)
        throw UsageError(
            "float64 volumes take --lossless, --max-error, --rel-error, --pw-rel-error or --psnr "
            "(a bit budget or a fixed --step would not bound the float64 voxels)");
    if (!(o.target > 0) || !std::isfinite(o.target))
        throw UsageError("the rate target must be a positive number");
    if (o.rate == RateMode::PwRelError && !(o.target < 1))
        throw UsageError(
            "the point-wise relative bound must be below 1 (a bound of |x| would not keep signs)");
    // A bound beyond float's range (float64 data beyond it) is the widest the float32 coder takes.
    if (o.rate == RateMode::MaxError)
        layer.target = std::min(layer.target, double(std::numeric_limits<float>::max()) / 4);
    return layer;
}

// Float64 frames: their float32 layer (each voxel narrowed, finite values beyond float's range clamped) coded
// by the float32 pipeline as I frames, then per frame the float64 layer that gives back every voxel exactly
// (lossless) or within the bound checked in double, in the frame's auxiliary block of a version 8 file.
std::vector<std::byte> encodeFloat64(ComputeContext& cc, const TimeSeries& series,
                                     const CodecOptions& options, EncodeReport* report,
                                     std::vector<FrameReport>* frameReports) {
    Stopwatch total;
    series.validate();
    TimeSeries narrowed;
    narrowed.times = series.times;
    for (const Volume& v : series.frames) {
        if (v.voxelCount() > codec::kMaxFloat64LayerVoxels)
            throw UsageError("a float64 frame of more than 2^32 voxels cannot be coded");
        narrowed.frames.push_back(v.convertedTo(ScalarType::Float32));
    }
    const std::size_t n = series.frames.size();
    const std::optional<CodecOptions> layerOptions = float32LayerOptions(options);
    const bool exact = !layerOptions;
    CodecOptions layerCodec = exact ? losslessOptions(options) : *layerOptions;
    layerCodec.motion = MotionMode::None;
    EncodeReport layerReport;
    const std::vector<std::byte> layerBytes =
        n == 1 ? encodeVolume(cc, narrowed.frames[0], layerCodec, &layerReport)
               : encodeSeries(cc, narrowed, layerCodec);
    const VczReader layerFile(layerBytes, "encoder");
    VczHeader h = layerFile.header();
    std::vector<codec::CodedFrame> frames(n);
    std::size_t stored = 0;
    for (std::size_t f = 0; f < n; ++f) {
        const std::span<const double> x = series.frames[f].values<double>();
        if (exact || h.rate == RateMode::Lossless) {
            // The layer is the narrowed frame bit for bit (a lossy target may have found lossless smaller).
            if (exact) {
                frames[f].aux = codec::encodeExactLayer(x, narrowed.frames[f].values<float>());
            } else {
                const auto outliers = codec::float64Outliers(x, narrowed.frames[f].values<float>(),
                                                             {options.rate, options.target});
                stored += outliers.size();
                frames[f].aux = codec::encodeCorrectionLayer(outliers);
            }
        } else {
            DecodeOptions d;
            d.frame = f;
            const Volume decoded = layerFile.decode(cc, d);
            const auto outliers =
                codec::float64Outliers(x, decoded.values<float>(), {options.rate, options.target});
            stored += outliers.size();
            frames[f].aux = codec::encodeCorrectionLayer(outliers);
        }
        for (std::size_t b = 0; b < h.brickCount(); ++b) {
            const auto payload = vczBrickPayload(layerBytes, h, f, b, "encoder");
            frames[f].payloads.emplace_back(payload.begin(), payload.end());
            frames[f].ranges.emplace_back(h.bricks[f][b].min, h.bricks[f][b].max);
        }
    }
    h.float64 = true;
    h.version = 0;
    if (!exact) { // the float64 bound the file holds, whatever the layer's
        h.rate = options.rate;
        h.rateTarget = options.target;
    }
    h.valueMin = std::numeric_limits<double>::infinity();
    h.valueMax = -h.valueMin;
    for (const Volume& v : series.frames) {
        const VolumeStats st = v.stats(1);
        h.valueMin = std::min(h.valueMin, st.min);
        h.valueMax = std::max(h.valueMax, st.max);
    }
    std::vector<std::byte> bytes = codec::assembleVcz(h, frames);
    // What the decoder gives, measured against the input in double (a lossless file is exact).
    const VczReader file(bytes, "encoder");
    std::vector<FrameReport> reps(n);
    for (std::size_t f = 0; f < n; ++f) {
        reps[f].psnr = std::numeric_limits<double>::infinity();
        if (exact) continue;
        DecodeOptions d;
        d.frame = f;
        measureFrame(series.frames[f], file.decode(cc, d), reps[f]);
    }
    EncodeReport r = layerReport;
    r.bytes = bytes.size();
    r.bitsPerVoxel = double(bytes.size()) * 8 / double(series.frames[0].voxelCount() * n);
    r.psnr = exact ? std::numeric_limits<double>::infinity() : reps[0].psnr;
    r.maxError = exact ? 0 : reps[0].maxError;
    r.corrections = stored;
    // A lossy target never gives a file larger than the lossless one.
    if (!exact) {
        EncodeReport losslessReport;
        std::vector<FrameReport> losslessFrames;
        std::vector<std::byte> exactBytes =
            encodeFloat64(cc, series, losslessOptions(options), &losslessReport, &losslessFrames);
        if (exactBytes.size() <= bytes.size()) {
            bytes = std::move(exactBytes);
            r = losslessReport;
            reps = std::move(losslessFrames);
        }
    }
    r.profile.total = total.milliseconds();
    if (report) *report = r;
    if (frameReports) *frameReports = std::move(reps);
    return bytes;
}

} // namespace

std::vector<std::byte> encodeVolume(ComputeContext& cc, const Volume& volume, const CodecOptions& options,
                                    EncodeReport* report) {
    if (volume.type() == ScalarType::Float64) {
        TimeSeries one;
        one.frames.push_back(volume);
        return encodeFloat64(cc, one, options, report, nullptr);
    }
    const std::optional<Dims> larger = extentTrial(volume, options);
    if (!larger) return encodeVolumeWith(cc, volume, options, report, nullptr);
    Stopwatch total;
    EncodeReport first, second;
    std::vector<std::byte> bytes = encodeVolumeWith(cc, volume, options, &first, nullptr);
    CodecOptions o = options;
    o.brick = *larger;
    std::vector<std::byte> other = encodeVolumeWith(cc, volume, o, &second, nullptr);
    const bool takeLarger = other.size() < bytes.size();
    if (takeLarger) bytes = std::move(other);
    if (report) {
        *report = takeLarger ? second : first;
        // The other extent's encode counts as the choice's time.
        report->profile.choose += total.milliseconds() - report->profile.total;
        report->profile.total = total.milliseconds();
    }
    return bytes;
}

namespace {

// encodeVolume; `voxelTrials` keeps the voxel coding of each brick measured by an encode of the same volume
// (the lossless file a lossy target is compared with and the lossy file share them).
std::vector<std::byte> encodeVolumeWith(ComputeContext& cc, const Volume& volume, const CodecOptions& options,
                                        EncodeReport* report, codec::VoxelBrickTrials* voxelTrials) {
    Stopwatch total;
    VczHeader h = planHeader(volume, options);
    // A lossy target never gives a file larger than the lossless one, which is exact and so meets every
    // target: for --bpv the lossless file within the budget is taken at once (no lossy file in the budget
    // is better); the other targets compare the two files below. Not for a fixed --step, which asks for that
    // quantiser.
    std::optional<std::vector<std::byte>> lossless;
    EncodeReport losslessReport;
    double chooseMs = 0;
    const bool compareLossless = h.rate != RateMode::Lossless && !options.step;
    // The two files code the same voxels: the second one's voxel trial reuses the first one's zstd passes.
    codec::VoxelBrickTrials sharedTrials;
    if (compareLossless && !voxelTrials) voxelTrials = &sharedTrials;
    auto encodeLossless = [&] {
        Stopwatch sw;
        lossless = encodeVolumeWith(cc, volume, losslessOptions(options), &losslessReport, voxelTrials);
        chooseMs += sw.milliseconds();
    };
    auto takeLossless = [&] {
        losslessReport.profile.choose += chooseMs - losslessReport.profile.total;
        losslessReport.profile.total = total.milliseconds();
        if (report) *report = losslessReport;
        return std::move(*lossless);
    };
    if (compareLossless && h.rate == RateMode::Bpv) {
        encodeLossless();
        if (double(lossless->size()) * 8 <= options.target * double(volume.voxelCount()))
            return takeLossless();
    }
    Pipeline pipeline(cc, options, h);
    // Before coding: a --bpv budget counts the metadata too.
    if (volume.type() == ScalarType::Float32 && pipeline.rangeOf(volume).nonFinite)
        noteNonFiniteBricks(h, volume, 0);
    codec::FrameResult frame = pipeline.encodeFrame(volume, 0, h);
    if (h.transform == TransformKind::IntegerLifting) {
        // The bricks' ranges (measured by the forward pass) give the volume's: no scan of the voxels.
        h.valueMin = std::numeric_limits<double>::infinity();
        h.valueMax = -h.valueMin;
        for (const auto& [lo, hi] : frame.coded.ranges) {
            h.valueMin = std::min(h.valueMin, lo);
            h.valueMax = std::max(h.valueMax, hi);
        }
    } else {
        const codec::ValueRange& st = pipeline.rangeOf(volume);
        h.valueMin = st.min;
        h.valueMax = st.max;
    }
    // Per brick, the smaller of the wavelet payload and the voxels coded as they are (exact, so within every
    // bound): flat regions of label volumes and masks stay flat, noise costs its entropy.
    codec::timeStage(&frame.report.profile, &CodecProfile::choose, [&] {
        if (codec::codeSmallerBricksAsVoxels(volume, h, frame.coded.payloads, options.threads, voxelTrials) >
            0)
            h.voxelBricks = true;
    });
    std::vector<codec::CodedFrame> coded;
    coded.push_back(std::move(frame.coded));
    std::vector<std::byte> bytes;
    codec::timeStage(&frame.report.profile, &CodecProfile::assemble,
                     [&] { bytes = codec::assembleVcz(h, coded); });
    // Bricks coded exactly make the error smaller than the rate control measured: their errors leave its
    // sums (the finite voxels' measure of NaN/Inf volumes stays the rate control's, an upper bound).
    if (h.voxelBricks && h.rate != RateMode::Lossless && !std::isnan(frame.report.psnr) &&
        frame.brickErrors.size() == coded.front().payloads.size()) {
        double sumSq = 0, kept = 0, maxErr = 0;
        for (std::size_t b = 0; b < frame.brickErrors.size(); ++b) {
            const auto [sq, mx] = frame.brickErrors[b];
            sumSq += sq;
            if (codec::isVoxelBrick(coded.front().payloads[b])) continue;
            kept += sq;
            maxErr = std::max(maxErr, mx);
        }
        frame.report.maxError = maxErr;
        frame.report.psnr = kept == 0 ? std::numeric_limits<double>::infinity()
                                      : frame.report.psnr + 10 * std::log10(sumSq / kept);
    }
    // Every lossy target is compared: no cheap test was found that rules the lossless file out (the frog
    // tissue map at --psnr 40, 32 M voxels, quantiser step above 1, under a quarter of its bricks voxel-coded:
    // lossy 194,015 B against lossless 192,341 B).
    if (compareLossless && h.rate != RateMode::Bpv) {
        encodeLossless();
        if (lossless->size() <= bytes.size()) {
            // The lossy encode's time counts as the choice's.
            chooseMs = total.milliseconds();
            return takeLossless();
        }
    }
    frame.report.profile.choose += chooseMs;
    frame.report.profile.total = total.milliseconds();
    if (report) {
        *report = frame.report;
        report->bytes = bytes.size();
        report->bitsPerVoxel = double(bytes.size()) * 8 / double(volume.voxelCount());
    }
    return bytes;
}

// False when a reference of `pf` holds a non-finite voxel: lossy frames of float voxels near FLT_MAX can
// reconstruct beyond float's range, and nothing can be predicted from them.
bool finiteReferences(const std::vector<const Volume*>& recon, const codec::PlannedFrame& pf) {
    for (std::int32_t r : {pf.reference0, pf.reference1})
        if (r >= 0 && recon[std::size_t(r)] && recon[std::size_t(r)]->type() == ScalarType::Float32)
            for (float x : recon[std::size_t(r)]->values<float>())
                if (!std::isfinite(x)) return false;
    return true;
}

// One pass of the series encoder; `step` receives the base quantiser step the first frame chose.
std::vector<std::byte> encodeSeriesOnce(ComputeContext& cc, const TimeSeries& series,
                                        const CodecOptions& options, std::vector<FrameReport>* reports,
                                        double& chosenStep) {
    series.validate();
    if (series.frames.empty()) throw UsageError("cannot encode an empty time series");
    const std::size_t n = series.frames.size();
    VczHeader h = planHeader(series.frames[0], options);
    h.frames.resize(n);
    const bool motion = options.motion == MotionMode::Block && h.transform != TransformKind::RawBits;
    for (std::size_t f = 0; f < n && motion; ++f) {
        // Intra frames store NaN/Inf voxels exactly; motion prediction needs finite frames: refuse naming
        // the frame before any work.
        const VolumeStats st = series.frames[f].stats(1);
        if (st.nanCount || st.infCount)
            throw DataError("frame " + std::to_string(f) +
                            " holds NaN/Inf voxels: motion prediction needs finite voxels (use --motion none "
                            "to code every frame as an intra frame, or --lossless)");
    }
    const std::vector<codec::PlannedFrame> plan =
        codec::planGop(n, motion ? options.gop : 1, motion ? options.bFrames : 0);
    Pipeline pipeline(cc, options, h);
    std::unique_ptr<codec::Predictor> predictor;
    if (motion)
        predictor = codec::makeMotionPredictor(options.motionSearch, options.globalShift, options.threads);
    const bool lossless = h.rate == RateMode::Lossless;
    // Reconstructions of the anchors later frames predict from (the two latest are enough).
    std::vector<std::optional<Volume>> recon(n);
    std::vector<const Volume*> reconPtr(n, nullptr);
    std::vector<codec::CodedFrame> coded(n);
    std::vector<FrameReport> rep(n);
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    double step = 1; // the base quantiser step the first frame chose
    for (std::size_t k = 0; k < plan.size(); ++k) {
        const codec::PlannedFrame& pf = plan[k];
        const std::size_t f = pf.frame;
        const Volume& frame = series.frames[f];
        const VolumeStats st = frame.stats(1);
        lo = std::min(lo, st.min);
        hi = std::max(hi, st.max);
        if (st.nanCount || st.infCount) noteNonFiniteBricks(h, frame, f);
        if (f < series.times.size()) h.frames[f].time = series.times[f];
        VczFrame& entry = h.frames[f];
        codec::FrameResult r = pipeline.rate().encodeFrame(frame, h, k == 0, nullptr);
        if (k == 0) step = r.report.step;
        entry.type = FrameType::I;
        entry.reference0 = entry.reference1 = -1;
        // A reference reconstructed beyond float's range (lossy voxels near FLT_MAX) predicts nothing.
        rep[f].intraFallback = pf.type != FrameType::I && !finiteReferences(reconPtr, pf);
        if (pf.type != FrameType::I && !rep[f].intraFallback) {
            codec::ReferenceFrames refs{reconPtr, pf.reference0, pf.reference1, lossless ? 1.0 : step,
                                        lossless};
            codec::Prediction p = predictor->predict(cc, frame, f, refs);
            const codec::ResidualTarget target{&frame, &*p.prediction};
            codec::FrameResult pr = pipeline.rate().encodeFrame(*p.signal, h, false, &target);
            pr.coded.aux = std::move(p.side);
            // The mode decision by actual cost, at frame level: the smaller coding wins.
            if (codedSize(pr.coded) < codedSize(r.coded)) {
                r = std::move(pr);
                entry.type = p.type;
                entry.reference0 = p.reference0;
                entry.reference1 = p.reference1;
            } else {
                rep[f].intraFallback = true;
            }
            // Brick statistics are the frame's (renderers skip bricks by them), not the residual's.
            r.coded.ranges = codec::brickRanges(frame, h, options.threads);
        }
        rep[f].type = entry.type;
        rep[f].reference0 = entry.reference0;
        rep[f].reference1 = entry.reference1;
        rep[f].bytes = codedSize(r.coded);
        rep[f].psnr = r.report.psnr;
        rep[f].maxError = r.report.maxError;
        const bool referenced =
            motion && pf.type != FrameType::B &&
            std::any_of(plan.begin() + std::ptrdiff_t(k) + 1, plan.end(), [&](const auto& q) {
                return q.reference0 == std::int32_t(f) || q.reference1 == std::int32_t(f);
            });
        if (referenced || (reports && !lossless && options.measureError)) {
            const codec::ReferenceFrames refs{reconPtr, entry.reference0, entry.reference1};
            Volume rec = lossless ? frame : reconstructCoded(cc, h, r.coded, entry, f, refs, options.threads);
            if (!lossless) measureFrame(frame, rec, rep[f]);
            if (referenced) {
                recon[f] = std::move(rec);
                reconPtr[f] = &*recon[f];
            }
        }
        // Anchors older than the previous anchor are referenced no more.
        for (std::size_t g = 0; g < f; ++g)
            if (recon[g] &&
                std::none_of(plan.begin() + std::ptrdiff_t(k) + 1, plan.end(), [&](const auto& q) {
                    return q.reference0 == std::int32_t(g) || q.reference1 == std::int32_t(g);
                })) {
                recon[g].reset();
                reconPtr[g] = nullptr;
            }
        coded[f] = std::move(r.coded);
    }
    h.valueMin = lo;
    h.valueMax = hi;
    chosenStep = step;
    if (reports) *reports = std::move(rep);
    return codec::assembleVcz(h, coded);
}

} // namespace

std::vector<std::byte> encodeSeries(ComputeContext& cc, const TimeSeries& series, const CodecOptions& options,
                                    std::vector<FrameReport>* reports) {
    if (!series.frames.empty() && series.frames[0].type() == ScalarType::Float64)
        return encodeFloat64(cc, series, options, nullptr, reports);
    std::vector<FrameReport> rep;
    double step = 0;
    std::vector<std::byte> bytes = encodeSeriesOnce(cc, series, options, &rep, step);
    // --psnr holds on every frame within kPsnrToleranceDb, but the steps the first frame chose serve every
    // frame: when a later frame falls short the series is coded again at a step finer by the shortfall (about
    // 6 dB per halving of the step).
    if (options.rate == RateMode::Psnr && !options.step && options.measureError)
        for (int attempt = 0; attempt < 4; ++attempt) {
            double worst = std::numeric_limits<double>::infinity();
            for (const FrameReport& f : rep)
                if (!std::isnan(f.psnr)) worst = std::min(worst, f.psnr);
            const double floor = options.target - kPsnrToleranceDb;
            if (!(worst < floor) || !(step > 0)) break;
            CodecOptions finer = options;
            finer.step = step * std::pow(10.0, -(floor - worst + kPsnrRecoveryMarginDb) / 20);
            bytes = encodeSeriesOnce(cc, series, finer, &rep, step);
        }
    if (reports) *reports = std::move(rep);
    return bytes;
}

Region parseRegion(std::string_view text) {
    Region r;
    std::size_t v[6];
    const std::string s(text);
    char c1, c2, c3, c4, c5;
    int consumed = 0;
    if (std::sscanf(s.c_str(), "%zu %c %zu %c %zu %c %zu %c %zu %c %zu%n", &v[0], &c1, &v[1], &c2, &v[2], &c3,
                    &v[3], &c4, &v[4], &c5, &v[5], &consumed) != 11 ||
        c1 != ',' || c2 != ',' || c3 != ':' || c4 != ',' || c5 != ',' ||
        static_cast<std::size_t>(consumed) != s.size())
        throw UsageError("--region must look like x0,y0,z0:x1,y1,z1 (got '" + s + "')");
    r.lo = {v[0], v[1], v[2]};
    r.hi = {v[3], v[4], v[5]};
    if (r.lo.x >= r.hi.x || r.lo.y >= r.hi.y || r.lo.z >= r.hi.z)
        throw UsageError("--region " + s + " is empty: each upper bound must exceed its lower bound");
    return r;
}

// ------------------------------------------------------------------------------ decoder

VczReader::VczReader(std::vector<std::byte> bytes, std::string name)
    : owned_(std::move(bytes)), bytes_(owned_), name_(std::move(name)) {
    header_ = readVczHeader(bytes_, name_);
}

VczReader::VczReader(const std::filesystem::path& path)
    : mapped_(std::make_shared<const MappedFile>(path)), bytes_(mapped_->bytes()), name_(path.string()) {
    // A mapped file is read brick by brick: what it holds is the index and one brick, whatever the frame's
    // size; decode() checks the frame or region it is asked for.
    header_ = readVczHeader(bytes_, name_, 0, VczHeaderUse::Bricks);
}

VczReader::VczReader(const VczReader& other)
    : owned_(other.owned_), mapped_(other.mapped_),
      bytes_(mapped_ ? mapped_->bytes() : std::span<const std::byte>(owned_)), name_(other.name_),
      header_(other.header_) {}

VczReader& VczReader::operator=(const VczReader& other) {
    if (this != &other) *this = VczReader(other);
    return *this;
}

void addPlacementMetadata(std::map<std::string, std::string>& metadata, const Direction3& direction,
                          bool anatomical) {
    if (direction != kIdentityDirection) {
        std::string text;
        for (double x : direction) {
            char buf[32];
            const auto end = std::to_chars(buf, buf + sizeof buf, x).ptr;
            if (!text.empty()) text += ' ';
            text.append(buf, end);
        }
        metadata[std::string(kVczDirectionKey)] = text;
    }
    if (anatomical) metadata[std::string(kVczAnatomicalKey)] = "1";
}

Direction3 vczDirection(const VczHeader& h) {
    const auto it = h.metadata.find(std::string(kVczDirectionKey));
    if (it == h.metadata.end()) return kIdentityDirection;
    Direction3 d{};
    const char* p = it->second.data();
    const char* end = p + it->second.size();
    for (double& x : d) {
        while (p < end && *p == ' ')
            ++p;
        const auto r = std::from_chars(p, end, x);
        if (r.ec != std::errc() || !std::isfinite(x))
            throw DataError(std::string(kVczDirectionKey) + " is not 9 finite numbers");
        p = r.ptr;
    }
    if (p != end) throw DataError(std::string(kVczDirectionKey) + " is not 9 finite numbers");
    const Direction3 o = orthonormalDirection(d);
    for (int i = 0; i < 9; ++i)
        if (std::abs(o[std::size_t(i)] - d[std::size_t(i)]) > 1e-6)
            throw DataError(std::string(kVczDirectionKey) + " is not orthonormal");
    return d;
}

Volume VczReader::decode(ComputeContext& cc, const DecodeOptions& o) const {
    return decodeStored(cc, o, true);
}

Volume VczReader::decodeStored(ComputeContext& cc, const DecodeOptions& o, bool float64) const {
    const VczHeader& h = header_;
    const int maxLevel = h.transform == TransformKind::RawBits ? 16 : h.levels;
    if (o.level < 0 || o.level > maxLevel)
        throw UsageError(name_ + ": --level must be between 0 and " + std::to_string(maxLevel) +
                         " (the encoded levels)");
    Region r{{0, 0, 0}, h.dims};
    if (o.region) {
        r = *o.region;
        if (r.hi.x > h.dims.x || r.hi.y > h.dims.y || r.hi.z > h.dims.z || r.lo.x >= r.hi.x ||
            r.lo.y >= r.hi.y || r.lo.z >= r.hi.z)
            throw UsageError(name_ + ": --region lies outside the volume (" + std::to_string(h.dims.x) + "x" +
                             std::to_string(h.dims.y) + "x" + std::to_string(h.dims.z) + ")");
    }
    const std::size_t f = std::size_t(1) << o.level;
    auto up = [f](std::size_t v) { return (v + f - 1) / f; };
    const Dims a{up(r.lo.x), up(r.lo.y), up(r.lo.z)}, e{up(r.hi.x), up(r.hi.y), up(r.hi.z)};
    const Dims outDims{e.x - a.x, e.y - a.y, e.z - a.z};
    if (outDims.count() == 0)
        throw UsageError(name_ + ": the region holds no sample at level " + std::to_string(o.level));
    checkVczDecodeBudget(h, outDims, 0, name_,
                         "a decoded " + std::to_string(outDims.x) + "x" + std::to_string(outDims.y) + "x" +
                             std::to_string(outDims.z) + " region");
    std::vector<std::size_t> which;
    for (std::size_t b = 0; b < h.brickCount(); ++b) {
        const Dims bo = h.brickOrigin(b), bd = h.brickDims(b);
        if (bo.x < r.hi.x && bo.x + bd.x > r.lo.x && bo.y < r.hi.y && bo.y + bd.y > r.lo.y && bo.z < r.hi.z &&
            bo.z + bd.z > r.lo.z)
            which.push_back(b);
    }
    Stopwatch total;
    Volume out(outDims, h.type);
    out.direction = vczDirection(h);
    out.anatomical = h.metadata.count(std::string(kVczAnatomicalKey)) != 0;
    for (int i = 0; i < 3; ++i) {
        out.spacing[i] = h.spacing[i] * double(f);
        // The region's first voxel in world: origin + D diag(spacing) first.
        double offset = 0.0;
        for (int c = 0; c < 3; ++c)
            offset += out.direction[std::size_t(i * 3 + c)] *
                      double((c == 0   ? a.x
                              : c == 1 ? a.y
                                       : a.z) *
                             f) *
                      h.spacing[std::size_t(c)];
        out.origin[i] = h.origin[i] + offset;
    }
    if (o.frame >= h.frames.size()) throw UsageError(name_ + ": no frame " + std::to_string(o.frame));
    if (h.frames[o.frame].type != FrameType::I) {
        if (o.level != 0)
            throw UsageError(name_ + ": frame " + std::to_string(o.frame) +
                             " is a motion-compensated frame: it decodes at --level 0 only");
        Volume whole = decodeFrame(cc, o.frame, {}, o.threads, o.profile);
        return o.region ? whole.cropped(r.lo, r.hi) : whole;
    }
    codec::decodeFrameBricks(cc, bytes_, h, o.frame, which, o.level, o.threads, name_, o.profile, a, e, out,
                             outDims, o.placeOnDevice, nullptr, o.ahead);
    if (float64 && h.float64) {
        // The float32 layer widened; at full resolution the float64 layer gives the voxels back (a coarser
        // level is the float32 layer's approximation).
        Volume wide = out.convertedTo(ScalarType::Float64);
        if (o.level == 0)
            codec::timeStage(o.profile, &CodecProfile::assemble, [&] {
                codec::applyFloat64Layer(vczFrameAux(bytes_, h, o.frame, name_), h.dims, a, e,
                                         wide.values<double>(), outDims, name_);
            });
        out = std::move(wide);
    }
    if (o.profile) o.profile->total += total.milliseconds();
    return out;
}

std::vector<std::size_t> VczReader::framesNeeded(std::size_t frame,
                                                 std::span<const Volume* const> decoded) const {
    const VczHeader& h = header_;
    if (frame >= h.frames.size()) throw UsageError(name_ + ": no frame " + std::to_string(frame));
    auto known = [&](std::size_t f) { return f < decoded.size() && decoded[f]; };
    // The reader checked that P frames reference earlier anchors and B frames an earlier and a later one,
    // so the anchors needed are decoded in increasing order and a B frame (never referenced) comes last.
    std::vector<char> needed(h.frames.size(), 0);
    std::vector<std::size_t> pending{frame};
    while (!pending.empty()) {
        const std::size_t f = pending.back();
        pending.pop_back();
        if (needed[f] || (known(f) && f != frame)) continue;
        needed[f] = 1;
        for (std::int32_t r : {h.frames[f].reference0, h.frames[f].reference1})
            if (r >= 0) pending.push_back(std::size_t(r));
    }
    std::vector<std::size_t> order;
    for (std::size_t f = 0; f < h.frames.size(); ++f)
        if (needed[f] && f != frame) order.push_back(f);
    order.push_back(frame);
    return order;
}

Volume VczReader::decodeFrame(ComputeContext& cc, std::size_t frame, std::span<const Volume* const> decoded,
                              unsigned threads, CodecProfile* profile) const {
    const VczHeader& h = header_;
    const std::vector<std::size_t> order = framesNeeded(frame, decoded);
    std::vector<std::optional<Volume>> own(h.frames.size());
    std::vector<const Volume*> ptr(h.frames.size(), nullptr);
    for (std::size_t f = 0; f < decoded.size() && f < ptr.size(); ++f)
        ptr[f] = decoded[f];
    for (std::size_t k = 0; k < order.size(); ++k) {
        const std::size_t f = order[k];
        const VczFrame& entry = h.frames[f];
        Volume v;
        if (entry.type == FrameType::I) {
            DecodeOptions o;
            o.frame = f;
            o.threads = threads;
            o.profile = profile;
            v = decode(cc, o);
        } else {
            Stopwatch total;
            // The float residual and the frame predicted from it (the voxel type's bytes bound neither).
            checkMemoryBudget(h.dims.count() * (sizeof(float) + scalarSize(h.type)), 0, name_,
                              "a motion-compensated frame and its residual");
            Volume residual(h.dims, ScalarType::Float32);
            residual.spacing = h.spacing;
            residual.origin = h.origin;
            std::vector<std::vector<codec::Correction>> corrections;
            codec::decodeFrameBricks(cc, bytes_, h, f, codec::allBricks(h), 0, threads, name_, profile,
                                     {0, 0, 0}, h.dims, residual, h.dims,
                                     h.transform == TransformKind::FloatLifting, &corrections);
            const auto aux = vczFrameAux(bytes_, h, f, name_);
            v = finishPredicted(cc, h, std::move(residual), entry, f, aux,
                                codec::ReferenceFrames{ptr, entry.reference0, entry.reference1}, corrections,
                                name_, profile);
            if (profile) profile->total += total.milliseconds();
            v.direction = vczDirection(h);
            v.anatomical = h.metadata.count(std::string(kVczAnatomicalKey)) != 0;
        }
        if (k + 1 == order.size()) return v;
        own[f] = std::move(v);
        ptr[f] = &*own[f];
        // Frames no later frame of the order references are released.
        for (std::size_t g = 0; g < f; ++g)
            if (own[g] &&
                std::none_of(order.begin() + std::ptrdiff_t(k) + 1, order.end(), [&](std::size_t q) {
                    return h.frames[q].reference0 == std::int32_t(g) ||
                           h.frames[q].reference1 == std::int32_t(g);
                })) {
                own[g].reset();
                ptr[g] = nullptr;
            }
    }
    throw Error("internal: empty decoding order");
}

Volume VczReader::decodeBrick(ComputeContext& cc, std::size_t frame, std::size_t brick, int level) const {
    if (brick >= header_.brickCount()) throw UsageError(name_ + ": no brick " + std::to_string(brick));
    const Dims o = header_.brickOrigin(brick), d = header_.brickDims(brick);
    DecodeOptions opt;
    opt.region = Region{o, {o.x + d.x, o.y + d.y, o.z + d.z}};
    opt.level = level;
    opt.frame = frame;
    opt.threads = 1;
    Volume v = decodeStored(cc, opt, false);
    // A mapped file's payload pages go back once decoded: the resident set holds the pool, not the file.
    if (mapped_ && header_.frames[frame].type == FrameType::I) {
        const VczBrickEntry& e = header_.bricks[frame][brick];
        mapped_->release(e.offset, e.size);
    }
    return v;
}

Volume decodeVolume(ComputeContext& cc, std::span<const std::byte> vcz, const DecodeOptions& options,
                    const std::string& name) {
    VczReader r(std::vector<std::byte>(vcz.begin(), vcz.end()), name);
    return r.decode(cc, options);
}

void decodeEachFrame(const VczReader& r, ComputeContext& cc, unsigned threads, CodecProfile* profile,
                     const std::function<void(std::size_t, Volume&&)>& use) {
    const std::size_t n = r.header().frames.size();
    // A frame is kept until the last frame that references it is decoded.
    std::vector<std::size_t> lastUse(n);
    for (std::size_t f = 0; f < n; ++f) {
        lastUse[f] = f;
        for (std::int32_t ref : {r.header().frames[f].reference0, r.header().frames[f].reference1})
            if (ref >= 0) lastUse[std::size_t(ref)] = std::max(lastUse[std::size_t(ref)], f);
    }
    std::vector<std::optional<Volume>> frames(n);
    std::vector<const Volume*> known(n, nullptr);
    for (std::size_t f = 0; f < n; ++f) {
        Volume v = r.decodeFrame(cc, f, known, threads, profile);
        if (lastUse[f] > f) {
            frames[f] = v; // a later frame predicts from it
            known[f] = &*frames[f];
        }
        use(f, std::move(v));
        for (std::size_t g = 0; g <= f; ++g)
            if (frames[g] && lastUse[g] <= f) {
                frames[g].reset();
                known[g] = nullptr;
            }
    }
}

std::vector<std::size_t> vczNonFiniteBricks(const VczHeader& h, std::size_t frame) {
    std::vector<std::size_t> out;
    const auto it = h.metadata.find(std::string(kVczNonFiniteKey));
    if (it == h.metadata.end()) return out;
    std::string_view rest = it->second;
    while (!rest.empty()) {
        const std::size_t end = std::min(rest.find(';'), rest.size());
        const std::string_view entry = rest.substr(0, end);
        rest.remove_prefix(std::min(end + 1, rest.size()));
        const std::size_t colon = entry.find(':');
        std::size_t f = 0;
        if (colon == std::string_view::npos ||
            std::from_chars(entry.data(), entry.data() + colon, f).ec != std::errc() || f != frame)
            continue;
        const char* p = entry.data() + colon + 1;
        const char* e = entry.data() + entry.size();
        while (p < e) {
            std::size_t b = 0;
            const auto r = std::from_chars(p, e, b);
            if (r.ec != std::errc()) break;
            if (b < h.brickCount()) out.push_back(b);
            p = r.ptr < e && *r.ptr == ',' ? r.ptr + 1 : e;
        }
    }
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
}

std::vector<double> vczFrameTimes(const VczHeader& h) {
    // A series encoded without times stores zeros.
    std::vector<double> times;
    for (const VczFrame& f : h.frames)
        times.push_back(f.time);
    if (std::all_of(times.begin(), times.end(), [](double t) { return t == 0; })) times.clear();
    return times;
}

TimeSeries decodeAllFrames(const VczReader& r, ComputeContext& cc, unsigned threads, CodecProfile* profile) {
    TimeSeries ts;
    decodeEachFrame(r, cc, threads, profile,
                    [&](std::size_t, Volume&& v) { ts.frames.push_back(std::move(v)); });
    ts.times = vczFrameTimes(r.header());
    return ts;
}

} // namespace volcl
