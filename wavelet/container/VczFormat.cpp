// .vcz serialisation and validated parsing (layout in docs/codec.md).
#include "wavelet/container/VczFormat.hpp"

#include "core/MemoryBudget.hpp"

#include "core/Error.hpp"
#include "wavelet/Varint.hpp"
#include "wavelet/entropy/EntropyCoder.hpp"
#include "wavelet/quantise/Corrections.hpp"

#include <xxhash.h>
#include <zstd.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>

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
// `bits32`: version 5 payload checksums, the low 32 bits of the XXH3-64.
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

// The fields every version shares: grid, kinds, geometry, rate and the quantisation steps.
void putFixedFields(Writer& w, const VczHeader& h) {
    w.put<std::uint64_t>(h.dims.x);
    w.put<std::uint64_t>(h.dims.y);
    w.put<std::uint64_t>(h.dims.z);
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
    w.put<std::uint32_t>(static_cast<std::uint32_t>(h.brick.x));
    w.put<std::uint32_t>(static_cast<std::uint32_t>(h.brick.y));
    w.put<std::uint32_t>(static_cast<std::uint32_t>(h.brick.z));
    w.put(h.rateTarget);
    w.put(h.reconstructionBias);
    w.put(h.valueMin);
    w.put(h.valueMax);
    w.put<std::uint32_t>(static_cast<std::uint32_t>(h.steps.size()));
    for (double s : h.steps)
        w.put(s);
}

bool isSeries(const VczHeader& h) noexcept {
    return h.frames.size() > 1;
}

// Version 5 keeps the low 32 bits of each payload's and motion block's XXH3-64.
bool shortChecksums(const VczHeader& h) noexcept {
    return h.version == kVczVersionSeries;
}

// Versions 3 and 4: fixed-width frame table and metadata.
std::vector<std::uint8_t> headerBody(const VczHeader& h) {
    Writer w;
    putFixedFields(w, h);
    w.put<std::uint32_t>(static_cast<std::uint32_t>(h.frames.size()));
    for (const VczFrame& f : h.frames) {
        w.put<std::uint8_t>(static_cast<std::uint8_t>(f.type));
        w.put(f.reference0);
        w.put(f.reference1);
        w.put(f.time);
        w.put(f.auxOffset);
        w.put(f.auxSize);
        w.put(f.auxChecksum);
    }
    w.put<std::uint32_t>(static_cast<std::uint32_t>(h.metadata.size()));
    for (const auto& [k, v] : h.metadata) {
        w.putString(k);
        w.putString(v);
    }
    return std::move(w.bytes);
}

constexpr std::size_t kIndexEntryBytes = 5 * 8;

// ---- Version 5 (files of more than one frame) ----

// How a version 5 index stores the brick ranges: the narrowest form that gives back every value bit for bit.
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

bool uniformTimes(const VczHeader& h) noexcept {
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

// Metadata as varint-length strings, zstd-compressed when that is smaller.
void putMetadataBlock(Writer& w, const std::map<std::string, std::string>& metadata) {
    Writer m;
    m.putVar(metadata.size());
    for (const auto& [k, v] : metadata) {
        m.putVarString(k);
        m.putVarString(v);
    }
    w.putVar(m.bytes.size());
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

CompactPreamble compactPreamble(const VczHeader& h) {
    CompactPreamble p;
    p.index = compactIndex(h);
    Writer w;
    putFixedFields(w, h);
    w.putVar(h.frames.size());
    const bool uniform = uniformTimes(h);
    w.put<std::uint8_t>(uniform ? 0 : 1);
    if (uniform) {
        w.put(h.frames[0].time);
        w.put(h.frames[1].time - h.frames[0].time);
    } else {
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
    putMetadataBlock(w, h.metadata);
    w.putVar(p.index.size());
    p.body = std::move(w.bytes);
    return p;
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
        const bool ok =
            e.type == FrameType::I ? e.reference0 == -1 && e.reference1 == -1 && e.auxSize == 0
            : e.type == FrameType::P
                ? anchor(e.reference0) && e.reference0 < f && e.reference1 == -1
                : anchor(e.reference0) && e.reference0 < f && anchor(e.reference1) && e.reference1 > f;
        if (!ok) r.fail(which + ": invalid references");
    }
}

} // namespace

std::size_t vczPreambleSize(const VczHeader& h) {
    if (isSeries(h)) {
        const CompactPreamble p = compactPreamble(h);
        return kVczMagic.size() + 8 + p.body.size() + 8 + p.index.size() + 8;
    }
    const std::size_t entries = h.frames.size() * h.brickCount();
    return kVczMagic.size() + 8 + headerBody(h).size() + 8 + entries * kIndexEntryBytes + 8;
}

std::vector<std::byte> writeVcz(const VczHeader& h, std::span<const std::vector<std::uint8_t>> payloads) {
    Writer w;
    w.bytes.assign(kVczMagic.begin(), kVczMagic.end());
    const bool predicted = std::any_of(h.frames.begin(), h.frames.end(),
                                       [](const VczFrame& f) { return f.type != FrameType::I; });
    const bool series = isSeries(h);
    w.put<std::uint32_t>(series ? kVczVersionSeries : predicted ? kVczVersionPredicted : kVczVersion);
    CompactPreamble compact;
    if (series) compact = compactPreamble(h);
    const std::vector<std::uint8_t> body = series ? std::move(compact.body) : headerBody(h);
    w.put<std::uint32_t>(static_cast<std::uint32_t>(body.size()));
    w.bytes.insert(w.bytes.end(), body.begin(), body.end());
    w.put<std::uint64_t>(vczChecksum(w.bytes));
    const std::size_t indexStart = w.bytes.size();
    if (series) {
        w.putBytes(compact.index);
    } else {
        for (const auto& frame : h.bricks) {
            for (const VczBrickEntry& e : frame) {
                w.put(e.offset);
                w.put(e.size);
                w.put(e.checksum);
                w.put(e.min);
                w.put(e.max);
            }
        }
    }
    w.put<std::uint64_t>(vczChecksum(std::span(w.bytes).subspan(indexStart)));
    if (series) {
        // Version 5 stores no offsets: each frame's bricks, then its auxiliary block, in order.
        std::uint64_t at = w.bytes.size();
        for (std::size_t f = 0; f < h.frames.size(); ++f) {
            for (const VczBrickEntry& e : h.bricks[f]) {
                if (e.offset != at) throw Error("internal: .vcz series payloads out of order");
                at += e.size;
            }
            if (h.frames[f].auxSize) {
                if (h.frames[f].auxOffset != at)
                    throw Error("internal: .vcz series motion block out of place");
                at += h.frames[f].auxSize;
            }
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

// The fields every version shares, validated.
void readFixedFields(Reader& r, VczHeader& h, const std::string& name, std::size_t memoryBudget) {
    h.dims.x = r.get<std::uint64_t>();
    h.dims.y = r.get<std::uint64_t>();
    h.dims.z = r.get<std::uint64_t>();
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
    h.brick.x = r.get<std::uint32_t>();
    h.brick.y = r.get<std::uint32_t>();
    h.brick.z = r.get<std::uint32_t>();
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
    checkMemoryBudget(h.dims.count() * scalarSize(h.type), memoryBudget, name,
                      "a " + std::to_string(h.dims.x) + "x" + std::to_string(h.dims.y) + "x" +
                          std::to_string(h.dims.z) + " frame");
    // While it decodes a brick into the frame, a decoder holds the brick's coefficients as 32-bit values (4
    // times a uint8 frame's voxels when the brick is the whole volume) and, for a brick with corrections,
    // their decompressed list (up to a 5-byte varint and a voxel value per voxel) and the decoded entries:
    // a forged brick size must not make these exhaust memory that the frame's size fits in.
    const Dims largest{std::min<std::size_t>(h.brick.x, h.dims.x), std::min<std::size_t>(h.brick.y, h.dims.y),
                       std::min<std::size_t>(h.brick.z, h.dims.z)};
    const std::size_t n = largest.count();
    const std::size_t brickBytes =
        n * (sizeof(std::int32_t) + sizeof(codec::Correction)) + codec::maxCorrectionListBytes(h.type, n);
    checkMemoryBudget(h.dims.count() * scalarSize(h.type) + brickBytes, memoryBudget, name,
                      "a frame with the coefficients and corrections of a " + std::to_string(largest.x) +
                          "x" + std::to_string(largest.y) + "x" + std::to_string(largest.z) + " brick");
    // Older encoders accepted --levels 0 for a wavelet transform and wrote files no decoder can read.
    if (h.transform != TransformKind::RawBits && h.levels == 0)
        r.fail("wavelet transform with 0 levels (written by an encoder that accepted --levels 0; re-encode "
               "with --levels 1 or more)");
    const auto nSteps = r.get<std::uint32_t>();
    if (nSteps > r.remaining() / 8) r.fail("truncated");
    h.steps.resize(nSteps);
    for (double& s : h.steps)
        s = r.get<double>();
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

// Version 5: varint frame table (references as distances, auxiliary offsets implied) and a metadata block.
// Returns the size of the index that follows the header.
std::uint64_t readCompactTail(Reader& r, VczHeader& h, std::size_t fileSize) {
    const std::uint64_t nFrames = r.getVar();
    // Each frame takes at least 2 bytes (type, motion size); version 5 is written for series only.
    if (nFrames < 2 || nFrames > r.remaining() / 2) r.fail("invalid frame count");
    h.frames.resize(std::size_t(nFrames));
    const auto timeForm = r.get<std::uint8_t>();
    if (timeForm > 1) r.fail("invalid frame time form");
    if (timeForm == 0) {
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
    return r.getVar();
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
                             std::uint64_t indexSize, VczHeader& h, const std::string& name) {
    const std::size_t nFrames = h.frames.size(), bricks = h.brickCount();
    if (indexSize > file.size() - indexStart || file.size() - indexStart - indexSize < 8)
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
    std::uint64_t at = indexStart + indexSize + 8;
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
                        std::size_t memoryBudget) {
    const std::span<const std::uint8_t> file(reinterpret_cast<const std::uint8_t*>(fileBytes.data()),
                                             fileBytes.size());
    if (file.size() < kVczMagic.size() + 8 || !std::equal(kVczMagic.begin(), kVczMagic.end(), file.begin()))
        throw IoError(name + ": not a .vcz file (bad magic)");
    Reader pre(file.subspan(kVczMagic.size()), name, "header");
    const auto version = pre.get<std::uint32_t>();
    if (version != kVczVersionSeries && version != kVczVersionPredicted && version != kVczVersion &&
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
    readFixedFields(r, h, name, memoryBudget);
    std::uint64_t compactIndexSize = 0;
    if (version == kVczVersionSeries) {
        compactIndexSize = readCompactTail(r, h, file.size());
    } else {
        readFrameTable(r, h, file.size());
    }
    checkFrameReferences(h, version, r);
    if (version != kVczVersionSeries) readMetadata(r, h);
    if (r.remaining() != 0) r.fail("unexpected trailing bytes");

    const std::size_t indexStart = bodyStart + bodySize + 8;
    const std::size_t payloadEnd = version == kVczVersionSeries
                                       ? readCompactIndex(file, indexStart, compactIndexSize, h, name)
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
