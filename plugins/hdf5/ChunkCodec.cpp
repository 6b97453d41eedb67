// HDF5 chunks <-> volcl-compressed bytes: parameter words, the stored chunk header, codec calls.
#include "plugins/hdf5/ChunkCodec.hpp"

#include "core/Error.hpp"
#include "core/Format.hpp"
#include "wavelet/Codec.hpp"
#include "wavelet/container/VczFormat.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <utility>

namespace volcl::hdf5 {
namespace {

// Stored chunk: this header, then one .vcz holding the chunk's frames. Version 2 (lossy chunks whose
// frames have a trimmed box) adds one FrameBox per frame between the header and the .vcz.
constexpr std::array<unsigned char, 4> kChunkMagic{'V', 'C', 'Z', 'H'};
constexpr std::uint8_t kChunkVersion = 1, kChunkVersionBoxes = 2;
constexpr std::size_t kChunkHeaderSize = 4 + 4 + 4 * 8; // magic, version/rank/type/rate, 4 dims
constexpr std::size_t kFrameBoxBytes = 3 * 4 + 4;       // box extents x, y, z (u32), the fill voxel's bytes
// Version 2: the low 32 bits of the XXH3-64 of the chunk header and the box table follow the table (the
// .vcz checks its own bytes; a damaged box would otherwise decode to other data without an error).
constexpr std::size_t kBoxChecksumBytes = 4;

std::size_t boxedHeaderBytes(const FilterParameters& p) {
    return kChunkHeaderSize + p.frameCount() * kFrameBoxBytes + kBoxChecksumBytes;
}
std::uint32_t boxChecksum(std::span<const std::byte> headerAndBoxes) {
    return std::uint32_t(
        vczChecksum({reinterpret_cast<const std::uint8_t*>(headerAndBoxes.data()), headerAndBoxes.size()}));
}

// HDF5 hands the filter whole chunks: those at the dataset's far edges are padded (with the fill value), and
// nothing tells the filter which voxels are real. A frame's box is the smallest origin-anchored box holding
// every voxel that differs from the frame's last voxel (`fill`, padding whenever the chunk is partial), so
// the real voxels always cover the box. Outside the box every voxel equals `fill` and is restored exactly
// on decode; inside, the codec codes the box (the rest set to one value of the box) and PSNR is held on
// it. Since the real voxels add only exact voxels to the box, their PSNR is at least the box's.
struct FrameBox {
    Dims extent;                     ///< {0, 0, 0}: every voxel equals `fill`
    std::array<std::byte, 4> fill{}; ///< the frame's last voxel (scalarSize bytes used)
};

// Codes of the element types in cd_values and in the chunk header.
unsigned typeCode(ScalarType t) {
    return unsigned(t);
}
ScalarType typeFromCode(unsigned code) {
    if (code > unsigned(ScalarType::Float64))
        throw DataError("volcl HDF5 filter: unknown element type code " + std::to_string(code));
    return ScalarType(code);
}

// Chunks up to this many voxels per axis are one brick; larger chunks are split into bricks of this size.
constexpr std::size_t kMaxBrickAxis = 64;
constexpr int kMaxLevels = 4;

CodecOptions codecOptions(const FilterParameters& p, std::size_t headerBytes) {
    const Dims d = p.frameDims();
    const std::size_t smallest = std::min({d.x, d.y, d.z});
    // As many levels as the smallest axis has halvings, at least one (the codec's transforms need one; a
    // 1-voxel axis passes through them unchanged), at most kMaxLevels.
    int levels = 1;
    while (levels < kMaxLevels && (std::size_t(2) << levels) <= smallest)
        ++levels;
    const std::size_t unit = std::size_t(1) << levels;
    auto brickAxis = [&](std::size_t n) { return (std::min(n, kMaxBrickAxis) + unit - 1) / unit * unit; };
    CodecOptions o;
    o.levels = levels;
    o.brick = {brickAxis(d.x), brickAxis(d.y), brickAxis(d.z)};
    // One host thread: HDF5 hands the filter one chunk at a time, and under MPI every rank runs its own.
    o.threads = 1;
    switch (p.rate) {
    case ChunkRate::Lossless:
        o.rate = RateMode::Lossless;
        break;
    case ChunkRate::MaxError:
        o.rate = RateMode::MaxError;
        o.target = p.bound;
        break;
    case ChunkRate::RelError:
        o.rate = RateMode::RelError;
        o.target = p.bound;
        break;
    case ChunkRate::PwRelError:
        o.rate = RateMode::PwRelError;
        o.target = p.bound;
        break;
    case ChunkRate::Psnr:
        o.rate = RateMode::Psnr;
        o.target = p.bound;
        // A single frame meets the target without the final measurement (it only fills the report). A series'
        // frames share the first frame's steps, and only the measured PSNR of each frame tells the encoder to
        // code again at a finer step when a later frame falls short.
        o.measureError = p.frameCount() > 1;
        break;
    case ChunkRate::Bpv:
        // The bound holds for the stored chunk: the chunk header's bits come out of the budget.
        o.rate = RateMode::Bpv;
        o.target = p.bound - double(headerBytes * 8) / double(d.count() * p.frameCount());
        if (!(o.target > 0))
            throw UsageError("volcl HDF5 filter: " + formatNumber(p.bound) +
                             " bits per voxel leave nothing for the voxels of a chunk of " +
                             std::to_string(d.count() * p.frameCount()) + " voxels after its " +
                             std::to_string(headerBytes) + "-byte header");
        break;
    }
    return o;
}

// PSNR mode: codings of a chunk tried before bounding every voxel's error instead, and the margin (dB) a
// new target gets above the shortfall it makes up.
constexpr int kPsnrAttempts = 4;
constexpr double kPsnrRetryMarginDb = 0.1;

FrameBox frameBox(const Volume& v) {
    const std::size_t size = scalarSize(v.type());
    const std::byte* bytes = v.bytes().data();
    const Dims d = v.dims();
    FrameBox b;
    std::memcpy(b.fill.data(), bytes + (d.count() - 1) * size, size);
    for (std::size_t z = 0; z < d.z; ++z)
        for (std::size_t y = 0; y < d.y; ++y)
            for (std::size_t x = 0; x < d.x; ++x)
                if (std::memcmp(bytes + v.index(x, y, z) * size, b.fill.data(), size) != 0)
                    b.extent = {std::max(b.extent.x, x + 1), std::max(b.extent.y, y + 1),
                                std::max(b.extent.z, z + 1)};
    return b;
}

// Voxels outside the box take one value of the box, the one nearest its mean: the codec then sees no
// padding value in the range and only a small step at the box's faces (replicating the faces copied their
// noise across the padding, which cost more bits than zeros).
void fillBeyond(Volume& v, Dims box) {
    if (box.count() == 0) return; // all `fill`: a constant frame codes to almost nothing
    const std::size_t size = scalarSize(v.type());
    std::byte* bytes = v.bytes().data();
    const Dims d = v.dims();
    double sum = 0;
    for (std::size_t z = 0; z < box.z; ++z)
        for (std::size_t y = 0; y < box.y; ++y)
            for (std::size_t x = 0; x < box.x; ++x)
                sum += v.valueAt(v.index(x, y, z));
    const double mean = sum / double(box.count());
    std::size_t nearest = 0;
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t z = 0; z < box.z; ++z)
        for (std::size_t y = 0; y < box.y; ++y)
            for (std::size_t x = 0; x < box.x; ++x) {
                const std::size_t i = v.index(x, y, z);
                if (const double gap = std::abs(v.valueAt(i) - mean); gap < best) {
                    best = gap;
                    nearest = i;
                }
            }
    std::array<std::byte, 4> value{};
    std::memcpy(value.data(), bytes + nearest * size, size);
    for (std::size_t z = 0; z < d.z; ++z)
        for (std::size_t y = 0; y < d.y; ++y)
            for (std::size_t x = 0; x < d.x; ++x)
                if (x >= box.x || y >= box.y || z >= box.z)
                    std::memcpy(bytes + v.index(x, y, z) * size, value.data(), size);
}

// Value range over box [0, b) of a frame.
std::pair<double, double> boxRange(const Volume& v, Dims b) {
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (std::size_t z = 0; z < b.z; ++z)
        for (std::size_t y = 0; y < b.y; ++y)
            for (std::size_t x = 0; x < b.x; ++x) {
                const double a = v.valueAt(v.index(x, y, z));
                lo = std::min(lo, a);
                hi = std::max(hi, a);
            }
    return {lo, hi};
}

// Largest amount (dB) by which a frame of the coded chunk falls below the target over its box (<= 0: none
// does): PSNR over the box with the box's own value range, as the codec defines it for a frame.
double worstPsnrShortfall(ComputeContext& cc, double target, const TimeSeries& series,
                          const std::vector<Dims>& boxes, const std::vector<std::byte>& vcz) {
    VczReader reader(vcz, "HDF5 chunk");
    double worst = -std::numeric_limits<double>::infinity();
    decodeEachFrame(reader, cc, 1, nullptr, [&](std::size_t f, Volume&& decoded) {
        const Volume& v = series.frames[f];
        const Dims b = boxes[f];
        const auto [lo, hi] = boxRange(v, b);
        double sumSq = 0;
        for (std::size_t z = 0; z < b.z; ++z)
            for (std::size_t y = 0; y < b.y; ++y)
                for (std::size_t x = 0; x < b.x; ++x) {
                    const std::size_t i = v.index(x, y, z);
                    const double e = decoded.valueAt(i) - v.valueAt(i);
                    sumSq += e * e;
                }
        if (sumSq == 0) return;
        const double psnr = hi > lo ? 10 * std::log10((hi - lo) * (hi - lo) * double(b.count()) / sumSq)
                                    : -std::numeric_limits<double>::infinity();
        worst = std::max(worst, target - psnr);
    });
    return worst;
}

void putU32(std::byte* dst, std::uint32_t v) {
    for (int i = 0; i < 4; ++i)
        dst[i] = std::byte(v >> (8 * i));
}
std::uint32_t getU32(const std::byte* src) {
    std::uint32_t v = 0;
    for (int i = 0; i < 4; ++i)
        v |= std::uint32_t(src[i]) << (8 * i);
    return v;
}

void putU64(std::byte* dst, std::uint64_t v) {
    for (int i = 0; i < 8; ++i)
        dst[i] = std::byte(v >> (8 * i));
}
std::uint64_t getU64(const std::byte* src) {
    std::uint64_t v = 0;
    for (int i = 0; i < 8; ++i)
        v |= std::uint64_t(src[i]) << (8 * i);
    return v;
}

} // namespace

Dims FilterParameters::frameDims() const noexcept {
    const std::size_t* d = chunk.data() + (rank == 4 ? 1 : 0);
    return {d[2], d[1], d[0]};
}
std::size_t FilterParameters::frameCount() const noexcept {
    return rank == 4 ? chunk[0] : 1;
}
std::size_t FilterParameters::chunkBytes() const noexcept {
    return frameDims().count() * frameCount() * scalarSize(type);
}

void parseUserValues(std::span<const unsigned> values, ChunkRate& rate, double& bound) {
    rate = ChunkRate::Lossless;
    bound = 0;
    if (values.empty()) return;
    if (values[0] > unsigned(ChunkRate::PwRelError))
        throw UsageError("volcl HDF5 filter: cd_values[0] = " + std::to_string(values[0]) +
                         " is not a rate (0 lossless, 1 max-error, 2 PSNR, 3 bits per voxel, 4 relative "
                         "error, 5 point-wise relative error)");
    rate = ChunkRate(values[0]);
    if (rate == ChunkRate::Lossless) return;
    if (values.size() < 3)
        throw UsageError("volcl HDF5 filter: the lossy rates need the bound as a double in cd_values[1..2]");
    bound = std::bit_cast<double>(std::uint64_t(values[1]) | std::uint64_t(values[2]) << 32);
    if (!std::isfinite(bound) || !(bound > 0))
        throw UsageError("volcl HDF5 filter: the bound in cd_values[1..2] must be a finite number > 0, got " +
                         std::to_string(bound));
}

std::array<unsigned, 3> userValues(ChunkRate rate, double bound) {
    const auto bits = std::bit_cast<std::uint64_t>(rate == ChunkRate::Lossless ? 0.0 : bound);
    return {unsigned(rate), unsigned(bits & 0xffffffffu), unsigned(bits >> 32)};
}

std::vector<unsigned> packParameters(const FilterParameters& p) {
    const auto user = userValues(p.rate, p.bound);
    std::vector<unsigned> v{user[0], user[1], user[2], kFilterParameterVersion, typeCode(p.type), p.rank};
    for (unsigned i = 0; i < p.rank; ++i)
        v.push_back(unsigned(p.chunk[i]));
    return v;
}

FilterParameters unpackParameters(std::span<const unsigned> values) {
    if (values.size() < 6 || values[3] != kFilterParameterVersion)
        throw DataError(
            "volcl HDF5 filter: the dataset's filter parameters are missing or of another version");
    FilterParameters p;
    try {
        parseUserValues(values.first(3), p.rate, p.bound);
    } catch (const UsageError& e) {
        throw DataError(e.what());
    }
    p.type = typeFromCode(values[4]);
    p.rank = values[5];
    if ((p.rank != 3 && p.rank != 4) || values.size() != 6 + p.rank)
        throw DataError("volcl HDF5 filter: the filter parameters name a chunk rank other than 3 or 4");
    for (unsigned i = 0; i < p.rank; ++i) {
        if (values[6 + i] == 0)
            throw DataError("volcl HDF5 filter: a chunk dimension in the parameters is 0");
        p.chunk[i] = values[6 + i];
    }
    // HDF5 chunks hold less than 4 GiB; a larger product means the parameters are damaged.
    if (double(p.frameDims().count()) * double(p.frameCount()) * double(scalarSize(p.type)) >= 4294967296.0)
        throw DataError("volcl HDF5 filter: the filter parameters describe a chunk of 4 GiB or more");
    return p;
}

namespace {

// The stored chunk, its lossy frames coded over their boxes when `trim`.
std::vector<std::byte> encodeFrames(ComputeContext& cc, const FilterParameters& p,
                                    std::span<const std::byte> chunk, bool trim) {
    const Dims d = p.frameDims();
    const std::size_t frameBytes = d.count() * scalarSize(p.type);
    TimeSeries series;
    for (std::size_t f = 0; f < p.frameCount(); ++f) {
        Volume v(d, p.type);
        std::memcpy(v.bytes().data(), chunk.data() + f * frameBytes, frameBytes);
        series.frames.push_back(std::move(v));
    }
    std::vector<FrameBox> boxes;
    std::vector<Dims> coded(p.frameCount(), d); // the voxels the codec's bound must hold on, per frame
    bool trimmed = false, constantBox = false;
    if (trim) {
        for (const Volume& v : series.frames) {
            boxes.push_back(frameBox(v));
            trimmed = trimmed || !(boxes.back().extent == d);
        }
        if (trimmed)
            for (std::size_t f = 0; f < p.frameCount(); ++f) {
                coded[f] = boxes[f].extent;
                const auto [lo, hi] = boxRange(series.frames[f], coded[f]);
                constantBox = constantBox || (coded[f].count() > 0 && lo == hi);
                fillBeyond(series.frames[f], coded[f]);
            }
        else
            boxes.clear();
    }
    const std::size_t headerBytes = trimmed ? boxedHeaderBytes(p) : kChunkHeaderSize;
    CodecOptions options = codecOptions(p, headerBytes);
    // A constant box beside other values (the real voxels may hold both) has a PSNR only when exact.
    if (p.rate == ChunkRate::Psnr && constantBox) options.rate = RateMode::Lossless;
    auto encode = [&] {
        return p.frameCount() == 1 ? encodeVolume(cc, series.frames[0], options)
                                   : encodeSeries(cc, series, options);
    };
    std::vector<std::byte> vcz = encode();
    if (options.rate == RateMode::Psnr) {
        // The codec holds the target over the whole (filled) frame, not over the box: code again with
        // the target raised by the worst shortfall, and as a last resort bound every voxel's error by E =
        // (smallest box range) * 10^(-target / 20), which bounds each box's MSE by E^2.
        for (int attempt = 0; attempt < kPsnrAttempts; ++attempt) {
            const double shortfall = worstPsnrShortfall(cc, p.bound, series, coded, vcz);
            if (!(shortfall > 0)) break;
            if (!std::isfinite(shortfall)) { // a constant frame coded inexactly: only exact meets it
                options.rate = RateMode::Lossless;
                vcz = encode();
                break;
            }
            if (attempt + 1 < kPsnrAttempts) {
                options.target += shortfall + kPsnrRetryMarginDb;
            } else {
                double smallest = std::numeric_limits<double>::infinity();
                for (std::size_t f = 0; f < p.frameCount(); ++f) {
                    const auto [lo, hi] = boxRange(series.frames[f], coded[f]);
                    if (hi > lo) smallest = std::min(smallest, hi - lo);
                }
                options.rate = RateMode::MaxError;
                options.target = smallest * std::pow(10.0, -p.bound / 20);
            }
            vcz = encode();
        }
    }
    std::vector<std::byte> out(headerBytes + vcz.size());
    std::memcpy(out.data(), kChunkMagic.data(), 4);
    out[4] = std::byte(trimmed ? kChunkVersionBoxes : kChunkVersion);
    out[5] = std::byte(p.rank);
    out[6] = std::byte(typeCode(p.type));
    out[7] = std::byte(unsigned(p.rate));
    for (unsigned i = 0; i < 4; ++i)
        putU64(out.data() + 8 + 8 * i, i < p.rank ? p.chunk[i] : 0);
    for (std::size_t f = 0; f < boxes.size(); ++f) {
        std::byte* at = out.data() + kChunkHeaderSize + f * kFrameBoxBytes;
        putU32(at, std::uint32_t(boxes[f].extent.x));
        putU32(at + 4, std::uint32_t(boxes[f].extent.y));
        putU32(at + 8, std::uint32_t(boxes[f].extent.z));
        std::memcpy(at + 12, boxes[f].fill.data(), 4);
    }
    if (trimmed)
        putU32(out.data() + headerBytes - kBoxChecksumBytes,
               boxChecksum(std::span(out).first(headerBytes - kBoxChecksumBytes)));
    std::memcpy(out.data() + headerBytes, vcz.data(), vcz.size());
    return out;
}

} // namespace

std::vector<std::byte> encodeChunk(ComputeContext& cc, const FilterParameters& p,
                                   std::span<const std::byte> chunk) {
    if (chunk.size() != p.chunkBytes())
        throw DataError("volcl HDF5 filter: chunk of " + std::to_string(chunk.size()) + " bytes, expected " +
                        std::to_string(p.chunkBytes()));
    // Lossy chunks code each frame's box only (lossless ones are exact as they are). A bits-per-voxel budget
    // that the boxes' header bytes leave too small for the codec is tried again without them.
    if (p.rate == ChunkRate::Bpv) {
        try {
            return encodeFrames(cc, p, chunk, true);
        } catch (const UsageError&) {
            return encodeFrames(cc, p, chunk, false);
        }
    }
    // Float64 frames are coded whole: the frame boxes' fill holds 4 bytes, and the codec's float64 layer
    // bounds every voxel of the frame, the edge chunks' padding included.
    return encodeFrames(cc, p, chunk, p.rate != ChunkRate::Lossless && p.type != ScalarType::Float64);
}

void decodeChunk(ComputeContext& cc, const FilterParameters& p, std::span<const std::byte> stored,
                 std::span<std::byte> chunk) {
    if (stored.size() < kChunkHeaderSize || std::memcmp(stored.data(), kChunkMagic.data(), 4) != 0)
        throw IoError("volcl HDF5 filter: stored chunk is not volcl data (bad magic or truncated)");
    const unsigned version = unsigned(stored[4]);
    if (version != kChunkVersion && version != kChunkVersionBoxes)
        throw IoError("volcl HDF5 filter: stored chunk has format version " + std::to_string(version));
    bool same = unsigned(stored[5]) == p.rank && unsigned(stored[6]) == typeCode(p.type) &&
                unsigned(stored[7]) == unsigned(p.rate);
    for (unsigned i = 0; i < 4; ++i)
        same = same && getU64(stored.data() + 8 + 8 * i) == (i < p.rank ? p.chunk[i] : 0);
    if (!same)
        throw DataError(
            "volcl HDF5 filter: stored chunk describes another chunk shape, element type or rate");
    if (chunk.size() != p.chunkBytes())
        throw DataError("volcl HDF5 filter: output buffer of " + std::to_string(chunk.size()) +
                        " bytes, expected " + std::to_string(p.chunkBytes()));

    const Dims d = p.frameDims();
    const std::size_t headerBytes = version == kChunkVersionBoxes ? boxedHeaderBytes(p) : kChunkHeaderSize;
    if (stored.size() < headerBytes) throw IoError("volcl HDF5 filter: stored chunk is truncated");
    if (version == kChunkVersionBoxes && getU32(stored.data() + headerBytes - kBoxChecksumBytes) !=
                                             boxChecksum(stored.first(headerBytes - kBoxChecksumBytes)))
        throw IoError("volcl HDF5 filter: stored chunk's frame boxes are corrupted (checksum mismatch)");
    std::vector<FrameBox> boxes(version == kChunkVersionBoxes ? p.frameCount() : 0);
    for (std::size_t f = 0; f < boxes.size(); ++f) {
        const std::byte* at = stored.data() + kChunkHeaderSize + f * kFrameBoxBytes;
        boxes[f].extent = {getU32(at), getU32(at + 4), getU32(at + 8)};
        std::memcpy(boxes[f].fill.data(), at + 12, 4);
        const Dims e = boxes[f].extent;
        const bool empty = e.x == 0 && e.y == 0 && e.z == 0;
        const bool inside = e.x >= 1 && e.y >= 1 && e.z >= 1 && e.x <= d.x && e.y <= d.y && e.z <= d.z;
        if (!empty && !inside)
            throw DataError("volcl HDF5 filter: a stored chunk's frame box lies outside the chunk");
    }
    const auto vcz = stored.subspan(headerBytes);
    VczReader reader(std::vector<std::byte>(vcz.begin(), vcz.end()), "HDF5 chunk");
    if (!(reader.header().dims == d) || reader.header().voxelType() != p.type ||
        reader.header().frames.size() != p.frameCount())
        throw DataError("volcl HDF5 filter: the chunk's .vcz does not match the chunk shape or element type");
    const std::size_t frameBytes = d.count() * scalarSize(p.type);
    for (std::size_t f = 0; f < p.frameCount(); ++f) {
        DecodeOptions o;
        o.frame = f;
        o.threads = 1;
        const Volume v = reader.decode(cc, o);
        if (v.byteSize() != frameBytes)
            throw DataError("volcl HDF5 filter: a decoded frame has the wrong size");
        std::byte* frame = chunk.data() + f * frameBytes;
        std::memcpy(frame, v.bytes().data(), frameBytes);
        if (boxes.empty()) continue;
        // Outside its box the frame was `fill` throughout: restored exactly.
        const Dims e = boxes[f].extent;
        const std::size_t size = scalarSize(p.type);
        for (std::size_t z = 0; z < d.z; ++z)
            for (std::size_t y = 0; y < d.y; ++y)
                for (std::size_t x = 0; x < d.x; ++x)
                    if (x >= e.x || y >= e.y || z >= e.z)
                        std::memcpy(frame + v.index(x, y, z) * size, boxes[f].fill.data(), size);
    }
}

} // namespace volcl::hdf5
