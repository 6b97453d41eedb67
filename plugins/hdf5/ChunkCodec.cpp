// HDF5 chunks <-> volcl-compressed bytes: parameter words, the stored chunk header, codec calls.
#include "plugins/hdf5/ChunkCodec.hpp"

#include "core/Error.hpp"
#include "core/Format.hpp"
#include "wavelet/Codec.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>

namespace volcl::hdf5 {
namespace {

// Stored chunk: this header, then one .vcz holding the chunk's frames.
constexpr std::array<unsigned char, 4> kChunkMagic{'V', 'C', 'Z', 'H'};
constexpr std::uint8_t kChunkVersion = 1;
constexpr std::size_t kChunkHeaderSize = 4 + 4 + 4 * 8; // magic, version/rank/type/rate, 4 dims

// Codes of the element types in cd_values and in the chunk header.
unsigned typeCode(ScalarType t) {
    return unsigned(t);
}
ScalarType typeFromCode(unsigned code) {
    if (code > unsigned(ScalarType::Float32))
        throw DataError("volcl HDF5 filter: unknown element type code " + std::to_string(code));
    return ScalarType(code);
}

// Chunks up to this many voxels per axis are one brick; larger chunks are split into bricks of this size.
constexpr std::size_t kMaxBrickAxis = 64;
constexpr int kMaxLevels = 4;

CodecOptions codecOptions(const FilterParameters& p) {
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
        o.target = p.bound - double(kChunkHeaderSize * 8) / double(d.count() * p.frameCount());
        if (!(o.target > 0))
            throw UsageError("volcl HDF5 filter: " + formatNumber(p.bound) +
                             " bits per voxel leave nothing for the voxels of a chunk of " +
                             std::to_string(d.count() * p.frameCount()) + " voxels after its " +
                             std::to_string(kChunkHeaderSize) + "-byte header");
        break;
    }
    return o;
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
    if (values[0] > unsigned(ChunkRate::Bpv))
        throw UsageError("volcl HDF5 filter: cd_values[0] = " + std::to_string(values[0]) +
                         " is not a rate (0 lossless, 1 max-error, 2 PSNR, 3 bits per voxel)");
    rate = ChunkRate(values[0]);
    if (rate == ChunkRate::Lossless) return;
    if (values.size() < 3)
        throw UsageError("volcl HDF5 filter: max-error, PSNR and bits per voxel need the bound as a double "
                         "in cd_values[1..2]");
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

std::vector<std::byte> encodeChunk(ComputeContext& cc, const FilterParameters& p,
                                   std::span<const std::byte> chunk) {
    if (chunk.size() != p.chunkBytes())
        throw DataError("volcl HDF5 filter: chunk of " + std::to_string(chunk.size()) + " bytes, expected " +
                        std::to_string(p.chunkBytes()));
    const Dims d = p.frameDims();
    const std::size_t frameBytes = d.count() * scalarSize(p.type);
    const CodecOptions options = codecOptions(p);
    std::vector<std::byte> vcz;
    if (p.frameCount() == 1) {
        Volume v(d, p.type);
        std::memcpy(v.bytes().data(), chunk.data(), frameBytes);
        vcz = encodeVolume(cc, v, options);
    } else {
        TimeSeries series;
        for (std::size_t f = 0; f < p.frameCount(); ++f) {
            Volume v(d, p.type);
            std::memcpy(v.bytes().data(), chunk.data() + f * frameBytes, frameBytes);
            series.frames.push_back(std::move(v));
        }
        vcz = encodeSeries(cc, series, options);
    }
    std::vector<std::byte> out(kChunkHeaderSize + vcz.size());
    std::memcpy(out.data(), kChunkMagic.data(), 4);
    out[4] = std::byte(kChunkVersion);
    out[5] = std::byte(p.rank);
    out[6] = std::byte(typeCode(p.type));
    out[7] = std::byte(unsigned(p.rate));
    for (unsigned i = 0; i < 4; ++i)
        putU64(out.data() + 8 + 8 * i, i < p.rank ? p.chunk[i] : 0);
    std::memcpy(out.data() + kChunkHeaderSize, vcz.data(), vcz.size());
    return out;
}

void decodeChunk(ComputeContext& cc, const FilterParameters& p, std::span<const std::byte> stored,
                 std::span<std::byte> chunk) {
    if (stored.size() < kChunkHeaderSize || std::memcmp(stored.data(), kChunkMagic.data(), 4) != 0)
        throw IoError("volcl HDF5 filter: stored chunk is not volcl data (bad magic or truncated)");
    if (unsigned(stored[4]) != kChunkVersion)
        throw IoError("volcl HDF5 filter: stored chunk has format version " +
                      std::to_string(unsigned(stored[4])));
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

    const auto vcz = stored.subspan(kChunkHeaderSize);
    VczReader reader(std::vector<std::byte>(vcz.begin(), vcz.end()), "HDF5 chunk");
    const Dims d = p.frameDims();
    if (!(reader.header().dims == d) || reader.header().type != p.type ||
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
        std::memcpy(chunk.data() + f * frameBytes, v.bytes().data(), frameBytes);
    }
}

} // namespace volcl::hdf5
