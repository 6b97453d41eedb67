// The codec pipeline: plans the header, then per frame runs the predict stage and the rate strategy that
// drives transform, quantise and payload stages, and assembles the container; decoding validates the
// request and runs the frame decoder's stages, then the predictor's reconstruction.
#include "wavelet/Codec.hpp"

#include "host/Error.hpp"
#include "host/runtime/Timing.hpp"
#include "wavelet/FrameDecoder.hpp"
#include "wavelet/RangeScan.hpp"
#include "wavelet/StageTiming.hpp"
#include "wavelet/container/FrameAssembly.hpp"
#include "wavelet/predict/Predictor.hpp"
#include "wavelet/rate/RateStrategy.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>

namespace volcl {

namespace {

// The header of an encoding of volumes like `v` with options `o_`: refuses invalid options.
VczHeader planHeader(const Volume& v, const CodecOptions& o_) {
    if (v.empty()) throw UsageError("cannot encode an empty volume");
    if (o_.levels < 0 || o_.levels > 8) throw UsageError("--levels must be between 0 and 8");
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
        if (o_.rate == RateMode::MaxError && integer && o_.target < 1.0) {
            // An integer volume within |error| < 1 is the volume itself.
            h.rate = RateMode::Lossless;
            h.wavelet = o_.wavelet && hasIntegerForm(*o_.wavelet) ? *o_.wavelet : Wavelet::Cdf53;
            h.transform = TransformKind::IntegerLifting;
        }
    }
    h.frames.resize(1);
    return h;
}

// Encodes the frames in order through the predictor and the rate strategy; fills the header's frame table.
class Pipeline {
public:
    Pipeline(ComputeContext& cc, const CodecOptions& o, const VczHeader& h)
        : cc_(cc), ranges_(o.threads), predictor_(codec::makeNonePredictor()),
          rate_(codec::makeRateStrategy(cc, o, h, ranges_)) {}

    /// Codes frame `index`; the rate search runs on the first frame, later frames reuse its steps (one
    /// header for the series).
    codec::FrameResult encodeFrame(const Volume& frame, std::size_t index, VczHeader& h) {
        // The none predictor references no frame, so no reconstruction is kept.
        const codec::Prediction p = predictor_->predict(cc_, frame, index, {});
        VczFrame& entry = h.frames[index];
        entry.type = p.type;
        entry.reference0 = p.reference0;
        entry.reference1 = p.reference1;
        return rate_->encodeFrame(*p.signal, h, index == 0);
    }

    /// The volume's value range (scanned once, shared with the rate control).
    const codec::ValueRange& rangeOf(const Volume& v) { return ranges_.of(v); }

private:
    ComputeContext& cc_;
    codec::ValueRangeCache ranges_;
    std::unique_ptr<codec::Predictor> predictor_;
    std::unique_ptr<codec::RateStrategy> rate_;
};

} // namespace

std::vector<std::byte> encodeVolume(ComputeContext& cc, const Volume& volume, const CodecOptions& options,
                                    EncodeReport* report) {
    Stopwatch total;
    VczHeader h = planHeader(volume, options);
    Pipeline pipeline(cc, options, h);
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
    std::vector<codec::CodedFrame> coded;
    coded.push_back(std::move(frame.coded));
    std::vector<std::byte> bytes;
    codec::timeStage(&frame.report.profile, &CodecProfile::assemble,
                     [&] { bytes = codec::assembleVcz(h, coded); });
    frame.report.profile.total = total.milliseconds();
    if (report) {
        *report = frame.report;
        report->bytes = bytes.size();
        report->bitsPerVoxel = double(bytes.size()) * 8 / double(volume.voxelCount());
    }
    return bytes;
}

std::vector<std::byte> encodeSeries(ComputeContext& cc, const TimeSeries& series,
                                    const CodecOptions& options) {
    series.validate();
    if (series.frames.empty()) throw UsageError("cannot encode an empty time series");
    VczHeader h = planHeader(series.frames[0], options);
    h.frames.resize(series.frames.size());
    Pipeline pipeline(cc, options, h);
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    std::vector<codec::CodedFrame> coded;
    for (std::size_t f = 0; f < series.frames.size(); ++f) {
        const VolumeStats st = series.frames[f].stats(1);
        lo = std::min(lo, st.min);
        hi = std::max(hi, st.max);
        if (f < series.times.size()) h.frames[f].time = series.times[f];
        coded.push_back(pipeline.encodeFrame(series.frames[f], f, h).coded);
    }
    h.valueMin = lo;
    h.valueMax = hi;
    return codec::assembleVcz(h, coded);
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
    : bytes_(std::move(bytes)), name_(std::move(name)) {
    header_ = readVczHeader(bytes_, name_);
}

Volume VczReader::decode(ComputeContext& cc, const DecodeOptions& o) const {
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
    std::vector<std::size_t> which;
    for (std::size_t b = 0; b < h.brickCount(); ++b) {
        const Dims bo = h.brickOrigin(b), bd = h.brickDims(b);
        if (bo.x < r.hi.x && bo.x + bd.x > r.lo.x && bo.y < r.hi.y && bo.y + bd.y > r.lo.y && bo.z < r.hi.z &&
            bo.z + bd.z > r.lo.z)
            which.push_back(b);
    }
    Stopwatch total;
    Volume out(outDims, h.type);
    for (int i = 0; i < 3; ++i) {
        const std::size_t first = i == 0 ? a.x : i == 1 ? a.y : a.z;
        out.spacing[i] = h.spacing[i] * double(f);
        out.origin[i] = h.origin[i] + double(first * f) * h.spacing[i];
    }
    if (o.frame >= h.frames.size()) throw UsageError(name_ + ": no frame " + std::to_string(o.frame));
    const std::unique_ptr<codec::Predictor> predictor =
        codec::predictorFor(h.frames[o.frame], o.frame, name_);
    codec::decodeFrameBricks(cc, bytes_, h, o.frame, which, o.level, o.threads, name_, o.profile, a, e, out,
                             outDims, o.placeOnDevice);
    // I frames carry no side information and reference no frame.
    predictor->reconstruct(cc, out, h.frames[o.frame], {}, {});
    if (o.profile) o.profile->total += total.milliseconds();
    return out;
}

Volume VczReader::decodeBrick(ComputeContext& cc, std::size_t frame, std::size_t brick, int level) const {
    if (brick >= header_.brickCount()) throw UsageError(name_ + ": no brick " + std::to_string(brick));
    const Dims o = header_.brickOrigin(brick), d = header_.brickDims(brick);
    DecodeOptions opt;
    opt.region = Region{o, {o.x + d.x, o.y + d.y, o.z + d.z}};
    opt.level = level;
    opt.frame = frame;
    opt.threads = 1;
    return decode(cc, opt);
}

Volume decodeVolume(ComputeContext& cc, std::span<const std::byte> vcz, const DecodeOptions& options,
                    const std::string& name) {
    VczReader r(std::vector<std::byte>(vcz.begin(), vcz.end()), name);
    return r.decode(cc, options);
}

} // namespace volcl
