// .vcz serialisation and validated parsing (layout in docs/codec.md).
#include "wavelet/container/VczFormat.hpp"

#include "core/MemoryBudget.hpp"

#include "core/Error.hpp"
#include "wavelet/Varint.hpp"
#include "wavelet/entropy/EntropyCoder.hpp"
#include "wavelet/quantise/Corrections.hpp"
#include "wavelet/quantise/Quantiser.hpp"

#include <xxhash.h>
#include <zstd.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>

namespace volcl {

Dims VczHeader::brickGrid() const noexcept {
    auto n = [](std::size_t d, std::size_t b) { return b == 0 ? 0 : (d + b - 1) / b; };
    return {n(dims.x, brick.x), n(dims.y, brick.y), n(dims.z, brick.z)};
}

Dims VczHeader::brickOrigin(std::size_t i) const noexcept {
    const Dims g = brickGrid();
    return {(i % g.x) * brick.x, (i / g.x % g.y) * brick.y, (i / (g.x * g.y)) * brick.z};
}

Dims VczHeader::brickDims(std::size_t i) const noexcept {
    const Dims o = brickOrigin(i);
    return {std::min(brick.x, dims.x - o.x), std::min(brick.y, dims.y - o.y),
            std::min(brick.z, dims.z - o.z)};
}

double VczHeader::step(int level, int orient) const {
    const std::size_t i = subbandIndex(level, orient);
    if (i >= steps.size()) throw Error("internal: subband step index out of range");
    return steps[i];
}

std::uint64_t vczChecksum(std::span<const std::uint8_t> bytes) noexcept {
    return XXH3_64bits(bytes.data(), bytes.size());
}

namespace {

// Every checksum test of the reader. The libFuzzer build defines VOLCL_FUZZ_ACCEPT_ANY_CHECKSUM (for this
// file only, never with the tests or in a product build): a mutated input would otherwise almost never get
// past the checksums to the parser and decoder behind them (the approach of zstd's and libpng's fuzzers).
// `bits32`: version 5 and 6 payload checksums, the low 32 bits of the XXH3-64.
bool checksumMatches(std::uint64_t stored, std::span<const std::uint8_t> bytes,
                     bool bits32 = false) noexcept {
    const std::uint64_t actual = vczChecksum(bytes) & (bits32 ? 0xFFFFFFFFu : ~std::uint64_t(0));
#ifdef VOLCL_FUZZ_ACCEPT_ANY_CHECKSUM
    (void)stored;
    (void)actual; // still hashed: the hash reads every byte it claims, under the sanitizers
    return true;
#else
    return stored == actual;
#endif
}

class Writer {
public:
    std::vector<std::uint8_t> bytes;
    template <class T> void put(T v) {
        static_assert(std::endian::native == std::endian::little,
                      "volcl writes little-endian files on little-endian hosts");
        const auto* p = reinterpret_cast<const std::uint8_t*>(&v);
        bytes.insert(bytes.end(), p, p + sizeof(T));
    }
    void putString(const std::string& s) {
        put<std::uint32_t>(static_cast<std::uint32_t>(s.size()));
        bytes.insert(bytes.end(), s.begin(), s.end());
    }
    void putVar(std::uint64_t v) { putVarint(bytes, v); }
    void putVarString(const std::string& s) {
        putVar(s.size());
        bytes.insert(bytes.end(), s.begin(), s.end());
    }
    void putBytes(std::span<const std::uint8_t> b) { bytes.insert(bytes.end(), b.begin(), b.end()); }
};

class Reader {
public:
    Reader(std::span<const std::uint8_t> b, const std::string& name, const char* part)
        : b_(b), name_(name), part_(part) {}
    template <class T> T get() {
        need(sizeof(T));
        T v;
        std::memcpy(&v, b_.data() + pos_, sizeof(T));
        pos_ += sizeof(T);
        return v;
    }
    std::string getString() {
        const auto n = get<std::uint32_t>();
        need(n);
        std::string s(reinterpret_cast<const char*>(b_.data() + pos_), n);
        pos_ += n;
        return s;
    }
    std::uint64_t getVar() {
        std::uint64_t v;
        if (getVarint(b_, pos_, v) != VarintStatus::Ok) fail("truncated or overlong number");
        return v;
    }
    std::string getVarString() {
        const std::uint64_t n = getVar();
        need(n);
        std::string s(reinterpret_cast<const char*>(b_.data() + pos_), std::size_t(n));
        pos_ += std::size_t(n);
        return s;
    }
    std::span<const std::uint8_t> getBytes(std::uint64_t n) {
        need(n);
        const auto out = b_.subspan(pos_, std::size_t(n));
        pos_ += std::size_t(n);
        return out;
    }
    std::size_t remaining() const noexcept { return b_.size() - pos_; }
    const std::string& name() const noexcept { return name_; }
    [[noreturn]] void fail(const std::string& what) const {
        throw IoError(name_ + ": " + part_ + ": " + what);
    }

private:
    void need(std::uint64_t n) const {
        if (n > b_.size() - pos_) fail("truncated");
    }
    std::span<const std::uint8_t> b_;
    std::size_t pos_ = 0;
    const std::string& name_;
    const char* part_;
};

// Version 6 steps forms. Implied: the steps are subbandSteps(wavelet, levels, delta) but for a few an encoder
// raised (LossyFrame::setDelta keeps every quantised index in range), listed as overrides.
enum class StepsForm : std::uint8_t { Listed = 0, Implied = 1 };

// subbandSteps measures its gains on 1024-sample lines: deeper transforms than the encoder's are not implied.
constexpr int kMaxImpliedLevels = 8;

// The implied form of `steps`: delta and the overrides, or nothing when it does not apply. The encoder's
// delta is not stored in the header, so it is recovered from the low band's step: the nearest doubles
// around steps[0] x gain^3 are tried and the one that gives back the most steps bit for bit kept.
std::optional<std::vector<std::uint8_t>> impliedSteps(const VczHeader& h) {
    if (h.transform != TransformKind::FloatLifting || h.levels < 1 || h.levels > kMaxImpliedLevels ||
        h.steps.size() != 1 + 7 * std::size_t(h.levels))
        return std::nullopt;
    const std::vector<double> unit = codec::subbandSteps(h.wavelet, h.levels, 1.0);
    double delta = h.steps[0] / unit[0];
    for (int k = 0; k < 4; ++k)
        delta = std::nextafter(delta, 0.0);
    double best = 0;
    std::vector<std::size_t> overrides(h.steps.size() + 1);
    for (int k = 0; k < 9; ++k, delta = std::nextafter(delta, HUGE_VAL)) {
        if (!(delta > 0) || !std::isfinite(delta)) continue;
        const std::vector<double> implied = codec::subbandSteps(h.wavelet, h.levels, delta);
        std::vector<std::size_t> differ;
        for (std::size_t i = 0; i < implied.size(); ++i)
            if (std::bit_cast<std::uint64_t>(implied[i]) != std::bit_cast<std::uint64_t>(h.steps[i]))
                differ.push_back(i);
        if (differ.size() < overrides.size()) {
            overrides = std::move(differ);
            best = delta;
        }
    }
    if (overrides.size() > h.steps.size()) return std::nullopt;
    Writer w;
    w.put(best);
    w.putVar(overrides.size());
    for (std::size_t i : overrides) {
        w.putVar(i);
        w.put(h.steps[i]);
    }
    return std::move(w.bytes);
}

// What compactPreamble writes: the file's preamble, or one at least as long as any the header can have once
// its payload sizes, ranges and metadata values are final (vczPreambleBound).
enum class PreambleKind { Exact, Bound };

// The header's fixed fields as version 6 writes them: grid, kinds, geometry, rate and the quantisation steps,
// sizes as varints and the steps in the shorter of their two forms.
void putFixedFields(Writer& w, const VczHeader& h) {
    for (std::size_t v : {h.dims.x, h.dims.y, h.dims.z})
        w.putVar(v);
    w.put<std::uint8_t>(static_cast<std::uint8_t>(h.type));
    w.put<std::uint8_t>(static_cast<std::uint8_t>(h.transform));
    w.put<std::uint8_t>(static_cast<std::uint8_t>(h.wavelet));
    w.put<std::uint8_t>(static_cast<std::uint8_t>(h.levels));
    w.put<std::uint8_t>(static_cast<std::uint8_t>(h.entropy));
    w.put<std::uint8_t>(static_cast<std::uint8_t>(h.rate));
    for (double v : h.spacing)
        w.put(v);
    for (double v : h.origin)
        w.put(v);
    for (std::size_t v : {h.brick.x, h.brick.y, h.brick.z})
        w.putVar(v);
    w.put(h.rateTarget);
    w.put(h.reconstructionBias);
    w.put(h.valueMin);
    w.put(h.valueMax);
    const std::optional<std::vector<std::uint8_t>> implied = impliedSteps(h);
    if (implied && implied->size() < 1 + 8 * h.steps.size()) {
        w.put<std::uint8_t>(static_cast<std::uint8_t>(StepsForm::Implied));
        w.putBytes(*implied);
    } else {
        w.put<std::uint8_t>(static_cast<std::uint8_t>(StepsForm::Listed));
        w.putVar(h.steps.size());
        for (double s : h.steps)
            w.put(s);
    }
}

// Versions 5 and 6: the compact frame table and index.
bool compactLayout(std::uint32_t version) noexcept {
    return version >= kVczVersionSeries;
}

// Versions 5 and 6 keep the low 32 bits of each payload's and motion block's XXH3-64.
bool shortChecksums(const VczHeader& h) noexcept {
    return compactLayout(h.version);
}

constexpr std::size_t kIndexEntryBytes = 5 * 8;

// ---- Versions 5 and 6: the compact frame table and index ----

// How a compact index stores the brick ranges: the narrowest form that gives back every value bit for bit.
enum class RangeForm : std::uint8_t { Integer = 0, Float32 = 1, Float64 = 2 };

constexpr double kMaxExactInteger = 9007199254740992.0; // 2^53: every integer up to it is a double
// A zstd metadata block may expand at most this much (the writer stores the block raw otherwise), so a
// forged size is refused before anything is allocated.
constexpr std::uint64_t kMaxMetadataExpansion = 64;

RangeForm rangeForm(const VczHeader& h) {
    bool integer = true, single = true;
    for (const auto& frame : h.bricks)
        for (const VczBrickEntry& e : frame) {
            if (!(e.min <= e.max)) integer = false;
            for (double v : {e.min, e.max}) {
                if (!(std::abs(v) <= kMaxExactInteger) || v != std::floor(v) || (v == 0 && std::signbit(v)))
                    integer = false;
                // Out-of-range doubles are not converted (undefined); NaN payloads may not survive float.
                if (!(std::abs(v) <= double(std::numeric_limits<float>::max()) || std::isinf(v)) ||
                    std::bit_cast<std::uint64_t>(double(float(v))) != std::bit_cast<std::uint64_t>(v))
                    single = false;
            }
        }
    return integer ? RangeForm::Integer : single ? RangeForm::Float32 : RangeForm::Float64;
}

// Frame times of the form t0 + f dt are stored as t0 and dt. One function computes them for the writer's
// test and the reader, so both get the same doubles.
double uniformTime(double t0, double dt, std::size_t f) noexcept {
    return t0 + double(f) * dt;
}

// Frame time forms: 0 start and step, 1 one double per frame, 2 every time 0 (single volumes; version 6).
enum class TimeForm : std::uint8_t { Uniform = 0, Listed = 1, Zero = 2 };

bool uniformTimes(const VczHeader& h) noexcept {
    if (h.frames.size() < 2) return false;
    const double t0 = h.frames[0].time, dt = h.frames[1].time - t0;
    for (std::size_t f = 0; f < h.frames.size(); ++f)
        if (std::bit_cast<std::uint64_t>(uniformTime(t0, dt, f)) !=
            std::bit_cast<std::uint64_t>(h.frames[f].time))
            return false;
    return true;
}

std::vector<std::uint8_t> compactIndex(const VczHeader& h) {
    Writer w;
    const RangeForm form = rangeForm(h);
    w.put<std::uint8_t>(static_cast<std::uint8_t>(form));
    for (const auto& frame : h.bricks)
        for (const VczBrickEntry& e : frame) {
            w.putVar(e.size);
            w.put<std::uint32_t>(static_cast<std::uint32_t>(e.checksum));
            switch (form) {
            case RangeForm::Integer:
                w.putVar(zigzagEncode(static_cast<std::int64_t>(e.min)));
                w.putVar(static_cast<std::uint64_t>(static_cast<std::int64_t>(e.max) -
                                                    static_cast<std::int64_t>(e.min)));
                break;
            case RangeForm::Float32:
                w.put(float(e.min));
                w.put(float(e.max));
                break;
            case RangeForm::Float64:
                w.put(e.min);
                w.put(e.max);
                break;
            }
        }
    return std::move(w.bytes);
}

// Metadata as varint-length strings, zstd-compressed when that is smaller. A bound takes the stored form's
// size plus the longest compressed-size varint: any compressed form (shorter than stored) fits in it.
void putMetadataBlock(Writer& w, const std::map<std::string, std::string>& metadata, PreambleKind kind) {
    Writer m;
    m.putVar(metadata.size());
    for (const auto& [k, v] : metadata) {
        m.putVarString(k);
        m.putVarString(v);
    }
    w.putVar(m.bytes.size());
    if (kind == PreambleKind::Bound) {
        w.put<std::uint8_t>(0);
        w.putBytes(m.bytes);
        w.bytes.resize(w.bytes.size() + kMaxVarintBytes);
        return;
    }
    std::vector<std::uint8_t> packed(ZSTD_compressBound(m.bytes.size()));
    const std::size_t n = ZSTD_compress(packed.data(), packed.size(), m.bytes.data(), m.bytes.size(),
                                        m.bytes.size() < (std::size_t(1) << 20) ? 19 : 3);
    if (!ZSTD_isError(n) && n < m.bytes.size() && m.bytes.size() <= kMaxMetadataExpansion * n) {
        w.put<std::uint8_t>(1);
        w.putVar(n);
        w.putBytes(std::span(packed.data(), n));
    } else {
        w.put<std::uint8_t>(0);
        w.putBytes(m.bytes);
    }
}

struct CompactPreamble {
    std::vector<std::uint8_t> body, index;
};

// `padding`: zero bytes between the index's checksum and the first payload (version 6), which let a writer
// that must reserve the preamble before the payloads are known fill the room it reserved.
CompactPreamble compactPreamble(const VczHeader& h, std::uint64_t padding = 0,
                                PreambleKind kind = PreambleKind::Exact) {
    CompactPreamble p;
    p.index = compactIndex(h);
    Writer w;
    putFixedFields(w, h);
    w.putVar(h.frames.size());
    const bool zero = std::all_of(h.frames.begin(), h.frames.end(), [](const VczFrame& f) {
        return std::bit_cast<std::uint64_t>(f.time) == 0; // +0.0 only: -0.0 is listed
    });
    const TimeForm form = zero ? TimeForm::Zero : uniformTimes(h) ? TimeForm::Uniform : TimeForm::Listed;
    w.put<std::uint8_t>(static_cast<std::uint8_t>(form));
    if (form == TimeForm::Uniform) {
        w.put(h.frames[0].time);
        w.put(h.frames[1].time - h.frames[0].time);
    } else if (form == TimeForm::Listed) {
        for (const VczFrame& f : h.frames)
            w.put(f.time);
    }
    for (std::size_t i = 0; i < h.frames.size(); ++i) {
        const VczFrame& f = h.frames[i];
        w.put<std::uint8_t>(static_cast<std::uint8_t>(f.type));
        // References as distances: a P/B frame's earlier one, then a B frame's later one.
        if (f.type != FrameType::I) w.putVar(static_cast<std::uint64_t>(std::int64_t(i) - f.reference0));
        if (f.type == FrameType::B) w.putVar(static_cast<std::uint64_t>(f.reference1 - std::int64_t(i)));
        w.putVar(f.auxSize);
        if (f.auxSize) w.put<std::uint32_t>(static_cast<std::uint32_t>(f.auxChecksum));
    }
    putMetadataBlock(w, h.metadata, kind);
    w.putVar(p.index.size());
    w.putVar(padding);
    p.body = std::move(w.bytes);
    return p;
}

std::size_t preambleBytes(const CompactPreamble& p, std::uint64_t padding) {
    return kVczMagic.size() + 8 + p.body.size() + 8 + p.index.size() + 8 + std::size_t(padding);
}

// The frame table's references form what the decoder can follow: I frames reference nothing and carry no
// auxiliary block; a P frame references an earlier I/P frame; a B frame an earlier and a later one. So every
// chain of references ends at an I frame. Older versions hold I frames only.
void checkFrameReferences(const VczHeader& h, std::uint32_t version, const Reader& r) {
    const auto n = static_cast<std::int64_t>(h.frames.size());
    // Encoders write version 4 only for files that hold P/B frames.
    if (version == kVczVersionPredicted &&
        std::all_of(h.frames.begin(), h.frames.end(),
                    [](const VczFrame& f) { return f.type == FrameType::I; }))
        r.fail("unsupported .vcz version 4 for a file of I frames only (corrupt header)");
    // A float64 file's bricks are its float32 layer and every frame is an I frame.
    if (h.float64 && (h.type != ScalarType::Float32 ||
                      std::any_of(h.frames.begin(), h.frames.end(),
                                  [](const VczFrame& f) { return f.type != FrameType::I; })))
        r.fail("float64 layer beside bricks that are not float32 I frames (corrupt header)");
    auto anchor = [&](std::int32_t k) {
        return k >= 0 && k < n && h.frames[std::size_t(k)].type != FrameType::B;
    };
    for (std::int64_t f = 0; f < n; ++f) {
        const VczFrame& e = h.frames[std::size_t(f)];
        const std::string which = "frame " + std::to_string(f);
        if (e.type != FrameType::I && version < kVczVersionPredicted)
            r.fail(which + ": P/B frame in a version " + std::to_string(version) + " file");
        if (e.type != FrameType::I && h.transform == TransformKind::RawBits)
            r.fail(which + ": P/B frame of raw float bit planes");
        // An I frame's auxiliary block is its float64 layer in a float64 file, and absent otherwise.
        const bool ok =
            e.type == FrameType::I ? e.reference0 == -1 && e.reference1 == -1 && (e.auxSize != 0) == h.float64
            : e.type == FrameType::P
                ? anchor(e.reference0) && e.reference0 < f && e.reference1 == -1
                : anchor(e.reference0) && e.reference0 < f && anchor(e.reference1) && e.reference1 > f;
        if (!ok) r.fail(which + ": invalid references");
    }
}

} // namespace

std::size_t vczPreambleSize(const VczHeader& h) {
    return preambleBytes(compactPreamble(h), 0);
}

std::size_t vczPreambleBound(const VczHeader& h, bool sizesKnown) {
    // Ranges in a form at least as wide as the index's can be for the voxel type: integer voxels' ranges take
    // the integer form, at most 6 bytes a brick for 16-bit types, within the float32 form's 8; float voxels'
    // may be NaN (the float64 form, the widest).
    VczBrickEntry widest;
    const bool integer =
        h.type == ScalarType::UInt8 || h.type == ScalarType::UInt16 || h.type == ScalarType::Int16;
    widest.min = widest.max = integer ? 0.5 : std::numeric_limits<double>::quiet_NaN();
    VczHeader b = h;
    if (sizesKnown) {
        for (auto& frame : b.bricks)
            for (VczBrickEntry& e : frame) {
                e.min = widest.min;
                e.max = widest.max;
            }
        return preambleBytes(compactPreamble(b), 0);
    }
    // Payload and motion block sizes below 32 GB (five-byte varints); the index from the frame count and brick
    // grid, since rate searches bound it before the entries exist.
    constexpr std::uint64_t kLargest = (std::uint64_t(1) << 35) - 1;
    widest.size = kLargest;
    b.bricks.assign(b.frames.size(), std::vector<VczBrickEntry>(b.brickCount(), widest));
    for (VczFrame& f : b.frames)
        if (f.type != FrameType::I) f.auxSize = kLargest;
    return preambleBytes(compactPreamble(b, 0, PreambleKind::Bound), 0) + kMaxVarintBytes;
}

void checkVczDecodeBudget(const VczHeader& h, Dims dims, std::size_t memoryBudget, const std::string& name,
                          const std::string& what) {
    // While it decodes a brick, a decoder holds the brick's coefficients as 32-bit values (4 times a uint8
    // frame's voxels when the brick is the whole volume) and, for a brick with corrections, their decompressed
    // list (up to a 5-byte varint and a voxel value per voxel) and the decoded entries: a forged brick size must
    // not make these exhaust memory that the voxels' size fits in.
    const Dims largest{std::min<std::size_t>(h.brick.x, h.dims.x), std::min<std::size_t>(h.brick.y, h.dims.y),
                       std::min<std::size_t>(h.brick.z, h.dims.z)};
    const std::size_t n = largest.count();
    const std::size_t brickBytes =
        n * (sizeof(std::int32_t) + sizeof(codec::Correction)) + codec::maxCorrectionListBytes(h.type, n);
    // A float64 file's region is decoded as its float32 layer, then widened; an exact float64 layer is expanded
    // for the whole frame (8 bytes a voxel).
    const std::size_t float64Bytes =
        h.float64 && dims.count() > 0 ? dims.count() * 8 + h.dims.count() * 8 : 0;
    checkMemoryBudget(dims.count() * scalarSize(h.type) + float64Bytes + brickBytes, memoryBudget, name,
                      what + " with the coefficients and corrections of a " + std::to_string(largest.x) +
                          "x" + std::to_string(largest.y) + "x" + std::to_string(largest.z) + " brick");
}

std::vector<std::byte> writeVcz(const VczHeader& h, std::span<const std::vector<std::uint8_t>> payloads,
                                std::size_t preambleSize) {
    if (h.frames.empty()) throw Error("internal: a .vcz without frames");
    CompactPreamble compact = compactPreamble(h);
    std::uint64_t padding = 0;
    if (preambleSize) {
        // The padding's own varint grows with it: try each length it can have.
        const std::size_t unpadded = preambleBytes(compact, 0);
        bool fits = false;
        for (std::size_t len = 1; len <= kMaxVarintBytes && !fits && preambleSize + 1 >= unpadded + len;
             ++len) {
            padding = preambleSize + 1 - unpadded - len;
            fits = varintBytes(padding) == len;
        }
        if (!fits) throw Error("internal: the reserved .vcz preamble is too small");
        compact = compactPreamble(h, padding);
    }
    Writer w;
    w.bytes.assign(kVczMagic.begin(), kVczMagic.end());
    w.put<std::uint32_t>(h.float64       ? kVczVersionFloat64
                         : h.voxelBricks ? kVczVersionVoxelBricks
                                         : kVczVersionCompact);
    w.put<std::uint32_t>(static_cast<std::uint32_t>(compact.body.size()));
    w.putBytes(compact.body);
    w.put<std::uint64_t>(vczChecksum(w.bytes));
    const std::size_t indexStart = w.bytes.size();
    w.putBytes(compact.index);
    w.put<std::uint64_t>(vczChecksum(std::span(w.bytes).subspan(indexStart)));
    w.bytes.resize(w.bytes.size() + std::size_t(padding));
    // No offsets are stored: each frame's bricks, then its auxiliary block, in order.
    std::uint64_t next = w.bytes.size();
    for (std::size_t f = 0; f < h.frames.size(); ++f) {
        for (const VczBrickEntry& e : h.bricks[f]) {
            if (e.offset != next) throw Error("internal: .vcz payloads out of order");
            next += e.size;
        }
        if (h.frames[f].auxSize) {
            if (h.frames[f].auxOffset != next) throw Error("internal: .vcz motion block out of place");
            next += h.frames[f].auxSize;
        }
    }
    // One allocation of the final size: appending the payloads grew a vector through several reallocations
    // and then copied it into the result (ch2better lossless: ~11 ms of an encode, mostly page faults).
    std::size_t total = w.bytes.size();
    for (const auto& p : payloads)
        total += p.size();
    std::vector<std::byte> out(total);
    std::memcpy(out.data(), w.bytes.data(), w.bytes.size());
    std::size_t at = w.bytes.size();
    for (const auto& p : payloads) {
        if (!p.empty()) std::memcpy(out.data() + at, p.data(), p.size());
        at += p.size();
    }
    return out;
}

namespace {

// The steps of a version 6 header, in either form (the caller validates them).
void readCompactSteps(Reader& r, VczHeader& h) {
    const auto form = r.get<std::uint8_t>();
    if (form == static_cast<std::uint8_t>(StepsForm::Listed)) {
        const std::uint64_t n = r.getVar();
        if (n > r.remaining() / 8) r.fail("truncated");
        h.steps.resize(std::size_t(n));
        for (double& s : h.steps)
            s = r.get<double>();
        return;
    }
    if (form != static_cast<std::uint8_t>(StepsForm::Implied)) r.fail("invalid quantisation step form");
    if (h.transform != TransformKind::FloatLifting || h.levels < 1 || h.levels > kMaxImpliedLevels)
        r.fail("implied quantisation steps without a lossy transform of 1 to 8 levels (corrupt header)");
    const auto delta = r.get<double>();
    if (!(delta > 0) || !std::isfinite(delta)) r.fail("invalid quantisation step");
    h.steps = codec::subbandSteps(h.wavelet, h.levels, delta);
    const std::uint64_t n = r.getVar();
    if (n > h.steps.size()) r.fail("invalid quantisation step overrides");
    std::uint64_t next = 0;
    for (std::uint64_t k = 0; k < n; ++k) {
        const std::uint64_t i = r.getVar();
        if (i < next || i >= h.steps.size()) r.fail("invalid quantisation step overrides");
        h.steps[std::size_t(i)] = r.get<double>();
        next = i + 1;
    }
}

// The fields every version shares, validated. `compact`: version 6's varint sizes and steps forms.
void readFixedFields(Reader& r, VczHeader& h, const std::string& name, std::size_t memoryBudget,
                     VczHeaderUse use, bool compact) {
    auto size = [&] { return compact ? r.getVar() : r.get<std::uint64_t>(); };
    h.dims.x = size();
    h.dims.y = size();
    h.dims.z = size();
    const auto type = r.get<std::uint8_t>(), transform = r.get<std::uint8_t>(),
               wavelet = r.get<std::uint8_t>();
    const auto levels = r.get<std::uint8_t>(), entropy = r.get<std::uint8_t>(), rate = r.get<std::uint8_t>();
    if (type > 3 || transform > 2 || wavelet > 3 || levels > 16 || entropy > 1 || rate > 5)
        r.fail("invalid field value");
    h.type = static_cast<ScalarType>(type);
    h.transform = static_cast<TransformKind>(transform);
    h.wavelet = static_cast<Wavelet>(wavelet);
    h.levels = levels;
    h.entropy = static_cast<EntropyMode>(entropy);
    h.rate = static_cast<RateMode>(rate);
    for (double& v : h.spacing)
        v = r.get<double>();
    for (double& v : h.origin)
        v = r.get<double>();
    // A forged or corrupt geometry would decode into a volume every writer refuses (or, spacing 0, into
    // one silently given spacing 1): refuse it here, as every other format's reader does.
    for (double v : h.spacing)
        if (!std::isfinite(v) || !(v > 0)) r.fail("voxel spacing is not a positive finite number");
    for (double v : h.origin)
        if (!std::isfinite(v)) r.fail("origin is not finite");
    for (std::size_t* b : {&h.brick.x, &h.brick.y, &h.brick.z}) {
        const std::uint64_t v = compact ? r.getVar() : r.get<std::uint32_t>();
        if (v > std::numeric_limits<std::uint32_t>::max()) r.fail("invalid brick size");
        *b = std::size_t(v);
    }
    h.rateTarget = r.get<double>();
    h.reconstructionBias = r.get<double>();
    h.valueMin = r.get<double>();
    h.valueMax = r.get<double>();
    constexpr std::uint64_t kMaxDim = 1u << 20;
    if (h.dims.x == 0 || h.dims.y == 0 || h.dims.z == 0 || h.dims.x > kMaxDim || h.dims.y > kMaxDim ||
        h.dims.z > kMaxDim)
        r.fail("invalid dimensions");
    if (h.brick.x == 0 || h.brick.y == 0 || h.brick.z == 0) r.fail("invalid brick size");
    // Combinations no encoder writes: integer lifting needs a reversible wavelet and integer voxels,
    // raw bit planes hold float voxels.
    if (h.transform == TransformKind::IntegerLifting && !hasIntegerForm(h.wavelet))
        r.fail("integer transform with a wavelet that has no integer form (corrupt header)");
    if (h.transform == TransformKind::IntegerLifting && h.type == ScalarType::Float32)
        r.fail("integer transform of float32 voxels (corrupt header)");
    if (h.transform == TransformKind::RawBits && h.type != ScalarType::Float32)
        r.fail("raw bit planes of integer voxels (corrupt header)");
    if (use == VczHeaderUse::Frame) {
        checkMemoryBudget(h.dims.count() * scalarSize(h.voxelType()), memoryBudget, name,
                          "a " + std::to_string(h.dims.x) + "x" + std::to_string(h.dims.y) + "x" +
                              std::to_string(h.dims.z) + " frame");
        checkVczDecodeBudget(h, h.dims, memoryBudget, name, "a frame");
    } else {
        checkVczDecodeBudget(h, Dims{0, 0, 0}, memoryBudget, name, "decoding one brick");
    }
    // Older encoders accepted --levels 0 for a wavelet transform and wrote files no decoder can read.
    if (h.transform != TransformKind::RawBits && h.levels == 0)
        r.fail("wavelet transform with 0 levels (written by an encoder that accepted --levels 0; re-encode "
               "with --levels 1 or more)");
    if (compact) {
        readCompactSteps(r, h);
    } else {
        const auto nSteps = r.get<std::uint32_t>();
        if (nSteps > r.remaining() / 8) r.fail("truncated");
        h.steps.resize(nSteps);
        for (double& s : h.steps)
            s = r.get<double>();
    }
    if (h.transform == TransformKind::FloatLifting) {
        if (h.steps.size() != 1 + 7 * static_cast<std::size_t>(h.levels))
            r.fail("wrong number of quantisation steps");
        for (double s : h.steps)
            if (!(s > 0) || !std::isfinite(s)) r.fail("invalid quantisation step");
    }
}

// Versions 2-4: fixed-width frame table and metadata.
void readFrameTable(Reader& r, VczHeader& h, std::size_t fileSize) {
    const auto nFrames = r.get<std::uint32_t>();
    if (nFrames == 0 || nFrames > r.remaining() / 41) r.fail("invalid frame count");
    h.frames.resize(nFrames);
    for (VczFrame& f : h.frames) {
        const auto ft = r.get<std::uint8_t>();
        if (ft > 2) r.fail("invalid frame type");
        f.type = static_cast<FrameType>(ft);
        f.reference0 = r.get<std::int32_t>();
        f.reference1 = r.get<std::int32_t>();
        f.time = r.get<double>();
        f.auxOffset = r.get<std::uint64_t>();
        f.auxSize = r.get<std::uint64_t>();
        f.auxChecksum = r.get<std::uint64_t>();
        if (f.auxSize > fileSize || f.auxOffset > fileSize - f.auxSize) r.fail("frame data outside the file");
    }
}

void readMetadata(Reader& r, VczHeader& h) {
    const auto nMeta = r.get<std::uint32_t>();
    for (std::uint32_t i = 0; i < nMeta; ++i) {
        std::string k = r.getString();
        h.metadata[k] = r.getString();
    }
}

// Where a compact index lies: its size and the padding after its checksum.
struct CompactIndexPlace {
    std::uint64_t size = 0, padding = 0;
};

// Versions 5 and 6: varint frame table (references as distances, auxiliary offsets implied) and a metadata
// block, then the index's size (and in version 6 the padding after it).
CompactIndexPlace readCompactTail(Reader& r, VczHeader& h, std::size_t fileSize, std::uint32_t version) {
    const std::uint64_t nFrames = r.getVar();
    // Each frame takes at least 2 bytes (type, motion size); version 5 was written for series only.
    const std::uint64_t fewest = version == kVczVersionSeries ? 2 : 1;
    if (nFrames < fewest || nFrames > r.remaining() / 2) r.fail("invalid frame count");
    h.frames.resize(std::size_t(nFrames));
    const auto timeForm = r.get<std::uint8_t>();
    const auto lastForm =
        static_cast<std::uint8_t>(version == kVczVersionSeries ? TimeForm::Listed : TimeForm::Zero);
    if (timeForm > lastForm) r.fail("invalid frame time form");
    if (timeForm == static_cast<std::uint8_t>(TimeForm::Zero)) {
        // every frame at time 0, as built
    } else if (timeForm == static_cast<std::uint8_t>(TimeForm::Uniform)) {
        const double t0 = r.get<double>(), dt = r.get<double>();
        for (std::size_t f = 0; f < h.frames.size(); ++f)
            h.frames[f].time = uniformTime(t0, dt, f);
    } else {
        if (nFrames > r.remaining() / 8) r.fail("truncated");
        for (VczFrame& f : h.frames)
            f.time = r.get<double>();
    }
    for (std::size_t i = 0; i < h.frames.size(); ++i) {
        VczFrame& f = h.frames[i];
        const auto ft = r.get<std::uint8_t>();
        if (ft > 2) r.fail("invalid frame type");
        f.type = static_cast<FrameType>(ft);
        if (f.type != FrameType::I) {
            const std::uint64_t back = r.getVar();
            if (back == 0 || back > i) r.fail("frame " + std::to_string(i) + ": invalid references");
            f.reference0 = static_cast<std::int32_t>(i - back);
        }
        if (f.type == FrameType::B) {
            const std::uint64_t ahead = r.getVar();
            if (ahead == 0 || ahead >= nFrames - i)
                r.fail("frame " + std::to_string(i) + ": invalid references");
            f.reference1 = static_cast<std::int32_t>(i + ahead);
        }
        f.auxSize = r.getVar();
        if (f.auxSize > fileSize) r.fail("frame data outside the file");
        if (f.auxSize) f.auxChecksum = r.get<std::uint32_t>();
    }
    const std::uint64_t rawSize = r.getVar();
    const auto method = r.get<std::uint8_t>();
    std::span<const std::uint8_t> raw;
    std::vector<std::uint8_t> unpacked;
    if (method == 0) {
        raw = r.getBytes(rawSize);
    } else if (method == 1) {
        const std::uint64_t packedSize = r.getVar();
        const std::span<const std::uint8_t> packed = r.getBytes(packedSize);
        if (rawSize > kMaxMetadataExpansion * packedSize ||
            ZSTD_getFrameContentSize(packed.data(), packed.size()) != rawSize)
            r.fail("metadata: invalid size");
        unpacked.resize(std::size_t(rawSize));
        const std::size_t n = ZSTD_decompress(unpacked.data(), unpacked.size(), packed.data(), packed.size());
        if (ZSTD_isError(n) || n != rawSize) r.fail("metadata: corrupt compressed block");
        raw = unpacked;
    } else {
        r.fail("metadata: unknown block form");
    }
    Reader m(raw, r.name(), "metadata");
    const std::uint64_t nMeta = m.getVar();
    if (nMeta > m.remaining() / 2) m.fail("invalid entry count");
    for (std::uint64_t i = 0; i < nMeta; ++i) {
        std::string k = m.getVarString();
        h.metadata[k] = m.getVarString();
    }
    if (m.remaining() != 0) m.fail("unexpected trailing bytes");
    CompactIndexPlace place;
    place.size = r.getVar();
    if (version >= kVczVersionCompact) place.padding = r.getVar();
    return place;
}

std::string framePart(const VczHeader& h, std::size_t f) {
    return h.frames.size() > 1 ? "frame " + std::to_string(f) + ", " : std::string();
}

[[noreturn]] void brickOutside(const std::string& name, const VczHeader& h, std::size_t f, std::size_t i) {
    throw IoError(name + ": " + framePart(h, f) + "brick " + std::to_string(i) +
                  " lies outside the file (truncated?)");
}

// Versions 2-4: 40 bytes per brick. Returns the end of the last payload or auxiliary block.
std::size_t readIndex(std::span<const std::uint8_t> file, std::size_t indexStart, VczHeader& h,
                      const std::string& name) {
    const std::size_t nFrames = h.frames.size(), bricks = h.brickCount();
    if (bricks == 0 || bricks > (file.size() - indexStart) / kIndexEntryBytes / nFrames)
        throw IoError(name + ": brick index: truncated");
    const std::size_t indexBytes = bricks * nFrames * kIndexEntryBytes;
    if (file.size() - indexStart < indexBytes + 8) throw IoError(name + ": brick index: truncated");
    std::uint64_t stored;
    std::memcpy(&stored, file.data() + indexStart + indexBytes, 8);
    if (!checksumMatches(stored, file.subspan(indexStart, indexBytes)))
        throw IoError(name + ": brick index checksum mismatch (corrupted index)");
    Reader ir(file.subspan(indexStart, indexBytes), name, "brick index");
    h.bricks.assign(nFrames, std::vector<VczBrickEntry>(bricks));
    const std::size_t payloadStart = indexStart + indexBytes + 8;
    std::size_t payloadEnd = payloadStart;
    for (std::size_t f = 0; f < nFrames; ++f) {
        for (std::size_t i = 0; i < bricks; ++i) {
            VczBrickEntry& e = h.bricks[f][i];
            e.offset = ir.get<std::uint64_t>();
            e.size = ir.get<std::uint64_t>();
            e.checksum = ir.get<std::uint64_t>();
            e.min = ir.get<double>();
            e.max = ir.get<double>();
            if (e.offset < payloadStart || e.size > file.size() || e.offset > file.size() - e.size)
                brickOutside(name, h, f, i);
            payloadEnd = std::max<std::size_t>(payloadEnd, e.offset + e.size);
        }
    }
    for (const VczFrame& f : h.frames)
        payloadEnd = std::max<std::size_t>(payloadEnd, f.auxOffset + f.auxSize);
    return payloadEnd;
}

// Version 5: per brick a varint size, a 32-bit checksum and the range in the index's form; payload offsets
// follow from the sizes (each frame's bricks, then its auxiliary block).
std::size_t readCompactIndex(std::span<const std::uint8_t> file, std::size_t indexStart,
                             CompactIndexPlace place, VczHeader& h, const std::string& name) {
    const std::size_t nFrames = h.frames.size(), bricks = h.brickCount();
    const std::uint64_t indexSize = place.size;
    if (indexSize > file.size() - indexStart || file.size() - indexStart - indexSize < 8 ||
        place.padding > file.size() - indexStart - indexSize - 8)
        throw IoError(name + ": brick index: truncated");
    std::uint64_t stored;
    std::memcpy(&stored, file.data() + indexStart + indexSize, 8);
    const auto index = file.subspan(indexStart, std::size_t(indexSize));
    if (!checksumMatches(stored, index))
        throw IoError(name + ": brick index checksum mismatch (corrupted index)");
    Reader ir(index, name, "brick index");
    const auto form = ir.get<std::uint8_t>();
    if (form > 2) ir.fail("invalid range form");
    const std::size_t entryMin = 1 + 4 + (form == 0 ? 2 : form == 1 ? 8 : 16);
    if (bricks == 0 || bricks > ir.remaining() / entryMin / nFrames) ir.fail("truncated");
    h.bricks.assign(nFrames, std::vector<VczBrickEntry>(bricks));
    std::uint64_t at = indexStart + indexSize + 8 + place.padding;
    for (std::size_t f = 0; f < nFrames; ++f) {
        for (std::size_t i = 0; i < bricks; ++i) {
            VczBrickEntry& e = h.bricks[f][i];
            e.size = ir.getVar();
            e.checksum = ir.get<std::uint32_t>();
            switch (static_cast<RangeForm>(form)) {
            case RangeForm::Integer: {
                const std::uint64_t lo = ir.getVar(), span = ir.getVar();
                const std::int64_t min = zigzagDecode(lo);
                if (span > std::uint64_t(2 * kMaxExactInteger) || std::abs(double(min)) > kMaxExactInteger ||
                    std::abs(double(min) + double(span)) > kMaxExactInteger)
                    ir.fail("invalid brick range");
                e.min = double(min);
                e.max = double(min + std::int64_t(span));
                break;
            }
            case RangeForm::Float32:
                e.min = ir.get<float>();
                e.max = ir.get<float>();
                break;
            case RangeForm::Float64:
                e.min = ir.get<double>();
                e.max = ir.get<double>();
                break;
            }
            if (e.size > file.size() || at > file.size() - e.size) brickOutside(name, h, f, i);
            e.offset = at;
            at += e.size;
        }
        VczFrame& fr = h.frames[f];
        if (fr.auxSize) {
            if (at > file.size() - fr.auxSize)
                throw IoError(name + ": frame " + std::to_string(f) +
                              ": motion data lies outside the file (truncated?)");
            fr.auxOffset = at;
            at += fr.auxSize;
        }
    }
    if (ir.remaining() != 0) ir.fail("unexpected trailing bytes");
    return std::size_t(at);
}

} // namespace

VczHeader readVczHeader(std::span<const std::byte> fileBytes, const std::string& name,
                        std::size_t memoryBudget, VczHeaderUse use) {
    const std::span<const std::uint8_t> file(reinterpret_cast<const std::uint8_t*>(fileBytes.data()),
                                             fileBytes.size());
    if (file.size() < kVczMagic.size() + 8 || !std::equal(kVczMagic.begin(), kVczMagic.end(), file.begin()))
        throw IoError(name + ": not a .vcz file (bad magic)");
    Reader pre(file.subspan(kVczMagic.size()), name, "header");
    const auto version = pre.get<std::uint32_t>();
    if (version != kVczVersionFloat64 && version != kVczVersionVoxelBricks && version != kVczVersionCompact &&
        version != kVczVersionSeries && version != kVczVersionPredicted && version != kVczVersion &&
        version != 2)
        throw IoError(name + ": unsupported .vcz version " + std::to_string(version));
    const auto bodySize = pre.get<std::uint32_t>();
    const std::size_t bodyStart = kVczMagic.size() + 8;
    if (bodySize > file.size() - bodyStart || file.size() - bodyStart - bodySize < 8)
        throw IoError(name + ": header: truncated");
    std::uint64_t stored;
    std::memcpy(&stored, file.data() + bodyStart + bodySize, 8);
    if (!checksumMatches(stored, file.first(bodyStart + bodySize)))
        throw IoError(name + ": header checksum mismatch (corrupted header)");

    Reader r(file.subspan(bodyStart, bodySize), name, "header");
    VczHeader h;
    h.version = version;
    h.float64 = version == kVczVersionFloat64;
    h.voxelBricks = version == kVczVersionVoxelBricks || h.float64;
    const bool compact = compactLayout(version);
    readFixedFields(r, h, name, memoryBudget, use, version >= kVczVersionCompact);
    CompactIndexPlace compactIndex;
    if (compact) {
        compactIndex = readCompactTail(r, h, file.size(), version);
    } else {
        readFrameTable(r, h, file.size());
    }
    checkFrameReferences(h, version, r);
    if (!compact) readMetadata(r, h);
    if (r.remaining() != 0) r.fail("unexpected trailing bytes");

    // The index's entries are held by every reader (a forged brick grid must not exhaust memory either;
    // the file's index bytes bound them too, at most 6x).
    const long double indexBytes =
        (long double)h.brickCount() * (long double)h.frames.size() * (long double)sizeof(VczBrickEntry);
    checkMemoryBudget(indexBytes > 1e18L ? std::size_t(-1) : std::size_t(indexBytes), memoryBudget, name,
                      "the brick index");
    const std::size_t indexStart = bodyStart + bodySize + 8;
    const std::size_t payloadEnd = compact ? readCompactIndex(file, indexStart, compactIndex, h, name)
                                           : readIndex(file, indexStart, h, name);
    if (payloadEnd != file.size())
        throw IoError(name + ": " + std::to_string(file.size() - payloadEnd) +
                      " bytes of trailing data after the last brick (corrupt or appended to)");
    return h;
}

std::span<const std::uint8_t> vczBrickPayload(std::span<const std::byte> fileBytes, const VczHeader& h,
                                              std::size_t frame, std::size_t brick, const std::string& name) {
    const std::span<const std::uint8_t> file(reinterpret_cast<const std::uint8_t*>(fileBytes.data()),
                                             fileBytes.size());
    if (frame >= h.bricks.size() || brick >= h.bricks[frame].size())
        throw UsageError(name + ": no such brick");
    const VczBrickEntry& e = h.bricks[frame][brick];
    if (e.size > file.size() || e.offset > file.size() - e.size)
        throw IoError(name + ": brick " + std::to_string(brick) + " lies outside the file (truncated?)");
    auto payload = file.subspan(e.offset, e.size);
    if (!checksumMatches(e.checksum, payload, shortChecksums(h))) {
        const Dims o = h.brickOrigin(brick);
        throw IoError(name + ": " + framePart(h, frame) + "brick " + std::to_string(brick) + " (voxel " +
                      std::to_string(o.x) + "," + std::to_string(o.y) + "," + std::to_string(o.z) +
                      ") checksum mismatch (corrupted data)");
    }
    return payload;
}

} // namespace volcl

namespace volcl {

std::span<const std::uint8_t> vczFrameAux(std::span<const std::byte> fileBytes, const VczHeader& h,
                                          std::size_t frame, const std::string& name) {
    const std::span<const std::uint8_t> file(reinterpret_cast<const std::uint8_t*>(fileBytes.data()),
                                             fileBytes.size());
    if (frame >= h.frames.size()) throw UsageError(name + ": no frame " + std::to_string(frame));
    const VczFrame& f = h.frames[frame];
    if (f.auxSize == 0) return {}; // I frames (the reader checked that they carry none)
    if (f.auxSize > file.size() || f.auxOffset > file.size() - f.auxSize)
        throw IoError(name + ": frame " + std::to_string(frame) +
                      ": motion data lies outside the file (truncated?)");
    auto aux = file.subspan(f.auxOffset, f.auxSize);
    if (!checksumMatches(f.auxChecksum, aux, shortChecksums(h)))
        throw IoError(name + ": frame " + std::to_string(frame) +
                      ": motion data checksum mismatch (corrupted data)");
    return aux;
}

} // namespace volcl
