// HDF5 filter plugin: chunk codec round trips and refusals, then datasets written and read through HDF5.
#include "plugins/hdf5/ChunkCodec.hpp"
#include "plugins/hdf5/H5Zvolcl.h"

#include "core/Error.hpp"
#include "tests/TestUtil.hpp"
#include "wavelet/Codec.hpp"

#include <hdf5.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

namespace {

using namespace volcl;
using volcl::hdf5::ChunkRate;
using volcl::hdf5::FilterParameters;

FilterParameters params(ScalarType type, std::vector<std::size_t> chunk, ChunkRate rate = ChunkRate::Lossless,
                        double bound = 0) {
    FilterParameters p;
    p.type = type;
    p.rank = unsigned(chunk.size());
    for (std::size_t i = 0; i < chunk.size(); ++i)
        p.chunk[i] = chunk[i];
    p.rate = rate;
    p.bound = bound;
    return p;
}

// A chunk of smooth waves plus noise, with the type's extreme values sprinkled in (and NaN/Inf/-0/denormals
// for float32 when `specials`).
std::vector<std::byte> makeChunk(const FilterParameters& p, bool specials, unsigned seed = 1) {
    const std::size_t n = p.chunkBytes() / scalarSize(p.type);
    std::vector<std::byte> bytes(p.chunkBytes());
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> noise(-1, 1);
    for (std::size_t i = 0; i < n; ++i) {
        const double v = 0.5 + 0.4 * std::sin(0.07 * double(i)) + 0.05 * noise(rng); // in [0.05, 0.95]
        switch (p.type) {
        case ScalarType::UInt8:
            reinterpret_cast<std::uint8_t*>(bytes.data())[i] = std::uint8_t(v * 255);
            break;
        case ScalarType::UInt16:
            reinterpret_cast<std::uint16_t*>(bytes.data())[i] = std::uint16_t(v * 65535);
            break;
        case ScalarType::Int16:
            reinterpret_cast<std::int16_t*>(bytes.data())[i] = std::int16_t(v * 65535 - 32768);
            break;
        case ScalarType::Float32:
            reinterpret_cast<float*>(bytes.data())[i] = float(v * 1000 - 500);
            break;
        case ScalarType::Float64: // detail below float32's precision
            reinterpret_cast<double*>(bytes.data())[i] = v * 1000 - 500 + 1e-9 * noise(rng);
            break;
        }
    }
    if (n >= 8) {
        auto put = [&](std::size_t i, auto value) {
            std::memcpy(bytes.data() + i * sizeof(value), &value, sizeof(value));
        };
        switch (p.type) {
        case ScalarType::UInt8:
            put(0, std::uint8_t(0)), put(n - 1, std::uint8_t(255));
            break;
        case ScalarType::UInt16:
            put(0, std::uint16_t(0)), put(n - 1, std::uint16_t(65535));
            break;
        case ScalarType::Int16:
            put(0, std::int16_t(-32768)), put(n - 1, std::int16_t(32767));
            break;
        case ScalarType::Float32:
            if (specials) {
                put(0, std::numeric_limits<float>::quiet_NaN());
                put(1, std::numeric_limits<float>::infinity());
                put(2, -std::numeric_limits<float>::infinity());
                put(3, -0.0f);
                put(4, std::numeric_limits<float>::denorm_min());
                put(5, std::numeric_limits<float>::max());
                put(n - 1, std::numeric_limits<float>::lowest());
            }
            break;
        case ScalarType::Float64: // NaN with a payload, Inf, -0, subnormal, and beyond float32's range
            if (specials) {
                put(0, std::bit_cast<double>(0x7ff8000000001234ull));
                put(1, std::numeric_limits<double>::infinity());
                put(2, -std::numeric_limits<double>::infinity());
                put(3, -0.0);
                put(4, 1e-310);
                put(5, 1e300);
                put(n - 1, -1e-300);
            }
            break;
        }
    }
    return bytes;
}

double valueAt(const FilterParameters& p, std::span<const std::byte> b, std::size_t i) {
    switch (p.type) {
    case ScalarType::UInt8:
        return double(reinterpret_cast<const std::uint8_t*>(b.data())[i]);
    case ScalarType::UInt16:
        return double(reinterpret_cast<const std::uint16_t*>(b.data())[i]);
    case ScalarType::Int16:
        return double(reinterpret_cast<const std::int16_t*>(b.data())[i]);
    case ScalarType::Float32:
        return double(reinterpret_cast<const float*>(b.data())[i]);
    case ScalarType::Float64:
        return reinterpret_cast<const double*>(b.data())[i];
    }
    return 0;
}

double maxAbsDifference(const FilterParameters& p, std::span<const std::byte> a,
                        std::span<const std::byte> b) {
    double worst = 0;
    for (std::size_t i = 0; i < p.chunkBytes() / scalarSize(p.type); ++i)
        worst = std::max(worst, std::abs(valueAt(p, a, i) - valueAt(p, b, i)));
    return worst;
}

std::vector<std::byte> roundTrip(const FilterParameters& p, const std::vector<std::byte>& chunk,
                                 std::size_t* storedBytes = nullptr) {
    auto& cc = test::computeContext();
    const auto stored = hdf5::encodeChunk(cc, p, chunk);
    if (storedBytes) *storedBytes = stored.size();
    std::vector<std::byte> back(p.chunkBytes());
    hdf5::decodeChunk(cc, p, stored, back);
    return back;
}

// --- parameter words ---------------------------------------------------------------------------------------

TEST(Hdf5FilterParameters, UserValuesRoundTripAndDefaults) {
    ChunkRate rate;
    double bound;
    hdf5::parseUserValues({}, rate, bound); // compression=420 alone
    EXPECT_EQ(rate, ChunkRate::Lossless);
    const unsigned lossless[] = {0};
    hdf5::parseUserValues(lossless, rate, bound);
    EXPECT_EQ(rate, ChunkRate::Lossless);
    for (double b : {0.5, 1e-7, 60.0, 3.0e9}) {
        const auto words = hdf5::userValues(ChunkRate::MaxError, b);
        hdf5::parseUserValues(words, rate, bound);
        EXPECT_EQ(rate, ChunkRate::MaxError);
        EXPECT_EQ(bound, b);
        // The documented layout: the IEEE bits of the double, low 32 bits first.
        EXPECT_EQ(std::uint64_t(words[1]) | std::uint64_t(words[2]) << 32, std::bit_cast<std::uint64_t>(b));
    }
}

TEST(Hdf5FilterParameters, BadUserValuesAreRefused) {
    ChunkRate rate;
    double bound;
    const unsigned unknownRate[] = {7};
    const unsigned missingBound[] = {1};
    EXPECT_THROW(hdf5::parseUserValues(unknownRate, rate, bound), UsageError);
    EXPECT_THROW(hdf5::parseUserValues(missingBound, rate, bound), UsageError);
    for (double b :
         {0.0, -1.0, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
        const auto bits = std::bit_cast<std::uint64_t>(b);
        const unsigned words[] = {2, unsigned(bits & 0xffffffffu), unsigned(bits >> 32)};
        EXPECT_THROW(hdf5::parseUserValues(words, rate, bound), UsageError) << b;
    }
}

TEST(Hdf5FilterParameters, PackedParametersRoundTripAndDamageIsRefused) {
    const auto p = params(ScalarType::Int16, {3, 16, 20, 24}, ChunkRate::MaxError, 2.5);
    const auto words = hdf5::packParameters(p);
    ASSERT_EQ(words.size(), 10u);
    const auto q = hdf5::unpackParameters(words);
    EXPECT_EQ(q.type, p.type);
    EXPECT_EQ(q.rank, 4u);
    EXPECT_EQ(q.chunk, p.chunk);
    EXPECT_EQ(q.bound, 2.5);
    EXPECT_EQ(q.frameCount(), 3u);
    EXPECT_EQ(q.frameDims(), (Dims{24, 20, 16}));

    auto damaged = [&](std::size_t i, unsigned v) {
        auto w = words;
        w[i] = v;
        return w;
    };
    EXPECT_THROW(hdf5::unpackParameters(std::span(words).first(5)), DataError); // user values only
    EXPECT_THROW(hdf5::unpackParameters(damaged(3, 99)), DataError);            // other version
    EXPECT_THROW(hdf5::unpackParameters(damaged(4, 9)), DataError);             // unknown type
    EXPECT_THROW(hdf5::unpackParameters(damaged(5, 2)), DataError);             // rank 2
    EXPECT_THROW(hdf5::unpackParameters(damaged(7, 0)), DataError);             // zero dim
    EXPECT_THROW(hdf5::unpackParameters(damaged(7, 0xffffffffu)), DataError);   // >= 4 GiB chunk
}

// --- chunk codec -------------------------------------------------------------------------------------------

TEST(Hdf5ChunkCodec, LosslessIsExactForEveryTypeWithExtremeValues) {
    for (ScalarType t : {ScalarType::UInt8, ScalarType::UInt16, ScalarType::Int16, ScalarType::Float32,
                         ScalarType::Float64}) {
        const auto p = params(t, {13, 17, 32});
        const auto chunk = makeChunk(p, true);
        std::size_t stored = 0;
        EXPECT_EQ(roundTrip(p, chunk, &stored), chunk) << scalarTypeName(t);
        EXPECT_GT(stored, 0u);
    }
}

TEST(Hdf5ChunkCodec, FourDimensionalChunkIsASeriesOfFrames) {
    const auto p = params(ScalarType::UInt16, {3, 8, 16, 16});
    auto chunk = makeChunk(p, false);
    EXPECT_EQ(roundTrip(p, chunk), chunk);
    const auto one = params(ScalarType::Float32, {1, 4, 4, 4});
    const auto c1 = makeChunk(one, true);
    EXPECT_EQ(roundTrip(one, c1), c1);
}

TEST(Hdf5ChunkCodec, DegenerateChunkShapesRoundTrip) {
    for (std::vector<std::size_t> d : {std::vector<std::size_t>{1, 1, 1},
                                       {1, 64, 64},
                                       {64, 1, 1},
                                       {2, 3, 100},
                                       {5, 7, 9},
                                       {65, 3, 2},
                                       {1, 1, 200}}) {
        const auto p = params(ScalarType::UInt8, d);
        const auto chunk = makeChunk(p, false, unsigned(d[2]));
        EXPECT_EQ(roundTrip(p, chunk), chunk) << d[0] << "x" << d[1] << "x" << d[2];
    }
}

// Float64 chunks: every bounded rate on every voxel in double (NaN/Inf bit for bit), a 4D chunk included.
TEST(Hdf5ChunkCodec, Float64BoundsHoldOnEveryVoxel) {
    for (ChunkRate rate : {ChunkRate::MaxError, ChunkRate::RelError, ChunkRate::PwRelError}) {
        const double bound = rate == ChunkRate::MaxError ? 0.05 : 1e-4;
        for (std::vector<std::size_t> shape : {std::vector<std::size_t>{13, 17, 32}, {2, 8, 9, 10}}) {
            const auto p = params(ScalarType::Float64, shape, rate, bound);
            const auto chunk = makeChunk(p, true);
            const auto back = roundTrip(p, chunk);
            const std::size_t n = p.chunkBytes() / 8;
            double lo = INFINITY, hi = -INFINITY;
            for (std::size_t i = 0; i < n; ++i)
                if (const double x = valueAt(p, chunk, i); std::isfinite(x))
                    lo = std::min(lo, x), hi = std::max(hi, x);
            std::size_t wrong = 0;
            for (std::size_t i = 0; i < n; ++i) {
                const double x = valueAt(p, chunk, i), y = valueAt(p, back, i);
                const double allowed = rate == ChunkRate::MaxError   ? bound
                                       : rate == ChunkRate::RelError ? bound * hi - bound * lo
                                                                     : bound * std::abs(x);
                if (!std::isfinite(x) || x == 0)
                    wrong += std::bit_cast<std::uint64_t>(x) != std::bit_cast<std::uint64_t>(y) &&
                             !(rate != ChunkRate::PwRelError && x == 0 && std::abs(y) <= allowed);
                else
                    wrong += !(std::abs(x - y) <= allowed);
            }
            EXPECT_EQ(wrong, 0u) << int(rate) << " " << shape.size() << "D";
        }
    }
}

TEST(Hdf5ChunkCodec, MaxErrorHoldsItsBound) {
    struct Case {
        ScalarType type;
        double bound;
    };
    for (Case c :
         {Case{ScalarType::Float32, 0.01}, Case{ScalarType::Float32, 5.0}, Case{ScalarType::UInt16, 3.0},
          Case{ScalarType::Int16, 40.0}, Case{ScalarType::UInt8, 1.0}}) {
        const auto p = params(c.type, {20, 32, 33}, ChunkRate::MaxError, c.bound);
        const auto chunk = makeChunk(p, false);
        std::size_t stored = 0;
        const auto back = roundTrip(p, chunk, &stored);
        EXPECT_LE(maxAbsDifference(p, chunk, back), c.bound)
            << scalarTypeName(c.type) << " bound " << c.bound;
        EXPECT_LT(stored, p.chunkBytes()) << scalarTypeName(c.type);
    }
}

TEST(Hdf5ChunkCodec, PsnrReachesItsTarget) {
    struct Case {
        std::size_t edge;
        double db;
    };
    for (Case c : {Case{32, 45.0}, Case{24, 40.0}, Case{16, 30.0}}) {
        const auto p = params(ScalarType::Float32, {c.edge, c.edge, c.edge}, ChunkRate::Psnr, c.db);
        const auto chunk = makeChunk(p, false);
        std::size_t stored = 0;
        const auto back = roundTrip(p, chunk, &stored);
        Volume a(p.frameDims(), p.type), b(p.frameDims(), p.type);
        std::memcpy(a.bytes().data(), chunk.data(), chunk.size());
        std::memcpy(b.bytes().data(), back.data(), back.size());
        // The rate control aims at [target, target + 0.25] dB.
        EXPECT_GE(psnr(a, b), c.db - 0.1) << c.edge;
        EXPECT_LE(psnr(a, b), c.db + 3.0) << c.edge;
        EXPECT_LT(stored, chunk.size() / 2) << c.edge;
    }
}

// An edge chunk as HDF5 hands it over: real voxels in [0, real) (a field offset from 0), zeros beyond.
std::vector<std::byte> paddedChunk(const FilterParameters& p, Dims real, std::size_t realFrames) {
    std::vector<std::byte> chunk = makeChunk(p, false, 7);
    const Dims d = p.frameDims();
    const std::size_t size = scalarSize(p.type);
    for (std::size_t f = 0; f < p.frameCount(); ++f)
        for (std::size_t z = 0; z < d.z; ++z)
            for (std::size_t y = 0; y < d.y; ++y)
                for (std::size_t x = 0; x < d.x; ++x)
                    if (f >= realFrames || x >= real.x || y >= real.y || z >= real.z)
                        std::memset(chunk.data() + ((f * d.z + z) * d.y + y) * d.x * size + x * size, 0,
                                    size);
    return chunk;
}

// PSNR over the real voxels [0, real) of frame f with their own value range, from the decoded bytes.
double realVoxelPsnr(const FilterParameters& p, std::span<const std::byte> in, std::span<const std::byte> out,
                     Dims real, std::size_t f) {
    const Dims d = p.frameDims();
    double lo = std::numeric_limits<double>::infinity(), hi = -lo, sumSq = 0;
    for (std::size_t z = 0; z < real.z; ++z)
        for (std::size_t y = 0; y < real.y; ++y)
            for (std::size_t x = 0; x < real.x; ++x) {
                const std::size_t i = ((f * d.z + z) * d.y + y) * d.x + x;
                const double a = valueAt(p, in, i), e = valueAt(p, out, i) - a;
                lo = std::min(lo, a);
                hi = std::max(hi, a);
                sumSq += e * e;
            }
    return sumSq == 0 ? std::numeric_limits<double>::infinity()
                      : 10 * std::log10((hi - lo) * (hi - lo) * double(real.count()) / sumSq);
}

// The filter cannot know which voxels of a chunk are padding: every mode must hold on the real voxels of
// any edge chunk, PSNR over their own range (the padding once made 4.8 dB of a 40 dB target).
TEST(Hdf5ChunkCodec, EveryModeHoldsOnTheRealVoxelsOfPaddedEdgeChunks) {
    struct Case {
        ScalarType type;
        std::vector<std::size_t> chunk;
        Dims real;
        std::size_t realFrames;
    };
    for (const Case& c : {Case{ScalarType::Float32, {16, 8, 32}, {6, 8, 16}, 1},
                          Case{ScalarType::Float32, {16, 8, 32}, {32, 1, 1}, 1},
                          Case{ScalarType::Float32, {16, 8, 32}, {6, 1, 1}, 1},
                          Case{ScalarType::UInt16, {8, 8, 16}, {5, 3, 7}, 1},
                          Case{ScalarType::Int16, {2, 8, 8, 16}, {16, 5, 8}, 1}}) {
        for (const auto& [rate, bound] :
             {std::pair{ChunkRate::Psnr, 40.0}, std::pair{ChunkRate::MaxError, 0.5},
              std::pair{ChunkRate::Bpv, 4.0}, std::pair{ChunkRate::Lossless, 0.0}}) {
            const auto p = params(c.type, c.chunk, rate, bound);
            const auto chunk = paddedChunk(p, c.real, c.realFrames);
            std::size_t stored = 0;
            const auto back = roundTrip(p, chunk, &stored);
            const std::string what = std::string(scalarTypeName(c.type)) + " real " +
                                     std::to_string(c.real.x) + "x" + std::to_string(c.real.y) + "x" +
                                     std::to_string(c.real.z) + " rate " + std::to_string(unsigned(rate));
            switch (rate) {
            case ChunkRate::Psnr:
                for (std::size_t f = 0; f < c.realFrames; ++f)
                    EXPECT_GE(realVoxelPsnr(p, chunk, back, c.real, f), bound) << what;
                break;
            case ChunkRate::MaxError:
                EXPECT_LE(maxAbsDifference(p, chunk, back), bound) << what;
                break;
            case ChunkRate::Bpv:
                EXPECT_LE(double(stored) * 8, bound * double(p.frameDims().count() * p.frameCount())) << what;
                break;
            case ChunkRate::Lossless:
                EXPECT_EQ(back, chunk) << what;
                break;
            }
        }
    }
}

// A chunk coded over its frames' boxes keeps them in a checksummed table: any damaged byte before the .vcz
// is an error, never other data.
TEST(Hdf5ChunkCodec, DamagedFrameBoxesAreRefused) {
    auto& cc = test::computeContext();
    const auto p = params(ScalarType::Float32, {16, 8, 32}, ChunkRate::Psnr, 40.0);
    const auto chunk = paddedChunk(p, {6, 8, 16}, 1);
    const auto stored = hdf5::encodeChunk(cc, p, chunk);
    ASSERT_EQ(unsigned(stored[4]), 2u); // the boxed layout
    std::vector<std::byte> out(p.chunkBytes());
    for (std::size_t i = 0; i < 40 + 16 + 4; ++i) {
        auto bad = stored;
        bad[i] ^= std::byte(0x21);
        EXPECT_THROW(hdf5::decodeChunk(cc, p, bad, out), Error) << "byte " << i;
    }
}

TEST(Hdf5ChunkCodec, BitsPerVoxelBoundTheStoredChunkHeaderIncluded) {
    struct Case {
        ScalarType type;
        std::vector<std::size_t> chunk;
        double bpv;
    };
    for (const Case& c :
         {Case{ScalarType::Float32, {24, 24, 24}, 2.0}, Case{ScalarType::UInt16, {17, 9, 33}, 2.0},
          Case{ScalarType::Int16, {3, 16, 20, 24}, 1.0}}) {
        const auto p = params(c.type, c.chunk, ChunkRate::Bpv, c.bpv);
        const auto chunk = makeChunk(p, false);
        std::size_t stored = 0;
        roundTrip(p, chunk, &stored);
        const double voxels = double(p.frameDims().count() * p.frameCount());
        EXPECT_LE(double(stored) * 8, c.bpv * voxels) << scalarTypeName(c.type);
        EXPECT_GT(double(stored) * 8, 0.5 * c.bpv * voxels) << scalarTypeName(c.type); // the budget is used
    }
    // A budget smaller than the chunk header is refused, naming the reason.
    const auto tiny = params(ScalarType::UInt8, {4, 4, 4}, ChunkRate::Bpv, 1.0);
    try {
        hdf5::encodeChunk(test::computeContext(), tiny, makeChunk(tiny, false));
        ADD_FAILURE() << "a 64-bit budget for a 320-bit header was accepted";
    } catch (const UsageError& e) {
        EXPECT_NE(std::string(e.what()).find("40-byte header"), std::string::npos) << e.what();
    }
}

TEST(Hdf5ChunkCodec, LossyKeepsNanInfExactlyLosslessKeepsEveryBit) {
    const auto lossy = params(ScalarType::Float32, {8, 8, 8}, ChunkRate::MaxError, 0.1);
    // NaN and +/-Inf without the float extremes (those overflow the lossy transform, refused on their own).
    auto chunk = makeChunk(lossy, false);
    const float specials[] = {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
                              -std::numeric_limits<float>::infinity()};
    for (std::size_t i = 0; i < 3; ++i)
        std::memcpy(chunk.data() + (7 + 50 * i) * sizeof(float), &specials[i], sizeof(float));
    const auto back = roundTrip(lossy, chunk);
    ASSERT_EQ(back.size(), chunk.size());
    for (std::size_t i = 0; i < chunk.size() / sizeof(float); ++i) {
        float a, b;
        std::memcpy(&a, chunk.data() + i * sizeof(float), sizeof(float));
        std::memcpy(&b, back.data() + i * sizeof(float), sizeof(float));
        if (std::isfinite(a))
            EXPECT_LE(std::abs(double(b) - double(a)), 0.1) << i;
        else
            EXPECT_EQ(std::memcmp(&a, &b, sizeof(float)), 0) << i;
    }
    const auto lossless = params(ScalarType::Float32, {8, 8, 8});
    const auto all = makeChunk(lossless, true);
    EXPECT_EQ(roundTrip(lossless, all), all);
}

TEST(Hdf5ChunkCodec, WrongSizesAndOtherShapesAreRefused) {
    auto& cc = test::computeContext();
    const auto p = params(ScalarType::UInt16, {8, 8, 8});
    const auto chunk = makeChunk(p, false);
    EXPECT_THROW(hdf5::encodeChunk(cc, p, std::span(chunk).first(100)), DataError);
    const auto stored = hdf5::encodeChunk(cc, p, chunk);
    std::vector<std::byte> out(p.chunkBytes());
    for (auto other : {params(ScalarType::UInt16, {8, 8, 16}), params(ScalarType::Int16, {8, 8, 8}),
                       params(ScalarType::UInt16, {1, 8, 8, 8}),
                       params(ScalarType::UInt16, {8, 8, 8}, ChunkRate::Psnr, 40)}) {
        std::vector<std::byte> o(other.chunkBytes());
        EXPECT_THROW(hdf5::decodeChunk(cc, other, stored, o), Error);
    }
    std::vector<std::byte> small(10);
    EXPECT_THROW(hdf5::decodeChunk(cc, p, stored, small), DataError);
}

TEST(Hdf5ChunkCodec, CorruptedOrTruncatedChunksThrowNeverCrash) {
    auto& cc = test::computeContext();
    const auto p = params(ScalarType::Float32, {16, 16, 24});
    const auto chunk = makeChunk(p, true);
    const auto stored = hdf5::encodeChunk(cc, p, chunk);
    std::vector<std::byte> out(p.chunkBytes());
    // Every byte of the preamble (chunk header, .vcz header and index), then a spread over the payload.
    std::vector<std::size_t> positions;
    for (std::size_t i = 0; i < std::min<std::size_t>(stored.size(), 400); ++i)
        positions.push_back(i);
    for (std::size_t i = 400; i < stored.size(); i += std::max<std::size_t>(1, stored.size() / 97))
        positions.push_back(i);
    positions.push_back(stored.size() - 1);
    std::size_t undetected = 0;
    for (std::size_t i : positions) {
        auto bad = stored;
        bad[i] ^= std::byte(0x5a);
        try {
            hdf5::decodeChunk(cc, p, bad, out);
            // A flip the checksums do not cover may decode; the data must then still be the chunk's.
            EXPECT_EQ(out, chunk) << "byte " << i << " decoded to other data without an error";
            ++undetected;
        } catch (const Error&) {
        }
    }
    EXPECT_EQ(undetected, 0u) << "flips that decoded without an error";
    for (std::size_t n : {std::size_t(0), std::size_t(3), std::size_t(39), std::size_t(40), std::size_t(41),
                          stored.size() / 2, stored.size() - 1})
        EXPECT_THROW(hdf5::decodeChunk(cc, p, std::span(stored).first(n), out), Error)
            << "truncated to " << n;
    auto longer = stored;
    longer.resize(stored.size() + 16, std::byte(0x77));
    try {
        hdf5::decodeChunk(cc, p, longer, out);
        EXPECT_EQ(out, chunk);
    } catch (const Error&) {
    }
}

// --- through HDF5 (the plugin loaded from its build folder) ----------------------------------------------

// Makes HDF5 search the plugin's build folder first and keeps expected failures off stderr.
struct Hdf5Session {
    Hdf5Session() { H5PLprepend(VOLCL_HDF5_PLUGIN_DIR); }
};

// Descriptions on the current HDF5 error stack, joined (then cleared).
std::string errorStackText() {
    std::string text;
    H5Ewalk2(
        H5E_DEFAULT, H5E_WALK_DOWNWARD,
        [](unsigned, const H5E_error2_t* e, void* out) -> herr_t {
            if (e->desc) *static_cast<std::string*>(out) += std::string(e->desc) + "\n";
            return 0;
        },
        &text);
    H5Eclear2(H5E_DEFAULT);
    return text;
}

struct QuietErrors {
    H5E_auto2_t func = nullptr;
    void* data = nullptr;
    QuietErrors() {
        H5Eget_auto2(H5E_DEFAULT, &func, &data);
        H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
    }
    ~QuietErrors() { H5Eset_auto2(H5E_DEFAULT, func, data); }
};

hid_t fileTypeOf(ScalarType t) {
    switch (t) {
    case ScalarType::UInt8:
        return H5T_STD_U8LE;
    case ScalarType::UInt16:
        return H5T_STD_U16LE;
    case ScalarType::Int16:
        return H5T_STD_I16LE;
    case ScalarType::Float32:
        return H5T_IEEE_F32LE;
    case ScalarType::Float64:
        return H5T_IEEE_F64LE;
    }
    return -1;
}

// Creates dataset `name` of dims (slowest first), chunked, with the filter as `setFilter` adds it; returns
// the dataset id or a negative id on failure.
// On failure `errors` receives the HDF5 error stack (read before later calls clear it).
template <class SetFilter>
hid_t createDataset(hid_t file, const char* name, hid_t type, const std::vector<hsize_t>& dims,
                    const std::vector<hsize_t>& chunk, SetFilter setFilter, std::string* errors = nullptr) {
    const hid_t space = H5Screate_simple(int(dims.size()), dims.data(), nullptr);
    const hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
    H5Pset_chunk(dcpl, int(chunk.size()), chunk.data());
    hid_t d = setFilter(dcpl) < 0 ? -1 : H5Dcreate2(file, name, type, space, H5P_DEFAULT, dcpl, H5P_DEFAULT);
    if (d < 0 && errors) *errors = errorStackText();
    H5Pclose(dcpl);
    H5Sclose(space);
    return d;
}

TEST(Hdf5Filter, PluginIsFoundWithEncoderAndDecoder) {
    Hdf5Session s;
    ASSERT_GT(H5Zfilter_avail(H5Z_FILTER_VOLCL), 0) << "plugin not found in " << VOLCL_HDF5_PLUGIN_DIR;
    unsigned config = 0;
    ASSERT_GE(H5Zget_filter_info(H5Z_FILTER_VOLCL, &config), 0);
    EXPECT_TRUE(config & H5Z_FILTER_CONFIG_ENCODE_ENABLED);
    EXPECT_TRUE(config & H5Z_FILTER_CONFIG_DECODE_ENABLED);
}

TEST(Hdf5Filter, DatasetsOfEveryTypeReadBackExactWithPartialEdgeChunks) {
    Hdf5Session s;
    const auto dir = test::tempDir("hdf5-filter-types");
    const std::string path = (dir / "types.h5").string();
    const std::vector<hsize_t> dims{21, 40, 37}, chunk{8, 16, 16}; // partial chunks on every axis
    std::vector<std::vector<std::byte>> written;
    const ScalarType types[] = {ScalarType::UInt8, ScalarType::UInt16, ScalarType::Int16, ScalarType::Float32,
                                ScalarType::Float64};
    {
        const hid_t f = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
        ASSERT_GE(f, 0);
        for (ScalarType t : types) {
            const auto whole = params(t, {21, 40, 37});
            written.push_back(makeChunk(whole, true, unsigned(t) + 3));
            const hid_t d = createDataset(f, std::string(scalarTypeName(t)).c_str(), fileTypeOf(t), dims,
                                          chunk, [](hid_t dcpl) { return H5Pset_volcl_lossless(dcpl); });
            ASSERT_GE(d, 0) << scalarTypeName(t);
            ASSERT_GE(H5Dwrite(d, fileTypeOf(t), H5S_ALL, H5S_ALL, H5P_DEFAULT, written.back().data()), 0);
            H5Dclose(d);
        }
        H5Fclose(f);
    }
    const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    ASSERT_GE(f, 0);
    for (std::size_t i = 0; i < std::size(types); ++i) {
        const hid_t d = H5Dopen2(f, std::string(scalarTypeName(types[i])).c_str(), H5P_DEFAULT);
        std::vector<std::byte> back(written[i].size());
        ASSERT_GE(H5Dread(d, fileTypeOf(types[i]), H5S_ALL, H5S_ALL, H5P_DEFAULT, back.data()), 0);
        EXPECT_EQ(back, written[i]) << scalarTypeName(types[i]);
        // The stored cd_values carry type and chunk shape (set_local).
        const hid_t dcpl = H5Dget_create_plist(d);
        unsigned flags = 0, values[16];
        size_t count = 16;
        ASSERT_GE(H5Pget_filter_by_id2(dcpl, H5Z_FILTER_VOLCL, &flags, &count, values, 0, nullptr, nullptr),
                  0);
        EXPECT_EQ(count, 9u);
        EXPECT_EQ(values[0], 0u);
        EXPECT_EQ(values[5], 3u);
        EXPECT_EQ(values[6], 8u);
        EXPECT_EQ(values[8], 16u);
        H5Pclose(dcpl);
        H5Dclose(d);
    }
    H5Fclose(f);
}

TEST(Hdf5Filter, MaxErrorAndPsnrDatasetsAndFourDimensionalSeries) {
    Hdf5Session s;
    const auto dir = test::tempDir("hdf5-filter-lossy");
    const std::string path = (dir / "lossy.h5").string();
    const auto whole = params(ScalarType::Float32, {24, 48, 40});
    const auto data = makeChunk(whole, false);
    const auto series = params(ScalarType::UInt16, {5, 10, 12, 14});
    const auto seriesData = makeChunk(series, false, 9);
    hid_t f = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    ASSERT_GE(f, 0);
    hid_t me = createDataset(f, "max_error", H5T_IEEE_F32LE, {24, 48, 40}, {16, 16, 16},
                             [](hid_t dcpl) { return H5Pset_volcl_max_error(dcpl, 0.05); });
    hid_t ps = createDataset(f, "psnr", H5T_IEEE_F32LE, {24, 48, 40}, {24, 24, 24},
                             [](hid_t dcpl) { return H5Pset_volcl_psnr(dcpl, 40.0); });
    hid_t t4 = createDataset(f, "series", H5T_STD_U16LE, {5, 10, 12, 14}, {2, 10, 8, 8},
                             [](hid_t dcpl) { return H5Pset_volcl_lossless(dcpl); });
    ASSERT_GE(me, 0);
    ASSERT_GE(ps, 0);
    ASSERT_GE(t4, 0);
    ASSERT_GE(H5Dwrite(me, H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, data.data()), 0);
    ASSERT_GE(H5Dwrite(ps, H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, data.data()), 0);
    ASSERT_GE(H5Dwrite(t4, H5T_NATIVE_UINT16, H5S_ALL, H5S_ALL, H5P_DEFAULT, seriesData.data()), 0);
    // Reopen: reads from the same open file could come from HDF5's chunk cache, never decoded.
    EXPECT_LT(H5Dget_storage_size(me), data.size());
    H5Dclose(me);
    H5Dclose(ps);
    H5Dclose(t4);
    H5Fclose(f);
    f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    ASSERT_GE(f, 0);
    me = H5Dopen2(f, "max_error", H5P_DEFAULT);
    ps = H5Dopen2(f, "psnr", H5P_DEFAULT);
    t4 = H5Dopen2(f, "series", H5P_DEFAULT);
    std::vector<std::byte> back(data.size());
    ASSERT_GE(H5Dread(me, H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, back.data()), 0);
    EXPECT_LE(maxAbsDifference(whole, data, back), 0.05);
    EXPECT_GT(maxAbsDifference(whole, data, back), 0.0); // lossy, so decoded rather than cached
    ASSERT_GE(H5Dread(ps, H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, back.data()), 0);
    EXPECT_LT(maxAbsDifference(whole, data, back), 0.1 * 1000); // each chunk near 40 dB over a ~1000 range
    EXPECT_GT(maxAbsDifference(whole, data, back), 0.0);
    std::vector<std::byte> seriesBack(seriesData.size());
    ASSERT_GE(H5Dread(t4, H5T_NATIVE_UINT16, H5S_ALL, H5S_ALL, H5P_DEFAULT, seriesBack.data()), 0);
    EXPECT_EQ(seriesBack, seriesData);
    H5Dclose(me);
    H5Dclose(ps);
    H5Dclose(t4);
    H5Fclose(f);
}

TEST(Hdf5Filter, UnsupportedDatasetsAreRefusedWithAMessage) {
    Hdf5Session s;
    QuietErrors quiet;
    const auto dir = test::tempDir("hdf5-filter-refused");
    const hid_t f = H5Fcreate((dir / "refused.h5").string().c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    ASSERT_GE(f, 0);
    auto lossless = [](hid_t dcpl) { return H5Pset_volcl_lossless(dcpl); };
    struct Case {
        const char* name;
        hid_t type;
        std::vector<hsize_t> dims, chunk;
        const char* message;
    };
    const Case cases[] = {
        {"i32", H5T_STD_I32LE, {8, 8, 8}, {8, 8, 8}, "element type"},
        {"u16be", H5T_STD_U16BE, {8, 8, 8}, {8, 8, 8}, "big-endian"},
        {"plane", H5T_STD_U8LE, {8, 8}, {8, 8}, "3 (z, y, x) or 4"},
        {"line", H5T_STD_U8LE, {64}, {16}, "3 (z, y, x) or 4"},
        {"five", H5T_STD_U8LE, {2, 2, 2, 2, 2}, {2, 2, 2, 2, 2}, "3 (z, y, x) or 4"},
    };
    for (const Case& c : cases) {
        std::string errors;
        const hid_t d = createDataset(f, c.name, c.type, c.dims, c.chunk, lossless, &errors);
        EXPECT_LT(d, 0) << c.name;
        EXPECT_NE(errors.find(c.message), std::string::npos) << c.name << ": " << errors;
        if (d >= 0) H5Dclose(d);
    }
    // A rate that does not exist, and max-error without its bound.
    std::string errors;
    const hid_t bad = createDataset(
        f, "rate7", H5T_STD_U8LE, {8, 8, 8}, {8, 8, 8},
        [](hid_t dcpl) {
            const unsigned cd[] = {7};
            return H5Pset_filter(dcpl, H5Z_FILTER_VOLCL, H5Z_FLAG_MANDATORY, 1, cd);
        },
        &errors);
    EXPECT_LT(bad, 0);
    EXPECT_NE(errors.find("is not a rate"), std::string::npos) << errors;
    const hid_t nobound = createDataset(
        f, "nobound", H5T_STD_U8LE, {8, 8, 8}, {8, 8, 8},
        [](hid_t dcpl) {
            const unsigned cd[] = {1};
            return H5Pset_filter(dcpl, H5Z_FILTER_VOLCL, H5Z_FLAG_MANDATORY, 1, cd);
        },
        &errors);
    EXPECT_LT(nobound, 0);
    EXPECT_NE(errors.find("need the bound"), std::string::npos) << errors;
    // NaN in a lossy float dataset is kept exactly (the finite voxels within the bound).
    const hid_t lossy = createDataset(f, "nan", H5T_IEEE_F32LE, {8, 8, 8}, {8, 8, 8},
                                      [](hid_t dcpl) { return H5Pset_volcl_max_error(dcpl, 0.1); });
    ASSERT_GE(lossy, 0);
    std::vector<float> nan(512, 1.0f);
    nan[17] = std::numeric_limits<float>::quiet_NaN();
    EXPECT_GE(H5Dwrite(lossy, H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, nan.data()), 0);
    std::vector<float> nanBack(512, 0.0f);
    EXPECT_GE(H5Dread(lossy, H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, nanBack.data()), 0);
    EXPECT_TRUE(std::isnan(nanBack[17]));
    EXPECT_NEAR(nanBack[16], 1.0f, 0.1f);
    EXPECT_GE(H5Dclose(lossy), 0);
    H5Fclose(f);
}

TEST(Hdf5Filter, CorruptedChunkIsAnHdf5ErrorAndOtherChunksStillRead) {
    Hdf5Session s;
    const auto dir = test::tempDir("hdf5-filter-corrupt");
    const std::string path = (dir / "corrupt.h5").string();
    const auto whole = params(ScalarType::UInt16, {16, 16, 32});
    const auto data = makeChunk(whole, false);
    {
        const hid_t f = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
        const hid_t d = createDataset(f, "data", H5T_STD_U16LE, {16, 16, 32}, {16, 16, 16},
                                      [](hid_t dcpl) { return H5Pset_volcl_lossless(dcpl); });
        ASSERT_GE(d, 0);
        ASSERT_GE(H5Dwrite(d, H5T_NATIVE_UINT16, H5S_ALL, H5S_ALL, H5P_DEFAULT, data.data()), 0);
        // Chunk (0, 0, 16) replaced with its own bytes, one flipped in the middle (stored through the
        // direct chunk API, which bypasses the filter).
        const hsize_t offset[] = {0, 0, 16};
        hsize_t size = 0;
        ASSERT_GE(H5Dget_chunk_storage_size(d, offset, &size), 0);
        std::vector<unsigned char> raw(size);
        uint32_t filterMask = 0;
        ASSERT_GE(H5Dread_chunk(d, H5P_DEFAULT, offset, &filterMask, raw.data()), 0);
        raw[raw.size() / 2] ^= 0x40;
        ASSERT_GE(H5Dwrite_chunk(d, H5P_DEFAULT, 0, offset, raw.size(), raw.data()), 0);
        H5Dclose(d);
        H5Fclose(f);
    }
    const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    const hid_t d = H5Dopen2(f, "data", H5P_DEFAULT);
    ASSERT_GE(d, 0);
    std::vector<std::uint16_t> back(16 * 16 * 32);
    {
        QuietErrors quiet;
        EXPECT_LT(H5Dread(d, H5T_NATIVE_UINT16, H5S_ALL, H5S_ALL, H5P_DEFAULT, back.data()), 0);
        EXPECT_NE(errorStackText().find("volcl"), std::string::npos);
    }
    // The intact chunk (x in [0, 16)) reads exactly.
    const hid_t fs = H5Dget_space(d);
    const hsize_t start[] = {0, 0, 0}, count[] = {16, 16, 16};
    H5Sselect_hyperslab(fs, H5S_SELECT_SET, start, nullptr, count, nullptr);
    const hid_t ms = H5Screate_simple(3, count, nullptr);
    std::vector<std::uint16_t> part(16 * 16 * 16);
    ASSERT_GE(H5Dread(d, H5T_NATIVE_UINT16, ms, fs, H5P_DEFAULT, part.data()), 0);
    const auto* src = reinterpret_cast<const std::uint16_t*>(data.data());
    std::size_t mismatches = 0;
    for (std::size_t z = 0; z < 16; ++z)
        for (std::size_t y = 0; y < 16; ++y)
            for (std::size_t x = 0; x < 16; ++x)
                mismatches += part[(z * 16 + y) * 16 + x] != src[(z * 16 + y) * 32 + x];
    EXPECT_EQ(mismatches, 0u);
    H5Sclose(ms);
    H5Sclose(fs);
    H5Dclose(d);
    H5Fclose(f);
}

} // namespace
