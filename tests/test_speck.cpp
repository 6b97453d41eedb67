// Set-partitioning (SPECK-style) section coder: bit-exact round trips against the dense coder's integers on
// every section shape (random, sparse, all-zero, one coefficient, extreme magnitudes, partial edge bricks),
// the per-section choice never larger than the dense coding, damaged sections (IoError or a clean decode,
// never a crash; every truncation refused), payload flags, and the codec end to end: files with and without
// set partitioning decode to the same voxels (full, level, region), within the bound computed in double; and
// the transform extent chosen by coded size (64- or 128-voxel bricks).
#include "core/Error.hpp"
#include "tests/CodecTestOptions.hpp"
#include "tests/TestUtil.hpp"
#include "wavelet/Codec.hpp"
#include "wavelet/container/VczFormat.hpp"
#include "wavelet/entropy/EntropyCoder.hpp"
#include "wavelet/entropy/SpeckModel.hpp"
#include "wavelet/entropy/TestSwitches.hpp"
#include "wavelet/payload/BrickPayload.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <string>
#include <vector>

using namespace volcl;

namespace {

constexpr std::int32_t kMaxMagnitude = (1 << 30) - 1;

// Every section shape: tiny, odd, flat and partial edge bricks, with 0 to 4 levels.
const Dims kShapes[] = {{1, 1, 1},   {1, 7, 1},  {2, 3, 5},    {5, 1, 3},   {16, 16, 16},
                        {17, 9, 33}, {31, 2, 1}, {64, 40, 24}, {64, 64, 7}, {3, 64, 64}};

// Coefficients with `density` of them non-zero, magnitudes up to `maxMagnitude` (log-uniform), random signs.
std::vector<std::int32_t> sparse(Dims d, double density, std::int32_t maxMagnitude, std::uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::vector<std::int32_t> c(d.count(), 0);
    for (auto& v : c) {
        if (u(rng) >= density) continue;
        const auto m = static_cast<std::int32_t>(
            std::min(double(maxMagnitude), std::exp(u(rng) * std::log(double(maxMagnitude) + 1.0))));
        v = (rng() & 1) ? -std::max(m, 1) : std::max(m, 1);
    }
    return c;
}

// Codes every section by set partitioning and decodes it back into a poisoned array; the integers must be
// the input's, which the dense coder also reproduces (its own tests), so both coders give the same ones.
void expectSpeckRoundTrip(const std::vector<std::int32_t>& c, Dims d, int levels, const std::string& what) {
    const auto layout = sectionLayout(d, levels);
    std::vector<std::int32_t> out(d.count(), 0x5A5A5A5A);
    for (std::size_t s = 0; s < layout.size(); ++s) {
        if (layout[s].empty()) continue;
        std::vector<std::uint8_t> bytes;
        entropy::encodeSpeck(c, d, layout[s], bytes);
        decodeSection(bytes, out, d, layout, s, EntropyMode::Dense, "test", true);
    }
    ASSERT_EQ(out, c) << what;
    // The dense coder's integers: the same.
    std::vector<std::int32_t> dense(d.count(), 0x5A5A5A5A);
    for (std::size_t s = 0; s < layout.size(); ++s) {
        std::vector<std::uint8_t> bytes;
        encodeSection(c, d, layout, s, EntropyMode::Dense, bytes);
        decodeSection(bytes, dense, d, layout, s, EntropyMode::Dense, "test");
    }
    EXPECT_EQ(out, dense) << what;
}

} // namespace

TEST(Speck, RoundTripsEveryShapeAndDensity) {
    std::uint32_t seed = 1;
    for (const Dims& d : kShapes)
        for (int levels = 0; levels <= 4; ++levels)
            for (double density : {0.0, 0.001, 0.02, 0.3, 1.0})
                for (std::int32_t top : {1, 7, 1000, kMaxMagnitude})
                    expectSpeckRoundTrip(sparse(d, density, top, seed++), d, levels,
                                         std::to_string(d.x) + "x" + std::to_string(d.y) + "x" +
                                             std::to_string(d.z) + " levels " + std::to_string(levels) +
                                             " density " + std::to_string(density) + " max " +
                                             std::to_string(top));
}

TEST(Speck, RoundTripsOneCoefficientAnywhere) {
    const Dims d{17, 9, 33};
    for (int levels : {0, 2, 3})
        for (std::size_t i = 0; i < d.count(); i += 97)
            for (std::int32_t v : {1, -1, -kMaxMagnitude, kMaxMagnitude, 12345}) {
                std::vector<std::int32_t> c(d.count(), 0);
                c[i] = v;
                expectSpeckRoundTrip(c, d, levels,
                                     "index " + std::to_string(i) + " value " + std::to_string(v));
            }
}

TEST(Speck, AllZeroSectionIsOneByte) {
    const Dims d{16, 16, 16};
    const auto layout = sectionLayout(d, 3);
    const std::vector<std::int32_t> c(d.count(), 0);
    std::vector<std::uint8_t> bytes;
    entropy::encodeSpeck(c, d, layout[3], bytes);
    EXPECT_EQ(bytes, std::vector<std::uint8_t>{0});
}

TEST(Speck, RefusesOutOfRangeMagnitudes) {
    const Dims d{4, 4, 4};
    const auto layout = sectionLayout(d, 1);
    for (std::int32_t bad : {1 << 30, -(1 << 30), INT32_MIN}) {
        std::vector<std::int32_t> c(d.count(), 0);
        c[5] = bad;
        std::vector<std::uint8_t> out;
        EXPECT_THROW(entropy::encodeSpeck(c, d, layout[0], out), Error);
    }
}

TEST(Speck, ChoiceNeverLargerThanDenseAndWinsWhenSparse) {
    const Dims d{64, 64, 64};
    const auto layout = sectionLayout(d, 4);
    std::size_t speckChosen = 0;
    std::uint32_t seed = 7;
    for (double density : {0.0005, 0.003, 0.05, 0.5}) {
        const auto c = sparse(d, density, 50, seed++);
        std::vector<std::int32_t> out(d.count(), 0x5A5A5A5A);
        for (std::size_t s = 0; s < layout.size(); ++s) {
            std::vector<std::uint8_t> dense, best;
            encodeSection(c, d, layout, s, EntropyMode::Dense, dense);
            const bool speck = encodeSectionSmallest(c, d, layout, s, EntropyMode::Dense, best);
            EXPECT_LE(best.size(), dense.size()) << density << " section " << s;
            speckChosen += speck;
            decodeSection(best, out, d, layout, s, EntropyMode::Dense, "test", speck);
        }
        EXPECT_EQ(out, c) << density;
    }
    // Isolated coefficients in large sections are where set partitioning must win.
    EXPECT_GT(speckChosen, 0u);
    // Fast mode never uses it.
    const auto c = sparse(d, 0.001, 50, 99);
    std::vector<std::uint8_t> fast;
    EXPECT_FALSE(encodeSectionSmallest(c, d, layout, 4, EntropyMode::Fast, fast));
}

TEST(Speck, DamagedSectionsAreRejectedWithoutCrashing) {
    const Dims d{17, 9, 33};
    const auto layout = sectionLayout(d, 2);
    const auto c = sparse(d, 0.05, 300, 3);
    std::mt19937 rng(11);
    for (std::size_t s = 0; s < layout.size(); ++s) {
        std::vector<std::uint8_t> bytes;
        entropy::encodeSpeck(c, d, layout[s], bytes);
        std::vector<std::int32_t> out(d.count(), 0);
        // Every truncation is refused.
        for (std::size_t n = 0; n < bytes.size(); ++n)
            EXPECT_THROW(
                decodeSection(std::span(bytes).first(n), out, d, layout, s, EntropyMode::Dense, "t", true),
                IoError)
                << "section " << s << " cut to " << n;
        // Appended bytes are refused.
        auto longer = bytes;
        longer.push_back(0);
        EXPECT_THROW(decodeSection(longer, out, d, layout, s, EntropyMode::Dense, "t", true), IoError);
        // Flipped bits and random bytes: IoError or a clean decode, magnitudes always in range.
        for (int k = 0; k < 300; ++k) {
            auto bad = bytes;
            if (k < 200) {
                bad[rng() % bad.size()] ^= static_cast<std::uint8_t>(1u << (rng() % 8));
            } else {
                bad.resize(1 + rng() % 64);
                for (auto& b : bad)
                    b = static_cast<std::uint8_t>(rng());
            }
            try {
                decodeSection(bad, out, d, layout, s, EntropyMode::Dense, "t", true);
                for (std::int32_t v : out)
                    ASSERT_LE(std::abs(v), kMaxMagnitude);
            } catch (const IoError&) {
            }
        }
    }
    // A set-partitioned section in a fast-mode file is refused.
    std::vector<std::uint8_t> bytes;
    entropy::encodeSpeck(c, d, layout[1], bytes);
    std::vector<std::int32_t> out(d.count(), 0);
    EXPECT_THROW(decodeSection(bytes, out, d, layout, 1, EntropyMode::Fast, "t", true), IoError);
}

TEST(Speck, PayloadFlagsParseAndRefuseInconsistentMasks) {
    VczHeader h;
    h.transform = TransformKind::FloatLifting;
    h.levels = 3;
    h.entropy = EntropyMode::Dense;
    const Dims d{32, 32, 32};
    std::vector<std::int32_t> q(d.count(), 0);
    q[5 + 32 * (7 + 32 * 20)] = 3; // one coefficient in the finest section: set partitioning wins there
    q[0] = 100;
    const auto p = codec::buildPayload(h, d, q, {});
    ASSERT_GE(p.size(), 3u);
    EXPECT_EQ(p[1] & 2, 2) << "no section was set-partitioned";
    const auto parsed = codec::parsePayload(p, 4, "t");
    EXPECT_NE(parsed.setPartitioned, 0u);
    const auto layout = sectionLayout(d, 3);
    std::vector<std::int32_t> out(d.count(), 0x5A5A5A5A);
    decodeSections(parsed.sections, out, d, layout, EntropyMode::Dense, "t", nullptr, parsed.setPartitioned);
    EXPECT_EQ(out, q);
    // A mask naming a missing section, or an empty mask with the flag set, is refused.
    auto bad = p;
    bad[2] = 0x10;
    EXPECT_THROW(codec::parsePayload(bad, 4, "t"), IoError);
    bad[2] = 0;
    EXPECT_THROW(codec::parsePayload(bad, 4, "t"), IoError);
    // Without set partitioning the payload is the dense coder's, flag clear.
    setSetPartitioningEnabled(false);
    const auto dense = codec::buildPayload(h, d, q, {});
    setSetPartitioningEnabled(true);
    EXPECT_EQ(dense[1], 0);
    EXPECT_LT(p.size(), dense.size());
}

namespace {

// A smooth volume (two Gaussian blobs on a ramp) that is small against its bricks: low rates, sparse detail.
Volume smoothVolume(Dims d) {
    Volume v(d, ScalarType::Float32);
    auto* f = v.values<float>().data();
    for (std::size_t z = 0; z < d.z; ++z)
        for (std::size_t y = 0; y < d.y; ++y)
            for (std::size_t x = 0; x < d.x; ++x) {
                auto g = [&](double cx, double cy, double cz, double r) {
                    const double dx = double(x) - cx, dy = double(y) - cy, dz = double(z) - cz;
                    return std::exp(-(dx * dx + dy * dy + dz * dz) / (2 * r * r));
                };
                f[x + d.x * (y + d.y * z)] =
                    static_cast<float>(100 * g(12, 20, 9, 5) - 60 * g(30, 10, 25, 7) + 0.2 * double(x));
            }
    return v;
}

std::size_t setPartitionedBricks(const std::vector<std::byte>& file) {
    const VczHeader h = readVczHeader(file, "t");
    std::size_t n = 0;
    for (std::size_t b = 0; b < h.brickCount(); ++b) {
        const auto p = vczBrickPayload(file, h, 0, b, "t");
        if (p.size() >= 2 && p[0] != 0 && (p[1] & 2)) ++n;
    }
    return n;
}

} // namespace

TEST(Speck, CodecFilesDecodeLikeDenseOnlyFilesWithinTheBound) {
    const Dims d{41, 35, 30}; // partial edge bricks with 16-voxel bricks
    const Volume v = smoothVolume(d);
    auto& ctx = test::computeContext();
    for (const auto& [rate, target] :
         {std::pair{RateMode::MaxError, 0.5}, std::pair{RateMode::MaxError, 0.02},
          std::pair{RateMode::Psnr, 40.0}, std::pair{RateMode::Psnr, 60.0}}) {
        const std::string what = "mode " + std::to_string(int(rate)) + " " + std::to_string(target);
        CodecOptions o = test::smallBrickOptions(rate, target);
        const auto withSpeck = encodeVolume(ctx, v, o);
        setSetPartitioningEnabled(false);
        const auto denseOnly = encodeVolume(ctx, v, o);
        setSetPartitioningEnabled(true);
        EXPECT_LE(withSpeck.size(), denseOnly.size()) << what;
        EXPECT_EQ(setPartitionedBricks(denseOnly), 0u) << what;
        if (rate == RateMode::MaxError && target == 0.5)
            EXPECT_GT(setPartitionedBricks(withSpeck), 0u) << what << ": set partitioning never chosen";
        // The same integers: the same voxels at every level and in a region.
        for (int level : {0, 1, 2}) {
            DecodeOptions lo;
            lo.level = level;
            const Volume a = decodeVolume(ctx, withSpeck, lo);
            const Volume b = decodeVolume(ctx, denseOnly, lo);
            ASSERT_EQ(a.bytes().size(), b.bytes().size()) << what;
            EXPECT_EQ(0, std::memcmp(a.bytes().data(), b.bytes().data(), a.bytes().size())) << what << level;
        }
        DecodeOptions ro;
        ro.region = Region{{3, 17, 5}, {38, 33, 22}};
        const Volume ra = decodeVolume(ctx, withSpeck, ro);
        const Volume rb = decodeVolume(ctx, denseOnly, ro);
        EXPECT_EQ(0, std::memcmp(ra.bytes().data(), rb.bytes().data(), ra.bytes().size())) << what;
        // The oracle: the decoded volume against the original in double.
        const Volume out = decodeVolume(ctx, withSpeck);
        const float* a = v.values<float>().data();
        const float* b = out.values<float>().data();
        double maxErr = 0, se = 0, lo = a[0], hi = a[0];
        for (std::size_t i = 0; i < v.voxelCount(); ++i) {
            const double e = double(a[i]) - double(b[i]);
            maxErr = std::max(maxErr, std::abs(e));
            se += e * e;
            lo = std::min(lo, double(a[i]));
            hi = std::max(hi, double(a[i]));
        }
        if (rate == RateMode::MaxError) EXPECT_LE(maxErr, target) << what;
        if (rate == RateMode::Psnr)
            EXPECT_GE(20 * std::log10((hi - lo) / std::sqrt(se / double(v.voxelCount()))), target - 1e-9)
                << what;
    }
}

TEST(TransformExtent, DefaultOptionsKeepTheSmallerOfTwoBrickSizes) {
    // Wider than one default brick: the encoder also tries 128-voxel bricks and keeps the smaller file.
    const Dims d{150, 70, 20};
    const Volume v = smoothVolume(d);
    auto& ctx = test::computeContext();
    for (double target : {40.0, 60.0}) {
        CodecOptions o;
        o.rate = RateMode::Psnr;
        o.target = target;
        const auto chosen = encodeVolume(ctx, v, o);
        o.chooseExtent = false;
        const auto small = encodeVolume(ctx, v, o);
        o.brick = {128, 128, 128};
        const auto large = encodeVolume(ctx, v, o);
        EXPECT_EQ(chosen.size(), std::min(small.size(), large.size())) << target;
        const VczHeader h = readVczHeader(chosen, "t");
        EXPECT_EQ(h.brick.x, small.size() <= large.size() ? 64u : 128u) << target;
        // Level and region decodes of the chosen file equal the matching parts of its full decode.
        const Volume full = decodeVolume(ctx, chosen);
        DecodeOptions ro;
        ro.region = Region{{60, 10, 3}, {140, 65, 19}};
        const Volume part = decodeVolume(ctx, chosen, ro);
        for (std::size_t z = 3; z < 19; ++z)
            for (std::size_t y = 10; y < 65; ++y)
                for (std::size_t x = 60; x < 140; x += 7)
                    ASSERT_EQ(part.values<float>()[part.index(x - 60, y - 10, z - 3)],
                              full.values<float>()[full.index(x, y, z)]);
        DecodeOptions lo;
        lo.level = 2;
        EXPECT_EQ(decodeVolume(ctx, chosen, lo).dims(), (Dims{38, 18, 5}));
        // The PSNR in double.
        double se = 0, lo2 = 1e300, hi = -1e300;
        for (std::size_t i = 0; i < v.voxelCount(); ++i) {
            const double a = v.values<float>()[i], e = a - double(full.values<float>()[i]);
            se += e * e;
            lo2 = std::min(lo2, a);
            hi = std::max(hi, a);
        }
        EXPECT_GE(20 * std::log10((hi - lo2) / std::sqrt(se / double(v.voxelCount()))), target - 1e-9);
    }
    // An explicit brick is kept as given.
    CodecOptions o;
    o.rate = RateMode::Psnr;
    o.target = 40;
    o.chooseExtent = false;
    EXPECT_EQ(readVczHeader(encodeVolume(ctx, v, o), "t").brick.x, 64u);
}
