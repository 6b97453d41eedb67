// Level-of-detail statistics: measured after encoding, serialised into the .vcz header's metadata.
#include "wavelet/container/LodStatistics.hpp"

#include "core/Error.hpp"
#include "core/Format.hpp"
#include "core/runtime/ParallelFor.hpp"
#include "wavelet/BrickVoxels.hpp"
#include "wavelet/Codec.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <tuple>
#include <utility>

namespace volcl {

namespace {

template <class T> void put(std::string& s, T v) {
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    s.append(b, sizeof(T));
}

} // namespace

std::string LodStatistics::serialise() const {
    std::string s;
    put<std::uint32_t>(s, std::uint32_t(levels));
    put<std::uint32_t>(s, std::uint32_t(frames.size()));
    for (const auto& f : frames) {
        put<std::uint32_t>(s, std::uint32_t(f.size()));
        for (const BrickLevelStats& e : f) {
            put(s, e.min);
            put(s, e.max);
            put(s, e.error);
            put(s, e.rms);
            put(s, e.faceMin);
            put(s, e.faceMax);
        }
    }
    return s;
}

std::optional<LodStatistics> LodStatistics::fromHeader(const VczHeader& h, const std::string& name) {
    const auto it = h.metadata.find(std::string(kVczLodKey));
    if (it == h.metadata.end()) return std::nullopt;
    const std::string& s = it->second;
    std::size_t pos = 0;
    auto fail = [&]() -> void {
        throw IoError(name + ": level-of-detail statistics do not match the header");
    };
    auto get = [&](auto& v) {
        if (s.size() - pos < sizeof(v)) fail();
        std::memcpy(&v, s.data() + pos, sizeof(v));
        pos += sizeof(v);
    };
    std::uint32_t levels = 0, nFrames = 0;
    get(levels);
    get(nFrames);
    if (int(levels) != h.levels || nFrames != h.frames.size()) fail();
    LodStatistics st;
    st.levels = int(levels);
    st.frames.resize(nFrames);
    const std::size_t per = h.brickCount() * (levels + 1);
    for (auto& f : st.frames) {
        std::uint32_t n = 0;
        get(n);
        if (n != 0 && n != per) fail();
        f.resize(n);
        for (BrickLevelStats& e : f) {
            get(e.min);
            get(e.max);
            get(e.error);
            get(e.rms);
            get(e.faceMin);
            get(e.faceMax);
        }
    }
    if (pos != s.size()) fail();
    return st;
}

BrickLevelStats brickLevelStats(std::span<const float> samples, Dims m, std::span<const float> input,
                                Dims full, int level) {
    BrickLevelStats st;
    st.min = std::numeric_limits<float>::infinity();
    st.max = -std::numeric_limits<float>::infinity();
    st.faceMin = std::numeric_limits<float>::infinity();
    st.faceMax = -std::numeric_limits<float>::infinity();
    for (std::size_t k = 0; k < m.z; ++k)
        for (std::size_t j = 0; j < m.y; ++j)
            for (std::size_t i = 0; i < m.x; ++i) {
                const float v = samples[(k * m.y + j) * m.x + i];
                if (!std::isfinite(v)) continue; // NaN/Inf voxels (stored exactly) take no part in ranges
                st.min = std::min(st.min, v);
                st.max = std::max(st.max, v);
                if (i == 0 || j == 0 || k == 0) {
                    st.faceMin = std::min(st.faceMin, v);
                    st.faceMax = std::max(st.faceMax, v);
                }
            }
    // Four partial maxima and sums (x mod 4) in named locals: independent chains in registers that the
    // compiler can put in vector lanes (one running sum was latency-bound, an indexed array went to memory).
    double e0 = 0, e1 = 0, e2 = 0, e3 = 0, q0 = 0, q1 = 0, q2 = 0, q3 = 0;
    forEachLevelValue(samples, m, full, level,
                      [&](std::size_t y, std::size_t z, std::span<const double> row) {
                          const float* in = input.data() + (z * full.y + y) * full.x;
                          const std::size_t n = row.size();
                          auto lane = [&](std::size_t x, double& e, double& q) {
                              // NaN/Inf voxels (restored exactly at level 0, where the interpolation
                              // beside them is NaN too; bricks holding them are drawn at level 0 only)
                              // take no part: a non-finite difference counts as none.
                              const double dv = std::abs(row[x] - double(in[x]));
                              const double d = std::isfinite(dv) ? dv : 0.0;
                              e = d > e ? d : e;
                              q += d * d;
                          };
                          std::size_t x = 0;
                          for (; x + 4 <= n; x += 4) {
                              lane(x, e0, q0);
                              lane(x + 1, e1, q1);
                              lane(x + 2, e2, q2);
                              lane(x + 3, e3, q3);
                          }
                          for (; x < n; ++x)
                              lane(x, e0, q0);
                      });
    const double err = std::max(std::max(e0, e1), std::max(e2, e3));
    const double sq = (q0 + q1) + (q2 + q3);
    // Rounded up so the stored bound is never below the measured deviation.
    const double rms = std::sqrt(sq / double(std::max<std::size_t>(full.count(), 1)));
    st.error = err == 0 ? 0.0f : std::nextafter(float(err), std::numeric_limits<float>::infinity());
    st.rms = rms == 0 ? 0.0f : std::nextafter(float(rms), std::numeric_limits<float>::infinity());
    return st;
}

LodStatistics measureLodStatistics(ComputeContext& cc, const std::vector<std::byte>& vcz,
                                   std::span<const Volume> inputs, const std::string& name) {
    const VczReader reader(vcz, name);
    const VczHeader& h = reader.header();
    if (inputs.size() != h.frames.size()) throw Error("internal: LOD statistics need every input frame");
    // Renderers sample a float64 file's float32 layer: its statistics are the narrowed voxels'.
    std::vector<Volume> narrowed;
    if (h.float64 || (!inputs.empty() && inputs[0].type() == ScalarType::Float64)) {
        for (const Volume& v : inputs)
            narrowed.push_back(v.convertedTo(ScalarType::Float32));
        inputs = narrowed;
    }
    const int levels = h.transform == TransformKind::RawBits ? 0 : h.levels;
    LodStatistics st;
    st.levels = h.levels;
    st.frames.resize(h.frames.size());
    const std::size_t nb = h.brickCount();
    for (std::size_t f = 0; f < h.frames.size(); ++f) {
        if (h.frames[f].type != FrameType::I) continue;
        std::vector<BrickLevelStats> out(nb * std::size_t(h.levels + 1));
        const Volume& input = inputs[f];
        const std::size_t perBrick = std::size_t(h.levels + 1);
        // Every coded level decoded once (each is at most 1/8 of the one below). A lossless file's level 0 is
        // the input itself (the codec's round trip is exact), so it is not decoded again.
        std::vector<Volume> decoded(std::size_t(levels) + 1);
        for (int l = 0; l <= levels; ++l) {
            if (l == 0 && h.rate == RateMode::Lossless) continue;
            DecodeOptions o;
            o.level = l;
            o.frame = f;
            decoded[std::size_t(l)] = reader.decode(cc, o);
            if (decoded[std::size_t(l)].type() == ScalarType::Float64)
                decoded[std::size_t(l)] = decoded[std::size_t(l)].convertedTo(ScalarType::Float32);
        }
        auto levelVoxels = [&](int l) -> const Volume& {
            return l == 0 && h.rate == RateMode::Lossless ? input : decoded[std::size_t(l)];
        };
        // Brick by brick, its input voxels gathered once as float for every level (no float copy of a whole
        // volume is held).
        parallelFor(nb, 2, [&](std::size_t b) {
            const Dims bo = h.brickOrigin(b), bd = h.brickDims(b);
            const std::vector<float> full = codec::brickVoxels<float>(input, h, b);
            for (int l = 0; l <= levels; ++l) {
                const std::size_t s = std::size_t(1) << l;
                const Dims m{(bd.x + s - 1) / s, (bd.y + s - 1) / s, (bd.z + s - 1) / s};
                const std::vector<float> samples =
                    codec::regionVoxels<float>(levelVoxels(l), Dims{bo.x / s, bo.y / s, bo.z / s}, m);
                out[b * perBrick + std::size_t(l)] = brickLevelStats(samples, m, full, bd, l);
            }
            // Raw float bit planes have no coarser levels: those entries are never chosen.
            for (int l = levels + 1; l <= h.levels; ++l) {
                const float lo = float(h.bricks[f][b].min), hi = float(h.bricks[f][b].max);
                const float inf = std::numeric_limits<float>::infinity();
                out[b * perBrick + std::size_t(l)] = {lo, hi, inf, inf, lo, hi};
            }
        });
        st.frames[f] = std::move(out);
    }
    return st;
}

std::vector<std::byte> addLodStatistics(ComputeContext& cc, std::vector<std::byte> vcz,
                                        std::span<const Volume> inputs, const std::string& name) {
    const LodStatistics st = measureLodStatistics(cc, vcz, inputs, name);
    const VczHeader h = readVczHeader(vcz, name);
    // Rewrite the header with the statistics; the payload block moves by the preamble's growth.
    VczHeader nh = h;
    nh.metadata[std::string(kVczLodKey)] = st.serialise();
    const std::size_t oldStart = vczPreambleSize(h), newStart = vczPreambleSize(nh);
    const auto shift = [&](std::uint64_t off) { return off - oldStart + newStart; };
    for (auto& frame : nh.bricks)
        for (VczBrickEntry& e : frame)
            e.offset = shift(e.offset);
    for (VczFrame& fr : nh.frames)
        if (fr.auxSize > 0) fr.auxOffset = shift(fr.auxOffset);
    std::vector<std::vector<std::uint8_t>> payload(1);
    const auto* p = reinterpret_cast<const std::uint8_t*>(vcz.data());
    payload[0].assign(p + oldStart, p + vcz.size());
    std::vector<std::byte> out = writeVcz(nh, payload);
    readVczHeader(out, name); // the rewritten file must parse exactly as written
    return out;
}

std::vector<std::byte> encodeWithLodStatistics(ComputeContext& cc, const TimeSeries& series,
                                               const CodecOptions& options, const std::string& name,
                                               EncodeReport* report, std::vector<FrameReport>* frames) {
    auto encodeAt = [&](const CodecOptions& o) {
        std::vector<std::byte> coded = series.frames.size() == 1
                                           ? encodeVolume(cc, series.frames[0], o, report)
                                           : encodeSeries(cc, series, o, frames);
        const std::size_t codedSize = coded.size();
        return std::pair{addLodStatistics(cc, std::move(coded), series.frames, name), codedSize};
    };
    auto [bytes, codedSize] = encodeAt(options);
    if (options.rate != RateMode::Bpv) return bytes;
    double voxels = 0;
    for (const Volume& v : series.frames)
        voxels += double(v.voxelCount());
    const double budgetBits = options.target * voxels;
    // The statistics' size barely depends on the payloads, so one or two passes settle it.
    CodecOptions tighter = options;
    for (int attempt = 0; attempt < 4 && double(bytes.size()) * 8 > budgetBits; ++attempt) {
        const double statisticsBits = double(bytes.size() - codedSize) * 8;
        tighter.target = attempt == 0 ? options.target - statisticsBits / voxels
                                      : tighter.target - (double(bytes.size()) * 8 - budgetBits) / voxels;
        if (!(tighter.target > 0))
            throw UsageError(name + ": --bpv " + formatNumber(options.target) +
                             " leaves nothing for the voxels after the level-of-detail statistics (" +
                             std::to_string(bytes.size() - codedSize) +
                             " bytes; --no-lod-stats leaves them out)");
        try {
            std::tie(bytes, codedSize) = encodeAt(tighter);
        } catch (const UsageError&) {
            throw UsageError(name + ": --bpv " + formatNumber(options.target) +
                             " cannot hold the voxels and the level-of-detail statistics (" +
                             std::to_string(bytes.size() - codedSize) +
                             " bytes; --no-lod-stats leaves them out)");
        }
    }
    if (double(bytes.size()) * 8 > budgetBits)
        throw DataError(name + ": --bpv " + formatNumber(options.target) +
                        " is not met with the level-of-detail statistics (--no-lod-stats leaves them out)");
    return bytes;
}

} // namespace volcl
