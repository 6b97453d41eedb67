// Decoding ahead (DecodeAhead): bricks entropy decoded on a thread before the decode give the same voxels as
// a decode without it, whatever part of the rounds it filled; a decode it does not match ignores it; a
// corrupt brick is still reported by the decoder.
#include "core/Error.hpp"
#include "tests/TestUtil.hpp"
#include "wavelet/Codec.hpp"
#include "wavelet/DecodeAhead.hpp"
#include "wavelet/FrameDecoder.hpp"
#include "wavelet/transform/BrickTransform.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

using namespace volcl;

namespace {

// A smooth field with noise, a zero slab (uniform bricks, filled rather than decoded) and a saturated one.
Volume makeVolume(Dims d, ScalarType type, unsigned seed) {
    Volume f(d, ScalarType::Float32);
    std::mt19937 rng(seed);
    std::normal_distribution<float> noise(0.f, 3.f);
    auto v = f.values<float>();
    for (std::size_t z = 0; z < d.z; ++z)
        for (std::size_t y = 0; y < d.y; ++y)
            for (std::size_t x = 0; x < d.x; ++x) {
                float s =
                    120.f + 80.f * std::sin(0.11f * float(x)) * std::cos(0.07f * float(y + z)) + noise(rng);
                if (z < 64) s = 0.f;
                if (x >= d.x - 5) s = 1e5f;
                v[f.index(x, y, z)] = s;
            }
    return f.convertedTo(type);
}

CodecOptions options(RateMode rate, double target, Dims brick) {
    CodecOptions o;
    o.rate = rate;
    o.target = target;
    o.brick = brick;
    o.levels = 3;
    return o;
}

// Bytes of the first round DecodeAhead fills (the bricks that are decoded, batched as the decoder does).
std::size_t roundBytes(const VczReader& reader) {
    const VczHeader& h = reader.header();
    std::size_t bytes = 0;
    const auto rounds =
        codec::batchRounds<std::int32_t>(h, codec::varyingBricks(reader.bytes(), h, 0, codec::allBricks(h)));
    for (const codec::BrickGroup& g : rounds.front())
        bytes += BrickBatch<std::int32_t>::bytesFor(g.dims, g.bricks.size());
    return bytes;
}

} // namespace

// Lossless integers over several transform rounds (64^3 bricks: 8 MB rounds of 8 bricks), lossy floats with
// exactly stored voxels (max-error corrections), each decoded ahead not at all, one round, everything, and
// stopped wherever the thread was when the decode took over.
TEST(DecodeAhead, SameVoxelsWhateverPartWasDecodedAhead) {
    ComputeContext& cc = test::computeContext();
    struct Case {
        ScalarType type;
        CodecOptions o;
    };
    const std::vector<Case> cases = {
        {ScalarType::UInt8, options(RateMode::Lossless, 0, {64, 64, 64})},
        {ScalarType::Int16, options(RateMode::Lossless, 0, {32, 64, 48})},
        {ScalarType::Float32, options(RateMode::MaxError, 0.5, {64, 64, 64})},
    };
    for (const Case& c : cases) {
        const Volume v = makeVolume({200, 192, 130}, c.type, 3);
        const auto bytes = encodeVolume(cc, v, c.o);
        VczReader reader(bytes, "ahead.vcz");
        const Volume expected = reader.decode(cc);
        if (c.o.rate == RateMode::Lossless) ASSERT_TRUE(expected == v) << scalarTypeName(c.type);
        const std::size_t varying =
            codec::varyingBricks(reader.bytes(), reader.header(), 0, codec::allBricks(reader.header()))
                .size();
        if (c.o.rate == RateMode::Lossless)
            ASSERT_LT(varying, reader.header().brickCount()) << "the zero slab gives uniform bricks";
        const std::size_t rounds =
            codec::batchRounds<std::int32_t>(
                reader.header(),
                codec::varyingBricks(reader.bytes(), reader.header(), 0, codec::allBricks(reader.header())))
                .size();
        ASSERT_GE(rounds, 2u) << scalarTypeName(c.type);
        for (const std::size_t maxBytes : {std::size_t(0), roundBytes(reader), DecodeAhead::kMaxBytes * 4}) {
            for (const bool waitFirst : {true, false}) {
                DecodeAhead ahead(reader, 0, cc.hostMemory(), maxBytes);
                if (waitFirst) ahead.wait();
                DecodeOptions o;
                o.ahead = &ahead;
                const Volume got = reader.decode(cc, o);
                EXPECT_TRUE(got == expected) << scalarTypeName(c.type) << " maxBytes " << maxBytes << " wait "
                                             << waitFirst << " ahead " << ahead.bricksDecoded();
                if (waitFirst && maxBytes == 0) EXPECT_EQ(ahead.bricksDecoded(), 0u);
                if (waitFirst && maxBytes > DecodeAhead::kMaxBytes) EXPECT_EQ(ahead.bricksDecoded(), varying);
                if (waitFirst && maxBytes == roundBytes(reader)) {
                    EXPECT_GT(ahead.bricksDecoded(), 0u);
                    EXPECT_LT(ahead.bricksDecoded(), varying);
                }
            }
        }
    }
}

// A decode of a region or a level, of another reader's file, or of a frame it was not made for does not use
// what was decoded ahead and gets the right voxels; the whole-frame decode after them still may, once.
TEST(DecodeAhead, UnmatchedDecodesIgnoreIt) {
    ComputeContext& cc = test::computeContext();
    const Volume v = makeVolume({70, 60, 100}, ScalarType::UInt16, 5);
    const auto bytes = encodeVolume(cc, v, options(RateMode::Lossless, 0, {32, 32, 32}));
    VczReader reader(bytes, "ahead.vcz");
    {
        DecodeAhead ahead(reader, 0, cc.hostMemory());
        ahead.wait();
        ASSERT_GT(ahead.bricksDecoded(), 0u);
        DecodeOptions region;
        region.ahead = &ahead;
        region.region = Region{{3, 4, 5}, {61, 50, 44}};
        EXPECT_TRUE(reader.decode(cc, region) == v.cropped({3, 4, 5}, {61, 50, 44}));
        DecodeOptions level;
        level.ahead = &ahead;
        level.level = 1;
        EXPECT_EQ(reader.decode(cc, level).dims(), (Dims{35, 30, 50}));
        DecodeOptions whole;
        whole.ahead = &ahead; // matches: takes it over (the region decode stopped the thread but left it)
        EXPECT_TRUE(reader.decode(cc, whole) == v);
        EXPECT_TRUE(reader.decode(cc, whole) == v);
    }
    {
        // Another reader over equal bytes is another file.
        VczReader other(bytes, "other.vcz");
        DecodeAhead ahead(other, 0, cc.hostMemory());
        DecodeOptions o;
        o.ahead = &ahead;
        EXPECT_TRUE(reader.decode(cc, o) == v);
    }
    {
        DecodeAhead ahead(reader, 7, cc.hostMemory()); // no such frame: nothing decoded
        ahead.wait();
        EXPECT_EQ(ahead.bricksDecoded(), 0u);
        DecodeOptions o;
        o.ahead = &ahead;
        EXPECT_TRUE(reader.decode(cc, o) == v);
    }
}

// A damaged brick stops the thread there; the decoder decodes it again and reports it, naming the brick.
TEST(DecodeAhead, CorruptBrickIsReportedByTheDecoder) {
    ComputeContext& cc = test::computeContext();
    const Volume v = makeVolume({96, 64, 128}, ScalarType::UInt8, 9);
    auto bytes = encodeVolume(cc, v, options(RateMode::Lossless, 0, {32, 32, 32}));
    VczReader good(bytes, "good.vcz");
    const std::vector<std::size_t> varying =
        codec::varyingBricks(good.bytes(), good.header(), 0, codec::allBricks(good.header()));
    ASSERT_GE(varying.size(), 4u);
    const std::size_t victim = varying[varying.size() / 2];
    const VczBrickEntry& e = good.header().bricks[0][victim];
    bytes[e.offset + e.size / 2] ^= std::byte{0x10};
    VczReader bad(bytes, "bad.vcz");
    std::string without, with;
    try {
        bad.decode(cc);
    } catch (const IoError& err) {
        without = err.what();
    }
    DecodeAhead ahead(bad, 0, cc.hostMemory());
    ahead.wait();
    EXPECT_LT(ahead.bricksDecoded(), varying.size());
    try {
        DecodeOptions o;
        o.ahead = &ahead;
        bad.decode(cc, o);
    } catch (const IoError& err) {
        with = err.what();
    }
    EXPECT_FALSE(without.empty());
    EXPECT_EQ(with, without);
    EXPECT_NE(with.find("brick " + std::to_string(victim)), std::string::npos) << with;
}
