// .vcz serialisation and validated parsing (layout in docs/codec.md).
#include "wavelet/container/VczFormat.hpp"

#include "host/MemoryBudget.hpp"

#include "host/Error.hpp"
#include "wavelet/entropy/EntropyCoder.hpp"

#include <xxhash.h>

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
bool checksumMatches(std::uint64_t stored, std::span<const std::uint8_t> bytes) noexcept {
#ifdef VOLCL_FUZZ_ACCEPT_ANY_CHECKSUM
    (void)stored;
    (void)vczChecksum(bytes); // still hashed: the hash reads every byte it claims, under the sanitizers
    return true;
#else
    return stored == vczChecksum(bytes);
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
    std::size_t remaining() const noexcept { return b_.size() - pos_; }
    [[noreturn]] void fail(const std::string& what) const {
        throw IoError(name_ + ": " + part_ + ": " + what);
    }

private:
    void need(std::size_t n) const {
        if (n > b_.size() - pos_) fail("truncated");
    }
    std::span<const std::uint8_t> b_;
    std::size_t pos_ = 0;
    const std::string& name_;
    const char* part_;
};

std::vector<std::uint8_t> headerBody(const VczHeader& h) {
    Writer w;
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

// The frame table's references form what the decoder can follow: I frames reference nothing and carry no
// auxiliary block; a P frame references an earlier I/P frame; a B frame an earlier and a later one. So every
// chain of references ends at an I frame. Older versions hold I frames only.
void checkFrameReferences(const VczHeader& h, std::uint32_t version, const Reader& r) {
    const auto n = static_cast<std::int64_t>(h.frames.size());
    // Encoders write version 4 only for files that hold P/B frames.
    if (version == kVczVersionPredicted &&
        std::all_of(h.frames.begin(), h.frames.end(), [](const VczFrame& f) { return f.type == FrameType::I; }))
        r.fail("unsupported .vcz version 4 for a file of I frames only (corrupt header)");
    auto anchor = [&](std::int32_t k) { return k >= 0 && k < n && h.frames[std::size_t(k)].type != FrameType::B; };
    for (std::int64_t f = 0; f < n; ++f) {
        const VczFrame& e = h.frames[std::size_t(f)];
        const std::string which = "frame " + std::to_string(f);
        if (e.type != FrameType::I && version < kVczVersionPredicted)
            r.fail(which + ": P/B frame in a version " + std::to_string(version) + " file");
        if (e.type != FrameType::I && h.transform == TransformKind::RawBits)
            r.fail(which + ": P/B frame of raw float bit planes");
        const bool ok = e.type == FrameType::I   ? e.reference0 == -1 && e.reference1 == -1 && e.auxSize == 0
                        : e.type == FrameType::P ? anchor(e.reference0) && e.reference0 < f && e.reference1 == -1
                                                 : anchor(e.reference0) && e.reference0 < f &&
                                                       anchor(e.reference1) && e.reference1 > f;
        if (!ok) r.fail(which + ": invalid references");
    }
}

} // namespace

std::size_t vczPreambleSize(const VczHeader& h) {
    const std::size_t entries = h.frames.size() * h.brickCount();
    return kVczMagic.size() + 8 + headerBody(h).size() + 8 + entries * kIndexEntryBytes + 8;
}

std::vector<std::byte> writeVcz(const VczHeader& h, std::span<const std::vector<std::uint8_t>> payloads) {
    Writer w;
    w.bytes.assign(kVczMagic.begin(), kVczMagic.end());
    const bool predicted = std::any_of(h.frames.begin(), h.frames.end(),
                                       [](const VczFrame& f) { return f.type != FrameType::I; });
    w.put<std::uint32_t>(predicted ? kVczVersionPredicted : kVczVersion);
    const std::vector<std::uint8_t> body = headerBody(h);
    w.put<std::uint32_t>(static_cast<std::uint32_t>(body.size()));
    w.bytes.insert(w.bytes.end(), body.begin(), body.end());
    w.put<std::uint64_t>(vczChecksum(w.bytes));
    const std::size_t indexStart = w.bytes.size();
    for (const auto& frame : h.bricks) {
        for (const VczBrickEntry& e : frame) {
            w.put(e.offset);
            w.put(e.size);
            w.put(e.checksum);
            w.put(e.min);
            w.put(e.max);
        }
    }
    w.put<std::uint64_t>(vczChecksum(std::span(w.bytes).subspan(indexStart)));
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

VczHeader readVczHeader(std::span<const std::byte> fileBytes, const std::string& name,
                        std::size_t memoryBudget) {
    const std::span<const std::uint8_t> file(reinterpret_cast<const std::uint8_t*>(fileBytes.data()),
                                             fileBytes.size());
    if (file.size() < kVczMagic.size() + 8 || !std::equal(kVczMagic.begin(), kVczMagic.end(), file.begin()))
        throw IoError(name + ": not a .vcz file (bad magic)");
    Reader pre(file.subspan(kVczMagic.size()), name, "header");
    const auto version = pre.get<std::uint32_t>();
    if (version != kVczVersionPredicted && version != kVczVersion && version != 2)
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
    h.dims.x = r.get<std::uint64_t>();
    h.dims.y = r.get<std::uint64_t>();
    h.dims.z = r.get<std::uint64_t>();
    const auto type = r.get<std::uint8_t>(), transform = r.get<std::uint8_t>(),
               wavelet = r.get<std::uint8_t>();
    const auto levels = r.get<std::uint8_t>(), entropy = r.get<std::uint8_t>(), rate = r.get<std::uint8_t>();
    if (type > 3 || transform > 2 || wavelet > 3 || levels > 16 || entropy > 1 || rate > 3)
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
        if (f.auxSize > file.size() || f.auxOffset > file.size() - f.auxSize)
            r.fail("frame data outside the file");
    }
    checkFrameReferences(h, version, r);
    const auto nMeta = r.get<std::uint32_t>();
    for (std::uint32_t i = 0; i < nMeta; ++i) {
        std::string k = r.getString();
        h.metadata[k] = r.getString();
    }
    if (r.remaining() != 0) r.fail("unexpected trailing bytes");

    const std::size_t indexStart = bodyStart + bodySize + 8;
    const std::size_t bricks = h.brickCount();
    if (bricks == 0 || bricks > (file.size() - indexStart) / kIndexEntryBytes / nFrames)
        throw IoError(name + ": brick index: truncated");
    const std::size_t indexBytes = bricks * nFrames * kIndexEntryBytes;
    if (file.size() - indexStart < indexBytes + 8) throw IoError(name + ": brick index: truncated");
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
                throw IoError(name + ": " + (nFrames > 1 ? "frame " + std::to_string(f) + ", " : std::string()) +
                              "brick " + std::to_string(i) + " lies outside the file (truncated?)");
            payloadEnd = std::max<std::size_t>(payloadEnd, e.offset + e.size);
        }
    }
    for (const VczFrame& f : h.frames)
        payloadEnd = std::max<std::size_t>(payloadEnd, f.auxOffset + f.auxSize);
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
    if (!checksumMatches(e.checksum, payload)) {
        const Dims o = h.brickOrigin(brick);
        const std::string framePart = h.frames.size() > 1 ? "frame " + std::to_string(frame) + ", " : "";
        throw IoError(name + ": " + framePart + "brick " + std::to_string(brick) + " (voxel " +
                      std::to_string(o.x) + "," +
                      std::to_string(o.y) + "," + std::to_string(o.z) +
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
        throw IoError(name + ": frame " + std::to_string(frame) + ": motion data lies outside the file (truncated?)");
    auto aux = file.subspan(f.auxOffset, f.auxSize);
    if (!checksumMatches(f.auxChecksum, aux))
        throw IoError(name + ": frame " + std::to_string(frame) + ": motion data checksum mismatch (corrupted data)");
    return aux;
}

} // namespace volcl
