// Never larger than lossless, and piecewise-constant volumes: bricks coded as voxels (palette or raw) chosen
// per brick by size, and the lossless file taken when a lossy target would be larger. Every check decodes
// the file and compares voxels in double with the input.
#include "core/Error.hpp"
#include "tests/CodecTestOptions.hpp"
#include "tests/TestUtil.hpp"
#include "wavelet/Codec.hpp"
#include "wavelet/payload/VoxelBrick.hpp"
#include "wavelet/transform/LiftingTransform.hpp"

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

constexpr Dims kDims{40, 36, 20}; // bricks of 16: a 3 x 3 x 2 grid with partial edge bricks

template <class T, class F> Volume makeVolume(ScalarType type, F f, Dims dims = kDims) {
    Volume v(dims, type);
    auto s = v.values<T>();
    std::mt19937 rng(11);
    for (std::size_t z = 0; z < dims.z; ++z)
        for (std::size_t y = 0; y < dims.y; ++y)
            for (std::size_t x = 0; x < dims.x; ++x)
                s[v.index(x, y, z)] = static_cast<T>(f(x, y, z, rng));
    return v;
}

// Label volume: `labels` regions as nested boxes and slabs, piecewise constant.
template <class T> Volume labelVolume(ScalarType type, int labels, Dims dims = kDims) {
    return makeVolume<T>(
        type,
        [&](std::size_t x, std::size_t y, std::size_t z, auto&) {
            return double((x / 5 + 7 * (y / 6) + 31 * (z / 4)) % std::size_t(labels));
        },
        dims);
}

std::uint32_t versionOf(const std::vector<std::byte>& file) {
    std::uint32_t v;
    std::memcpy(&v, file.data() + 8, 4);
    return v;
}

double voxel(const Volume& v, std::size_t i) {
    switch (v.type()) {
    case ScalarType::UInt8:
        return v.values<std::uint8_t>()[i];
    case ScalarType::UInt16:
        return v.values<std::uint16_t>()[i];
    case ScalarType::Int16:
        return v.values<std::int16_t>()[i];
    case ScalarType::Float32:
        break;
    }
    return v.values<float>()[i];
}

double maxError(const Volume& a, const Volume& b) {
    EXPECT_EQ(a.voxelCount(), b.voxelCount());
    double m = 0;
    for (std::size_t i = 0; i < a.voxelCount(); ++i)
        m = std::max(m, std::abs(voxel(a, i) - voxel(b, i)));
    return m;
}

double psnrInDouble(const Volume& a, const Volume& b) {
    double lo = voxel(a, 0), hi = lo, se = 0;
    for (std::size_t i = 0; i < a.voxelCount(); ++i) {
        lo = std::min(lo, voxel(a, i));
        hi = std::max(hi, voxel(a, i));
        const double d = voxel(a, i) - voxel(b, i);
        se += d * d;
    }
    if (se == 0) return INFINITY;
    return 20 * std::log10((hi - lo) / std::sqrt(se / double(a.voxelCount())));
}

std::vector<std::byte> encode(const Volume& v, CodecOptions o) {
    return encodeVolume(test::computeContext(), v, o);
}

Volume decode(const std::vector<std::byte>& f, DecodeOptions o = {}) {
    return decodeVolume(test::computeContext(), f, o);
}

void expectExact(const Volume& v, const std::vector<std::byte>& f, const std::string& what) {
    const Volume d = decode(f);
    ASSERT_EQ(d.type(), v.type()) << what;
    EXPECT_EQ(0, std::memcmp(d.bytes().data(), v.bytes().data(), v.bytes().size())) << what;
}

// Every rate mode on one volume: the file is never larger than lossless and its target holds.
void checkEveryMode(const Volume& v, const std::string& name) {
    const auto lossless = encode(v, test::smallBrickOptions(RateMode::Lossless, 0));
    expectExact(v, lossless, name + " lossless");
    struct Mode {
        RateMode rate;
        double target;
    };
    for (const Mode m : {Mode{RateMode::Psnr, 40}, Mode{RateMode::Psnr, 50}, Mode{RateMode::Psnr, 60},
                         Mode{RateMode::MaxError, 2}, Mode{RateMode::RelError, 1e-2},
                         Mode{RateMode::PwRelError, 1e-2}, Mode{RateMode::Bpv, 1}}) {
        const std::string what =
            name + " mode " + std::to_string(int(m.rate)) + " " + std::to_string(m.target);
        const auto f = encode(v, test::smallBrickOptions(m.rate, m.target));
        EXPECT_LE(f.size(), lossless.size()) << what;
        const Volume d = decode(f);
        const double err = maxError(v, d);
        if (m.rate == RateMode::Psnr) EXPECT_GE(psnrInDouble(v, d), m.target - 1e-9) << what;
        if (m.rate == RateMode::MaxError) EXPECT_LE(err, m.target) << what;
        if (m.rate == RateMode::Bpv)
            EXPECT_LE(double(f.size()) * 8, m.target * double(v.voxelCount()) + 1e-9) << what;
        if (m.rate == RateMode::PwRelError)
            for (std::size_t i = 0; i < v.voxelCount(); ++i)
                ASSERT_LE(std::abs(voxel(v, i) - voxel(d, i)), m.target * std::abs(voxel(v, i)) + 1e-12)
                    << what;
    }
}

TEST(VoxelBricks, HardCasesRoundTripInEveryMode) {
    checkEveryMode(makeVolume<std::uint8_t>(ScalarType::UInt8, [](auto, auto, auto, auto&) { return 0; }),
                   "all-zero");
    checkEveryMode(
        makeVolume<std::uint16_t>(ScalarType::UInt16, [](auto, auto, auto, auto&) { return 1234; }),
        "one value");
    checkEveryMode(makeVolume<std::uint8_t>(ScalarType::UInt8,
                                            [](std::size_t x, std::size_t y, std::size_t z, auto&) {
                                                const double r = std::hypot(double(x) - 20, double(y) - 18,
                                                                            double(z) - 10);
                                                return r < 12 ? 1 : 0;
                                            }),
                   "two values");
    checkEveryMode(makeVolume<std::uint8_t>(ScalarType::UInt8,
                                            [](std::size_t x, std::size_t y, std::size_t z, auto&) {
                                                return ((x / 3 + y / 4 + z / 2) % 2) * 255;
                                            }),
                   "0/255");
    checkEveryMode(labelVolume<std::uint16_t>(ScalarType::UInt16, 900), "uint16 900 labels");
    checkEveryMode(labelVolume<std::int16_t>(ScalarType::Int16, 40), "int16 labels");
    checkEveryMode(
        makeVolume<std::uint8_t>(ScalarType::UInt8, [](auto, auto, auto, auto& rng) { return rng() % 256; }),
        "uint8 noise");
    checkEveryMode(makeVolume<std::uint8_t>(ScalarType::UInt8,
                                            [](std::size_t x, std::size_t, std::size_t, auto& rng) {
                                                return x % 16 < 8 ? 7.0 : double(rng() % 200);
                                            }),
                   "flat and textured halves");
}

TEST(VoxelBricks, LabelVolumesUseThemAndStayExact) {
    // A label volume's bricks are voxel-coded (version 7) in lossless and lossy files, and decode exactly.
    for (const auto& v : {labelVolume<std::uint16_t>(ScalarType::UInt16, 900),
                          labelVolume<std::uint8_t>(ScalarType::UInt8, 60)}) {
        for (RateMode r : {RateMode::Lossless, RateMode::Psnr}) {
            const auto f = encode(v, test::smallBrickOptions(r, r == RateMode::Psnr ? 50 : 0));
            EXPECT_EQ(versionOf(f), kVczVersionVoxelBricks);
            expectExact(v, f, "labels");
        }
    }
    // Smooth data keeps the wavelet: version 6, as before.
    const Volume smooth =
        makeVolume<std::uint8_t>(ScalarType::UInt8, [](std::size_t x, std::size_t y, std::size_t z, auto&) {
            return 120 + 100 * std::sin(0.1 * double(x)) * std::cos(0.13 * double(y + z));
        });
    EXPECT_EQ(versionOf(encode(smooth, test::smallBrickOptions(RateMode::Psnr, 40))), kVczVersionCompact);
}

TEST(VoxelBricks, FloatLabelsAndNonFiniteVoxels) {
    Volume v = labelVolume<float>(ScalarType::Float32, 12);
    v.values<float>()[5] = NAN;
    v.values<float>()[kDims.count() - 3] = -INFINITY;
    for (RateMode r : {RateMode::Lossless, RateMode::Psnr, RateMode::MaxError}) {
        const auto f = encode(v, test::smallBrickOptions(r, r == RateMode::Psnr ? 60 : 0.01));
        const Volume d = decode(f);
        EXPECT_TRUE(std::isnan(d.values<float>()[5]));
        EXPECT_EQ(d.values<float>()[kDims.count() - 3], -INFINITY);
        // Lossless and --max-error 0.01 hold every finite voxel within 0.01; --psnr 60 holds its PSNR over the
        // finite voxels' range (0 to 11).
        double sumSq = 0;
        std::size_t finite = 0;
        for (std::size_t i = 0; i < v.voxelCount(); ++i)
            if (std::isfinite(v.values<float>()[i])) {
                const double e = double(v.values<float>()[i]) - double(d.values<float>()[i]);
                if (r != RateMode::Psnr) ASSERT_LE(std::abs(e), 0.01);
                sumSq += e * e;
                ++finite;
            }
        if (r == RateMode::Psnr && sumSq > 0)
            EXPECT_GE(10 * std::log10(11.0 * 11.0 / (sumSq / double(finite))), 60.0 - 0.1);
    }
}

TEST(VoxelBricks, LevelsAndRegionsMatchTheReference) {
    const Volume v = labelVolume<std::uint16_t>(ScalarType::UInt16, 900);
    const auto f = encode(v, test::smallBrickOptions(RateMode::Lossless, 0));
    ASSERT_EQ(versionOf(f), kVczVersionVoxelBricks);
    const Volume full = decode(f);
    // A region equals the crop of the full decode.
    DecodeOptions ro;
    ro.region = Region{{3, 5, 2}, {37, 30, 19}};
    const Volume part = decode(f, ro);
    for (std::size_t z = 2; z < 19; ++z)
        for (std::size_t y = 5; y < 30; ++y)
            for (std::size_t x = 3; x < 37; ++x)
                ASSERT_EQ(part.values<std::uint16_t>()[part.index(x - 3, y - 5, z - 2)],
                          full.values<std::uint16_t>()[full.index(x, y, z)]);
    // Level k: each brick's low band of the reversible cdf53 (what a wavelet brick of the same voxels gives).
    for (int level : {1, 2}) {
        DecodeOptions lo;
        lo.level = level;
        const Volume d = decode(f, lo);
        for (std::size_t bz = 0; bz < kDims.z; bz += 16)
            for (std::size_t by = 0; by < kDims.y; by += 16)
                for (std::size_t bx = 0; bx < kDims.x; bx += 16) {
                    const Dims bd{std::min<std::size_t>(16, kDims.x - bx),
                                  std::min<std::size_t>(16, kDims.y - by),
                                  std::min<std::size_t>(16, kDims.z - bz)};
                    std::vector<std::int32_t> c(bd.count());
                    for (std::size_t z = 0; z < bd.z; ++z)
                        for (std::size_t y = 0; y < bd.y; ++y)
                            for (std::size_t x = 0; x < bd.x; ++x)
                                c[(z * bd.y + y) * bd.x + x] =
                                    v.values<std::uint16_t>()[v.index(bx + x, by + y, bz + z)];
                    reference::forward3d(std::span<std::int32_t>(c), bd, level, Wavelet::Cdf53);
                    for (auto& x : c) // the decoders clamp the low band to the voxel type
                        x = std::clamp(x, 0, 65535);
                    const Dims ld = levelDims(bd, level);
                    const std::size_t s = std::size_t(1) << level;
                    for (std::size_t z = 0; z < ld.z; ++z)
                        for (std::size_t y = 0; y < ld.y; ++y)
                            for (std::size_t x = 0; x < ld.x; ++x)
                                ASSERT_EQ(double(d.values<std::uint16_t>()[d.index(bx / s + x, by / s + y,
                                                                                   bz / s + z)]),
                                          double(c[(z * bd.y + y) * bd.x + x]));
                }
    }
}

TEST(VoxelBricks, DamageIsRefused) {
    const Volume v = labelVolume<std::uint8_t>(ScalarType::UInt8, 60);
    const auto f = encode(v, test::smallBrickOptions(RateMode::Lossless, 0));
    ASSERT_EQ(versionOf(f), kVczVersionVoxelBricks);
    // Every byte flip of the last brick's payload (the file's tail) is caught by its checksum.
    for (std::size_t k = 1; k <= 24; ++k) {
        auto bad = f;
        bad[bad.size() - k] ^= std::byte{0x5a};
        EXPECT_THROW(decode(bad), IoError) << k;
    }
    // The voxel decoder alone: random and truncated payloads are refused or decode, never crash.
    std::mt19937 rng(3);
    const Dims d{16, 16, 16};
    for (int t = 0; t < 300; ++t) {
        std::vector<std::uint8_t> p(rng() % 64);
        for (auto& b : p)
            b = std::uint8_t(rng());
        if (!p.empty()) p[0] = 0;
        if (p.size() > 1) p[1] = std::uint8_t(1 + t % 3);
        try {
            const auto vox = codec::decodeVoxelBrick(p, ScalarType::UInt16, d, "random");
            EXPECT_EQ(vox.size(), d.count());
        } catch (const IoError&) {
        }
    }
}

} // namespace
