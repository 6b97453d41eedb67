// Wavelet codec: brick planning, transforms on the device, quantisation and rate control, entropy coding
// on host threads, .vcz assembly, and validated region / level decoding.
#include "wavelet/Codec.hpp"

#include "host/Error.hpp"

#include <zstd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <exception>
#include <limits>
#include <mutex>
#include <thread>

namespace volcl {

namespace {

constexpr double kMaxQuantIndex = double(1 << 29); // keeps magnitude classes well inside the coder's range

// Runs fn(i) for i in [0, n) on up to `threads` threads; rethrows the first exception.
template <class Fn> void parallelFor(std::size_t n, unsigned threads, Fn fn) {
    threads = std::max(1u, std::min<unsigned>(threads, static_cast<unsigned>(std::max<std::size_t>(n, 1))));
    if (threads == 1) {
        for (std::size_t i = 0; i < n; ++i)
            fn(i);
        return;
    }
    std::atomic<std::size_t> next{0};
    std::exception_ptr error;
    std::mutex m;
    auto work = [&] {
        for (;;) {
            const std::size_t i = next.fetch_add(1);
            if (i >= n) return;
            try {
                fn(i);
            } catch (...) {
                std::lock_guard lock(m);
                if (!error) error = std::current_exception();
                next = n;
                return;
            }
        }
    };
    std::vector<std::thread> pool;
    for (unsigned t = 1; t < threads; ++t)
        pool.emplace_back(work);
    work();
    for (auto& t : pool)
        t.join();
    if (error) std::rethrow_exception(error);
}

// Calls fn with the volume's typed span.
template <class Fn> decltype(auto) visitTyped(const Volume& v, Fn fn) {
    switch (v.type()) {
    case ScalarType::UInt8:
        return fn(v.values<std::uint8_t>());
    case ScalarType::UInt16:
        return fn(v.values<std::uint16_t>());
    case ScalarType::Int16:
        return fn(v.values<std::int16_t>());
    case ScalarType::Float32:
        return fn(v.values<float>());
    }
    throw Error("internal: unknown scalar type");
}
template <class Fn> decltype(auto) visitTyped(Volume& v, Fn fn) {
    switch (v.type()) {
    case ScalarType::UInt8:
        return fn(v.values<std::uint8_t>());
    case ScalarType::UInt16:
        return fn(v.values<std::uint16_t>());
    case ScalarType::Int16:
        return fn(v.values<std::int16_t>());
    case ScalarType::Float32:
        return fn(v.values<float>());
    }
    throw Error("internal: unknown scalar type");
}

// Converts a reconstructed value to the voxel type: round to nearest and clamp for integers.
template <class T> T toVoxel(double v) {
    if constexpr (std::is_same_v<T, float>) {
        return static_cast<float>(v);
    } else {
        const double r = std::nearbyint(v);
        return static_cast<T>(
            std::clamp(r, double(std::numeric_limits<T>::min()), double(std::numeric_limits<T>::max())));
    }
}

// Bricks of equal dims are transformed together in one batch.
struct BrickGroup {
    Dims dims;
    std::vector<std::size_t> bricks;
};
std::vector<BrickGroup> groupBricks(const VczHeader& h, const std::vector<std::size_t>& which) {
    std::vector<BrickGroup> groups;
    for (std::size_t b : which) {
        const Dims d = h.brickDims(b);
        auto it =
            std::find_if(groups.begin(), groups.end(), [&](const BrickGroup& g) { return g.dims == d; });
        if (it == groups.end()) {
            groups.push_back({d, {}});
            it = groups.end() - 1;
        }
        it->bricks.push_back(b);
    }
    return groups;
}

// Dense brick arrays (brick dims, x fastest) <-> the batch's padded layout.
template <class T>
void toBatch(const BrickBatch<T>& b, std::size_t slot, std::span<const T> dense, std::vector<T>& host) {
    const Dims d = b.brick();
    for (std::size_t z = 0; z < d.z; ++z)
        for (std::size_t y = 0; y < d.y; ++y)
            std::copy_n(dense.data() + (z * d.y + y) * d.x, d.x,
                        host.data() + slot * b.brickStride() + (z * d.y + y) * b.pitch());
}
template <class T>
void fromBatch(const BrickBatch<T>& b, std::size_t slot, const std::vector<T>& host, std::span<T> dense) {
    const Dims d = b.brick();
    for (std::size_t z = 0; z < d.z; ++z)
        for (std::size_t y = 0; y < d.y; ++y)
            std::copy_n(host.data() + slot * b.brickStride() + (z * d.y + y) * b.pitch(), d.x,
                        dense.data() + (z * d.y + y) * d.x);
}

// Voxels of one brick of the volume as T (dense brick layout).
template <class T> std::vector<T> brickVoxels(const Volume& v, const VczHeader& h, std::size_t brick) {
    const Dims o = h.brickOrigin(brick), d = h.brickDims(brick);
    std::vector<T> out(d.count());
    visitTyped(v, [&](auto src) {
        for (std::size_t z = 0; z < d.z; ++z)
            for (std::size_t y = 0; y < d.y; ++y) {
                const std::size_t s = v.index(o.x, o.y + y, o.z + z);
                T* dst = out.data() + (z * d.y + y) * d.x;
                for (std::size_t x = 0; x < d.x; ++x) {
                    if constexpr (std::is_same_v<T, std::int32_t> &&
                                  std::is_same_v<typename decltype(src)::element_type, const float>) {
                        std::int32_t bits;
                        std::memcpy(&bits, &src[s + x], 4);
                        dst[x] = bits;
                    } else {
                        dst[x] = static_cast<T>(src[s + x]);
                    }
                }
            }
    });
    return out;
}

// Forward transform of the listed bricks; returns dense coefficient arrays and adds kernel time to `ms`.
template <class T>
std::vector<std::vector<T>> forwardBricks(ComputeContext& cc, LiftingTransform<T>& t, const Volume& v,
                                          const VczHeader& h, double& ms) {
    std::vector<std::size_t> all(h.brickCount());
    for (std::size_t i = 0; i < all.size(); ++i)
        all[i] = i;
    std::vector<std::vector<T>> coeffs(all.size());
    for (const BrickGroup& g : groupBricks(h, all)) {
        BrickBatch<T> batch(cc, g.dims, g.bricks.size());
        std::vector<T> host = batch.makeHost();
        for (std::size_t s = 0; s < g.bricks.size(); ++s) {
            coeffs[g.bricks[s]] = brickVoxels<T>(v, h, g.bricks[s]);
            toBatch<T>(batch, s, coeffs[g.bricks[s]], host);
        }
        batch.upload(cc, host);
        ms += t.forward(cc, batch, h.levels);
        batch.download(cc, host);
        for (std::size_t s = 0; s < g.bricks.size(); ++s)
            fromBatch<T>(batch, s, host, coeffs[g.bricks[s]]);
    }
    return coeffs;
}

// Inverse transform of dense coefficient arrays (brick dims) in place, stopping at `level`.
template <class T>
void inverseBricks(ComputeContext& cc, LiftingTransform<T>& t, const VczHeader& h,
                   const std::vector<std::size_t>& which, std::vector<std::vector<T>>& coeffs, int level) {
    for (const BrickGroup& g : groupBricks(h, which)) {
        BrickBatch<T> batch(cc, g.dims, g.bricks.size());
        std::vector<T> host = batch.makeHost();
        for (std::size_t s = 0; s < g.bricks.size(); ++s)
            toBatch<T>(batch, s, coeffs[g.bricks[s]], host);
        batch.upload(cc, host);
        t.inverse(cc, batch, h.levels, level);
        batch.download(cc, host);
        for (std::size_t s = 0; s < g.bricks.size(); ++s)
            fromBatch<T>(batch, s, host, coeffs[g.bricks[s]]);
    }
}

// ------------------------------------------------------------------------------ quantisation

// L2 norm of the 1D synthesis basis function of a level-l low or high coefficient.
double synthesisGain(Wavelet w, int level, bool high) {
    const std::size_t n = 1024;
    std::vector<double> line(n, 0.0);
    const std::size_t lowLen = n >> level, highLen = (n >> (level - 1)) - lowLen;
    line[high ? lowLen + highLen / 2 : lowLen / 2] = 1.0;
    reference::inverse3d(std::span<double>(line), {n, 1, 1}, level, w);
    double s = 0;
    for (double v : line)
        s += v * v;
    return std::sqrt(s);
}

// Per-subband steps: a coefficient error e costs about e * gain in the voxel domain, so step = delta / gain.
std::vector<double> subbandSteps(Wavelet w, int levels, double delta) {
    std::vector<double> steps;
    if (levels == 0) return {delta};
    const double lowGain = synthesisGain(w, levels, false);
    steps.push_back(delta / (lowGain * lowGain * lowGain));
    for (int l = 1; l <= levels; ++l) {
        const double gl = synthesisGain(w, l, false), gh = synthesisGain(w, l, true);
        for (int o = 1; o < 8; ++o) {
            const double g = ((o & 1) ? gh : gl) * ((o & 2) ? gh : gl) * ((o & 4) ? gh : gl);
            steps.push_back(delta / g);
        }
    }
    return steps;
}

// Calls fn(index, step) for every coefficient of a brick of dims d.
template <class Fn> void forEachSubbandCoefficient(const VczHeader& h, Dims d, Fn fn) {
    const auto layout = sectionLayout(d, h.levels);
    for (const auto& sec : layout)
        for (const SubbandBox& b : sec) {
            const double step = h.step(b.level, b.orient);
            for (std::size_t z = b.z0; z < b.z1; ++z)
                for (std::size_t y = b.y0; y < b.y1; ++y)
                    for (std::size_t x = b.x0; x < b.x1; ++x)
                        fn((z * d.y + y) * d.x + x, step);
        }
}

std::vector<std::int32_t> quantise(const VczHeader& h, Dims d, const std::vector<float>& c) {
    std::vector<std::int32_t> q(c.size());
    forEachSubbandCoefficient(h, d, [&](std::size_t i, double step) {
        const double a = std::floor(std::abs(double(c[i])) / step);
        const auto m = static_cast<std::int32_t>(std::min(a, kMaxQuantIndex));
        q[i] = c[i] < 0 ? -m : m;
    });
    return q;
}

std::vector<float> dequantise(const VczHeader& h, Dims d, std::span<const std::int32_t> q) {
    std::vector<float> c(q.size());
    forEachSubbandCoefficient(h, d, [&](std::size_t i, double step) {
        const std::int32_t v = q[i];
        c[i] = v == 0 ? 0.0f
                      : static_cast<float>((v < 0 ? -1.0 : 1.0) *
                                           (std::abs(double(v)) + h.reconstructionBias) * step);
    });
    return c;
}

// ------------------------------------------------------------------------------ brick payloads

struct Correction {
    std::uint32_t index;
    double value;
};

void putVarint(std::vector<std::uint8_t>& out, std::uint64_t v) {
    while (v >= 0x80) {
        out.push_back(static_cast<std::uint8_t>(v | 0x80));
        v >>= 7;
    }
    out.push_back(static_cast<std::uint8_t>(v));
}
std::uint64_t getVarint(std::span<const std::uint8_t> in, std::size_t& pos, const std::string& what) {
    std::uint64_t v = 0;
    for (int shift = 0; shift < 64; shift += 7) {
        if (pos >= in.size()) throw IoError(what + ": truncated corrections");
        const std::uint8_t b = in[pos++];
        v |= std::uint64_t(b & 0x7f) << shift;
        if (!(b & 0x80)) return v;
    }
    throw IoError(what + ": invalid corrections");
}

std::vector<std::uint8_t> encodeCorrections(const std::vector<Correction>& corr, ScalarType type) {
    std::vector<std::uint8_t> raw;
    putVarint(raw, corr.size());
    std::uint32_t prev = 0;
    for (const Correction& c : corr) {
        putVarint(raw, c.index - prev);
        prev = c.index;
        std::uint8_t bytes[4];
        switch (type) {
        case ScalarType::UInt8:
            bytes[0] = static_cast<std::uint8_t>(c.value);
            break;
        case ScalarType::UInt16: {
            auto v = static_cast<std::uint16_t>(c.value);
            std::memcpy(bytes, &v, 2);
            break;
        }
        case ScalarType::Int16: {
            auto v = static_cast<std::int16_t>(c.value);
            std::memcpy(bytes, &v, 2);
            break;
        }
        case ScalarType::Float32: {
            auto v = static_cast<float>(c.value);
            std::memcpy(bytes, &v, 4);
            break;
        }
        }
        raw.insert(raw.end(), bytes, bytes + scalarSize(type));
    }
    std::vector<std::uint8_t> out(ZSTD_compressBound(raw.size()));
    const std::size_t n = ZSTD_compress(out.data(), out.size(), raw.data(), raw.size(), 3);
    if (ZSTD_isError(n)) throw Error(std::string("zstd compression failed: ") + ZSTD_getErrorName(n));
    out.resize(n);
    return out;
}

std::vector<Correction> decodeCorrections(std::span<const std::uint8_t> in, ScalarType type,
                                          std::size_t brickVoxels, const std::string& what) {
    const unsigned long long size = ZSTD_getFrameContentSize(in.data(), in.size());
    const std::size_t maxSize = 10 + brickVoxels * (5 + scalarSize(type));
    if (size == ZSTD_CONTENTSIZE_ERROR || size == ZSTD_CONTENTSIZE_UNKNOWN || size > maxSize)
        throw IoError(what + ": invalid corrections");
    std::vector<std::uint8_t> raw(size);
    const std::size_t n = ZSTD_decompress(raw.data(), raw.size(), in.data(), in.size());
    if (ZSTD_isError(n) || n != raw.size()) throw IoError(what + ": invalid corrections");
    std::size_t pos = 0;
    const std::uint64_t count = getVarint(raw, pos, what);
    if (count > brickVoxels) throw IoError(what + ": invalid corrections");
    std::vector<Correction> out(count);
    std::uint64_t index = 0;
    for (Correction& c : out) {
        index += getVarint(raw, pos, what);
        if (index >= brickVoxels || raw.size() - pos < scalarSize(type))
            throw IoError(what + ": invalid corrections");
        c.index = static_cast<std::uint32_t>(index);
        const std::uint8_t* b = raw.data() + pos;
        switch (type) {
        case ScalarType::UInt8:
            c.value = b[0];
            break;
        case ScalarType::UInt16: {
            std::uint16_t v;
            std::memcpy(&v, b, 2);
            c.value = v;
            break;
        }
        case ScalarType::Int16: {
            std::int16_t v;
            std::memcpy(&v, b, 2);
            c.value = v;
            break;
        }
        case ScalarType::Float32: {
            float v;
            std::memcpy(&v, b, 4);
            c.value = v;
            break;
        }
        }
        pos += scalarSize(type);
    }
    return out;
}

// Payload: u8 section count, u8 flags (bit 0: corrections), u32 size per section, u32 corrections size, data.
std::vector<std::uint8_t> buildPayload(const VczHeader& h, Dims d, std::span<const std::int32_t> q,
                                       const std::vector<Correction>& corr) {
    const int levels = h.transform == TransformKind::RawBits ? 0 : h.levels;
    const auto layout = sectionLayout(d, levels);
    std::vector<std::vector<std::uint8_t>> sections(layout.size());
    for (std::size_t s = 0; s < layout.size(); ++s)
        encodeSection(q, d, layout, s, h.entropy, sections[s]);
    std::vector<std::uint8_t> corrBytes;
    if (!corr.empty()) corrBytes = encodeCorrections(corr, h.type);
    std::vector<std::uint8_t> out;
    out.push_back(static_cast<std::uint8_t>(layout.size()));
    out.push_back(corr.empty() ? 0 : 1);
    auto put32 = [&](std::size_t v) {
        const auto u = static_cast<std::uint32_t>(v);
        out.insert(out.end(), reinterpret_cast<const std::uint8_t*>(&u),
                   reinterpret_cast<const std::uint8_t*>(&u) + 4);
    };
    for (const auto& s : sections)
        put32(s.size());
    put32(corrBytes.size());
    for (const auto& s : sections)
        out.insert(out.end(), s.begin(), s.end());
    out.insert(out.end(), corrBytes.begin(), corrBytes.end());
    return out;
}

struct ParsedPayload {
    std::vector<std::span<const std::uint8_t>> sections;
    std::span<const std::uint8_t> corrections;
};
ParsedPayload parsePayload(std::span<const std::uint8_t> p, std::size_t expectedSections,
                           const std::string& what) {
    if (p.size() < 2 || p[0] != expectedSections || p[1] > 1) throw IoError(what + ": invalid brick header");
    std::size_t pos = 2;
    auto get32 = [&]() -> std::size_t {
        if (p.size() - pos < 4) throw IoError(what + ": truncated brick header");
        std::uint32_t v;
        std::memcpy(&v, p.data() + pos, 4);
        pos += 4;
        return v;
    };
    std::vector<std::size_t> sizes(expectedSections + 1);
    for (auto& s : sizes)
        s = get32();
    ParsedPayload out;
    for (std::size_t i = 0; i <= expectedSections; ++i) {
        if (sizes[i] > p.size() - pos) throw IoError(what + ": section sizes exceed the brick");
        auto span = p.subspan(pos, sizes[i]);
        pos += sizes[i];
        if (i < expectedSections)
            out.sections.push_back(span);
        else
            out.corrections = span;
    }
    if (pos != p.size()) throw IoError(what + ": unexpected bytes after the brick data");
    if ((p[1] == 1) != !out.corrections.empty()) throw IoError(what + ": inconsistent corrections flag");
    return out;
}

// ------------------------------------------------------------------------------ encoder

struct FrameResult {
    std::vector<std::vector<std::uint8_t>> payloads;
    std::vector<std::pair<double, double>> ranges;
    EncodeReport report;
};

struct ErrorStats {
    double sumSq = 0, maxErr = 0;
};

class Encoder {
public:
    Encoder(ComputeContext& cc, const CodecOptions& o) : cc_(cc), o_(o) {}

    VczHeader plan(const Volume& v) {
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

    FrameResult encodeFrame(const Volume& v, VczHeader& h, bool chooseStep) {
        if (h.transform == TransformKind::IntegerLifting) return encodeLossless(v, h);
        if (h.transform == TransformKind::RawBits) return encodeRaw(v, h);
        return encodeLossy(v, h, chooseStep);
    }

private:
    std::vector<std::pair<double, double>> brickRanges(const Volume& v, const VczHeader& h) {
        std::vector<std::pair<double, double>> r(h.brickCount());
        parallelFor(r.size(), o_.threads, [&](std::size_t b) {
            const auto vox = brickVoxels<double>(v, h, b);
            double lo = std::numeric_limits<double>::infinity(), hi = -lo;
            for (double x : vox)
                if (!std::isnan(x)) {
                    lo = std::min(lo, x);
                    hi = std::max(hi, x);
                }
            if (lo > hi) lo = hi = 0;
            r[b] = {lo, hi};
        });
        return r;
    }

    FrameResult encodeLossless(const Volume& v, VczHeader& h) {
        LiftingTransform<std::int32_t> t(cc_, h.wavelet);
        FrameResult r;
        auto coeffs = forwardBricks(cc_, t, v, h, r.report.transformMs);
        r.payloads.resize(coeffs.size());
        parallelFor(coeffs.size(), o_.threads,
                    [&](std::size_t b) { r.payloads[b] = buildPayload(h, h.brickDims(b), coeffs[b], {}); });
        r.ranges = brickRanges(v, h);
        r.report.psnr = std::numeric_limits<double>::infinity();
        return r;
    }

    FrameResult encodeRaw(const Volume& v, VczHeader& h) {
        FrameResult r;
        r.payloads.resize(h.brickCount());
        parallelFor(r.payloads.size(), o_.threads, [&](std::size_t b) {
            const auto bits = brickVoxels<std::int32_t>(v, h, b);
            r.payloads[b] = buildPayload(h, h.brickDims(b), bits, {});
        });
        r.ranges = brickRanges(v, h);
        r.report.psnr = std::numeric_limits<double>::infinity();
        return r;
    }

    // Quantises with the header's steps, reconstructs like the decoder and measures the error;
    // with `bound` it also lists the voxels to store exactly.
    struct Trial {
        std::vector<std::vector<std::int32_t>> q;
        std::vector<std::vector<Correction>> corrections;
        ErrorStats err;
    };
    Trial trial(const Volume& v, const VczHeader& h, LiftingTransform<float>& t,
                const std::vector<std::vector<float>>& coeffs, std::optional<double> bound) {
        Trial tr;
        const std::size_t n = coeffs.size();
        tr.q.resize(n);
        tr.corrections.resize(n);
        std::vector<std::vector<float>> rec(n);
        parallelFor(n, o_.threads, [&](std::size_t b) {
            tr.q[b] = quantise(h, h.brickDims(b), coeffs[b]);
            rec[b] = dequantise(h, h.brickDims(b), tr.q[b]);
        });
        std::vector<std::size_t> all(n);
        for (std::size_t i = 0; i < n; ++i)
            all[i] = i;
        inverseBricks(cc_, t, h, all, rec, 0);
        std::vector<ErrorStats> es(n);
        parallelFor(n, o_.threads, [&](std::size_t b) {
            const auto orig = brickVoxels<double>(v, h, b);
            visitTyped(v, [&](auto span) {
                using V = std::remove_const_t<typename decltype(span)::element_type>;
                for (std::size_t i = 0; i < orig.size(); ++i) {
                    const double e = std::abs(double(toVoxel<V>(rec[b][i])) - orig[i]);
                    if (bound && e > *bound) {
                        tr.corrections[b].push_back({static_cast<std::uint32_t>(i), orig[i]});
                        continue;
                    }
                    es[b].sumSq += e * e;
                    es[b].maxErr = std::max(es[b].maxErr, e);
                }
            });
        });
        for (const auto& e : es) {
            tr.err.sumSq += e.sumSq;
            tr.err.maxErr = std::max(tr.err.maxErr, e.maxErr);
        }
        return tr;
    }

    std::size_t codedBytes(const VczHeader& h, const Trial& tr,
                           std::vector<std::vector<std::uint8_t>>* payloads) {
        std::vector<std::vector<std::uint8_t>> p(tr.q.size());
        parallelFor(p.size(), o_.threads, [&](std::size_t b) {
            p[b] = buildPayload(h, h.brickDims(b), tr.q[b], tr.corrections[b]);
        });
        std::size_t total = vczPreambleSize(h);
        for (const auto& x : p)
            total += x.size();
        if (payloads) *payloads = std::move(p);
        return total;
    }

    FrameResult encodeLossy(const Volume& v, VczHeader& h, bool chooseStep) {
        const VolumeStats st = v.stats(1);
        if (st.nanCount > 0 || st.infCount > 0)
            throw DataError(
                "lossy encoding needs finite voxels (found NaN/Inf): use --lossless to keep them exactly");
        LiftingTransform<float> t(cc_, h.wavelet);
        FrameResult r;
        auto coeffs = forwardBricks(cc_, t, v, h, r.report.transformMs);
        for (const auto& c : coeffs)
            for (float x : c)
                if (!std::isfinite(x))
                    throw DataError("voxel values too large for the float transform: use --lossless");
        const double range = st.max - st.min;
        const double n = double(v.voxelCount());
        const double rangeSq = range * range;
        double lastDelta = 0, bestDelta = 0;
        auto setDelta = [&](double delta) {
            lastDelta = delta;
            h.steps = subbandSteps(h.wavelet, h.levels, delta);
            clampSteps(h, coeffs);
        };
        Trial best;
        if (o_.step && chooseStep) {
            if (!(*o_.step > 0) || !std::isfinite(*o_.step))
                throw UsageError("the quantiser step must be a positive number");
            setDelta(*o_.step);
            chooseStep = false;
        }
        if (!chooseStep) {
            bestDelta = lastDelta;
            best = trial(v, h, t, coeffs,
                         h.rate == RateMode::MaxError ? std::optional(o_.target) : std::nullopt);
        } else if (h.rate == RateMode::MaxError) {
            // Larger steps leave more voxels to store exactly: keep the candidate with the smallest file.
            std::size_t bestBytes = std::numeric_limits<std::size_t>::max();
            std::vector<double> bestSteps;
            for (double k : {0.9, 1.4, 2.0, 2.8}) {
                setDelta(k * o_.target);
                Trial tr = trial(v, h, t, coeffs, o_.target);
                const std::size_t bytes = codedBytes(h, tr, nullptr);
                if (bytes < bestBytes) {
                    bestBytes = bytes;
                    best = std::move(tr);
                    bestSteps = h.steps;
                    bestDelta = lastDelta;
                }
            }
            h.steps = bestSteps;
        } else {
            // Bisection on log2(delta) around a first guess. PSNR falls and size shrinks as delta grows: keep
            // the largest delta with PSNR >= P, or the smallest with size <= R bits/voxel.
            const bool psnrMode = h.rate == RateMode::Psnr;
            const double guess =
                psnrMode ? std::log2(std::max(range, 1e-30) * std::pow(10.0, -o_.target / 20) * 3.0)
                         : std::log2(std::max(range, 1e-30)) - 2 * o_.target;
            // Rate targets span many octaves of delta (a smooth volume fits 1 bit/voxel at tiny steps).
            double lo = psnrMode ? guess - 8 : guess - 30, hi = guess + 8;
            bool found = false;
            std::vector<double> bestSteps;
            for (int attempt = 0; attempt < 2 && !found; ++attempt) {
                if (attempt == 1) { // widen once when the first bracket missed
                    lo = psnrMode ? guess - 40 : guess;
                    hi = psnrMode ? guess : guess + 40;
                }
                for (int it = 0; it < 24 && hi - lo > 0.02; ++it) {
                    const double mid = 0.5 * (lo + hi);
                    setDelta(std::exp2(mid));
                    Trial tr = trial(v, h, t, coeffs, std::nullopt);
                    double quality;
                    bool ok;
                    if (psnrMode) {
                        const double mse = tr.err.sumSq / n;
                        quality = mse == 0 ? std::numeric_limits<double>::infinity()
                                           : 10 * std::log10(rangeSq / mse);
                        ok = range == 0 || quality >= o_.target;
                    } else {
                        quality = double(codedBytes(h, tr, nullptr)) * 8 / n;
                        ok = quality <= o_.target;
                    }
                    if (ok) {
                        found = true;
                        best = std::move(tr);
                        bestSteps = h.steps;
                        bestDelta = lastDelta;
                        if (psnrMode && quality < o_.target + 0.25) break;
                    }
                    // PSNR: ok -> try a larger step. Rate: ok -> try a smaller step.
                    if (ok == psnrMode)
                        lo = mid;
                    else
                        hi = mid;
                }
            }
            if (!found) {
                if (!psnrMode)
                    throw UsageError("--bpv " + std::to_string(o_.target) +
                                     " is below what this volume can be coded in");
                setDelta(std::exp2(lo));
                best = trial(v, h, t, coeffs, std::nullopt);
                bestSteps = h.steps;
                bestDelta = lastDelta;
            }
            h.steps = bestSteps;
        }
        codedBytes(h, best, &r.payloads);
        r.report.step = bestDelta;
        std::size_t corr = 0;
        for (const auto& c : best.corrections)
            corr += c.size();
        r.report.corrections = corr;
        r.report.maxError = best.err.maxErr;
        const double mse = best.err.sumSq / n;
        r.report.psnr = mse == 0 ? std::numeric_limits<double>::infinity() : 10 * std::log10(rangeSq / mse);
        r.ranges = brickRanges(v, h);
        return r;
    }

    // Keeps quantisation indices inside the coder's range for data of huge dynamic range.
    static void clampSteps(VczHeader& h, const std::vector<std::vector<float>>& coeffs) {
        std::vector<double> maxAbs(h.steps.size(), 0.0);
        for (std::size_t b = 0; b < coeffs.size(); ++b) {
            const auto layout = sectionLayout(h.brickDims(b), h.levels);
            const Dims d = h.brickDims(b);
            for (const auto& sec : layout)
                for (const SubbandBox& sb : sec) {
                    const std::size_t si =
                        sb.level == 0 ? 0 : 1 + std::size_t(sb.level - 1) * 7 + std::size_t(sb.orient - 1);
                    for (std::size_t z = sb.z0; z < sb.z1; ++z)
                        for (std::size_t y = sb.y0; y < sb.y1; ++y)
                            for (std::size_t x = sb.x0; x < sb.x1; ++x)
                                maxAbs[si] = std::max(maxAbs[si],
                                                      double(std::abs(coeffs[b][(z * d.y + y) * d.x + x])));
                }
        }
        for (std::size_t i = 0; i < h.steps.size(); ++i)
            h.steps[i] = std::max(h.steps[i], maxAbs[i] / (kMaxQuantIndex - 2));
    }

    ComputeContext& cc_;
    const CodecOptions& o_;
};

std::vector<std::byte> assemble(VczHeader& h, std::vector<FrameResult>& frames) {
    h.bricks.assign(frames.size(), std::vector<VczBrickEntry>(h.brickCount()));
    std::size_t offset = vczPreambleSize(h);
    std::vector<std::vector<std::uint8_t>> payloads;
    for (std::size_t f = 0; f < frames.size(); ++f) {
        for (std::size_t b = 0; b < h.brickCount(); ++b) {
            auto& p = frames[f].payloads[b];
            VczBrickEntry& e = h.bricks[f][b];
            e.offset = offset;
            e.size = p.size();
            e.checksum = vczChecksum(p);
            e.min = frames[f].ranges[b].first;
            e.max = frames[f].ranges[b].second;
            offset += p.size();
            payloads.push_back(std::move(p));
        }
    }
    return writeVcz(h, payloads);
}

} // namespace

std::vector<std::byte> encodeVolume(ComputeContext& cc, const Volume& volume, const CodecOptions& options,
                                    EncodeReport* report) {
    Encoder enc(cc, options);
    VczHeader h = enc.plan(volume);
    const VolumeStats st = volume.stats(1);
    h.valueMin = st.min;
    h.valueMax = st.max;
    std::vector<FrameResult> frames;
    frames.push_back(enc.encodeFrame(volume, h, true));
    auto bytes = assemble(h, frames);
    if (report) {
        *report = frames[0].report;
        report->bytes = bytes.size();
        report->bitsPerVoxel = double(bytes.size()) * 8 / double(volume.voxelCount());
    }
    return bytes;
}

std::vector<std::byte> encodeSeries(ComputeContext& cc, const TimeSeries& series,
                                    const CodecOptions& options) {
    series.validate();
    if (series.frames.empty()) throw UsageError("cannot encode an empty time series");
    Encoder enc(cc, options);
    VczHeader h = enc.plan(series.frames[0]);
    h.frames.resize(series.frames.size());
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    std::vector<FrameResult> frames;
    for (std::size_t f = 0; f < series.frames.size(); ++f) {
        const VolumeStats st = series.frames[f].stats(1);
        lo = std::min(lo, st.min);
        hi = std::max(hi, st.max);
        if (f < series.times.size()) h.frames[f].time = series.times[f];
        // Rate searches run on the first frame; later frames reuse its steps (one header for the series).
        frames.push_back(enc.encodeFrame(series.frames[f], h, f == 0));
    }
    h.valueMin = lo;
    h.valueMax = hi;
    return assemble(h, frames);
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

namespace {

// Decoded bricks at one level, as float or int32 (dense, levelDims(brickDims, level)).
struct DecodedBricks {
    std::vector<std::vector<std::int32_t>> ints;
    std::vector<std::vector<float>> floats;
    std::vector<std::vector<Correction>> corrections;
};

DecodedBricks decodeBricks(ComputeContext& cc, std::span<const std::byte> file, const VczHeader& h,
                           std::size_t frame, const std::vector<std::size_t>& which, int level,
                           unsigned threads, const std::string& name) {
    if (frame >= h.frames.size()) throw UsageError(name + ": no frame " + std::to_string(frame));
    if (h.frames[frame].type != FrameType::I)
        throw DataError(name + ": frame " + std::to_string(frame) +
                        " is a motion-compensated frame; this decoder reads I frames");
    const std::size_t n = h.brickCount();
    const int levels = h.transform == TransformKind::RawBits ? 0 : h.levels;
    const int stop = h.transform == TransformKind::RawBits ? 0 : level;
    DecodedBricks out;
    out.ints.resize(n);
    out.corrections.resize(n);
    parallelFor(which.size(), threads, [&](std::size_t k) {
        const std::size_t b = which[k];
        const std::string what = name + ": brick " + std::to_string(b);
        const auto payload = vczBrickPayload(file, h, frame, b, name);
        const Dims d = h.brickDims(b);
        const auto layout = sectionLayout(d, levels);
        const ParsedPayload p = parsePayload(payload, layout.size(), what);
        out.ints[b].assign(d.count(), 0);
        for (std::size_t s = 0; s + stop < layout.size(); ++s)
            decodeSection(p.sections[s], out.ints[b], d, layout, s, h.entropy, what.c_str());
        if (!p.corrections.empty() && level == 0)
            out.corrections[b] = decodeCorrections(p.corrections, h.type, d.count(), what);
    });
    if (h.transform == TransformKind::IntegerLifting) {
        LiftingTransform<std::int32_t> t(cc, h.wavelet);
        inverseBricks(cc, t, h, which, out.ints, level);
    } else if (h.transform == TransformKind::FloatLifting) {
        out.floats.resize(n);
        parallelFor(which.size(), threads, [&](std::size_t k) {
            const std::size_t b = which[k];
            out.floats[b] = dequantise(h, h.brickDims(b), out.ints[b]);
            std::vector<std::int32_t>().swap(out.ints[b]);
        });
        LiftingTransform<float> t(cc, h.wavelet);
        inverseBricks(cc, t, h, which, out.floats, level);
    }
    return out;
}

// Copies the samples of decoded brick b that fall in [a, e) (level-k sample indices; sample j sits at
// full-resolution voxel j * 2^k) into `out`. Lifting bricks hold the level-k approximation in their low
// corner; raw bricks are decimated.
template <class V>
void placeBrick(const VczHeader& h, const DecodedBricks& db, std::size_t b, int level, Dims a, Dims e,
                std::span<V> out, Dims outDims) {
    const Dims o = h.brickOrigin(b), d = h.brickDims(b);
    const bool raw = h.transform == TransformKind::RawBits;
    const std::size_t f = std::size_t(1) << level;
    auto up = [f](std::size_t v) { return (v + f - 1) / f; };
    const Dims first{up(o.x), up(o.y), up(o.z)}, last{up(o.x + d.x), up(o.y + d.y), up(o.z + d.z)};
    auto local = [&](std::size_t j, std::size_t origin, std::size_t firstJ) {
        return raw ? j * f - origin : j - firstJ;
    };
    for (std::size_t z = std::max(first.z, a.z); z < std::min(last.z, e.z); ++z)
        for (std::size_t y = std::max(first.y, a.y); y < std::min(last.y, e.y); ++y) {
            const std::size_t row = (local(z, o.z, first.z) * d.y + local(y, o.y, first.y)) * d.x;
            V* dst = out.data() + ((z - a.z) * outDims.y + (y - a.y)) * outDims.x;
            for (std::size_t x = std::max(first.x, a.x); x < std::min(last.x, e.x); ++x) {
                const std::size_t i = row + local(x, o.x, first.x);
                V v;
                if (raw) {
                    if constexpr (std::is_same_v<V, float>) {
                        std::memcpy(&v, &db.ints[b][i], 4);
                    } else {
                        v = static_cast<V>(db.ints[b][i]);
                    }
                } else if (h.transform == TransformKind::IntegerLifting) {
                    v = toVoxel<V>(double(db.ints[b][i]));
                } else {
                    v = toVoxel<V>(double(db.floats[b][i]));
                }
                dst[x - a.x] = v;
            }
        }
    if (level == 0)
        for (const Correction& c : db.corrections[b]) {
            const std::size_t x = o.x + c.index % d.x, y = o.y + c.index / d.x % d.y,
                              z = o.z + c.index / (d.x * d.y);
            if (x >= a.x && x < e.x && y >= a.y && y < e.y && z >= a.z && z < e.z)
                out[((z - a.z) * outDims.y + (y - a.y)) * outDims.x + (x - a.x)] = static_cast<V>(c.value);
        }
}

} // namespace

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
    const DecodedBricks db = decodeBricks(cc, bytes_, h, o.frame, which, o.level, o.threads, name_);
    Volume out(outDims, h.type);
    for (int i = 0; i < 3; ++i) {
        const std::size_t first = i == 0 ? a.x : i == 1 ? a.y : a.z;
        out.spacing[i] = h.spacing[i] * double(f);
        out.origin[i] = h.origin[i] + double(first * f) * h.spacing[i];
    }
    visitTyped(out, [&](auto span) {
        for (std::size_t b : which)
            placeBrick(h, db, b, o.level, a, e, span, outDims);
    });
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

// ------------------------------------------------------------------------------ metrics

namespace {
template <class Fn> void forEachPair(const Volume& a, const Volume& b, Fn fn) {
    if (a.dims() != b.dims()) throw UsageError("volumes differ in dimensions: cannot compare");
    for (std::size_t i = 0; i < a.voxelCount(); ++i)
        fn(a.valueAt(i), b.valueAt(i));
}
} // namespace

double maxAbsError(const Volume& a, const Volume& b) {
    double m = 0;
    forEachPair(a, b, [&](double x, double y) { m = std::max(m, std::abs(x - y)); });
    return m;
}

double rmse(const Volume& a, const Volume& b) {
    double s = 0;
    forEachPair(a, b, [&](double x, double y) { s += (x - y) * (x - y); });
    return std::sqrt(s / double(a.voxelCount()));
}

double psnr(const Volume& a, const Volume& b) {
    const double e = rmse(a, b);
    const VolumeStats st = a.stats(1);
    if (e == 0) return std::numeric_limits<double>::infinity();
    if (st.max == st.min) return std::numeric_limits<double>::quiet_NaN();
    return 20 * std::log10((st.max - st.min) / e);
}

} // namespace volcl
