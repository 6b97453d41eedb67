// Float64 volumes kept as float64: readers and writers, lossless bit for bit and every lossy bound checked
// in double on every voxel, from the decoded volumes (adversarial volumes, series, regions, Isabel).
#include "core/Error.hpp"
#include "host/io/VolumeIo.hpp"
#include "tests/CodecTestOptions.hpp"
#include "tests/TestUtil.hpp"
#include "wavelet/Codec.hpp"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <utility>
#include <vector>

using namespace volcl;
namespace fs = std::filesystem;

namespace {

constexpr Dims kDims{21, 18, 13};

Volume doubleVolume(const std::function<double(std::size_t, std::size_t, std::size_t, std::mt19937&)>& f,
                    unsigned seed = 11) {
    return test::generatedVolume<double>(kDims, f, seed);
}

double smooth(std::size_t x, std::size_t y, std::size_t z) {
    return test::smoothWave(x, y, z);
}

// Adversarial float64 volumes, each named: float32 cannot hold most of them.
std::vector<std::pair<std::string, Volume>> adversarialVolumes() {
    std::vector<std::pair<std::string, Volume>> out;
    std::uniform_real_distribution<double> u(-1, 1);
    out.emplace_back("signed-zeros",
                     doubleVolume([](std::size_t x, auto, auto, auto&) { return x % 2 ? -0.0 : 0.0; }));
    out.emplace_back("constant", doubleVolume([](auto, auto, auto, auto&) { return -3.25000000000001; }));
    out.emplace_back("mixed-signs", doubleVolume([&](std::size_t x, std::size_t y, std::size_t z, auto& rng) {
                         // crosses zero everywhere, with detail below float32's precision
                         return smooth(x, y, z) + 1e-12 * u(rng);
                     }));
    out.emplace_back("denormals", doubleVolume([&](std::size_t x, std::size_t y, std::size_t z, auto& rng) {
                         return 1e-310 * (1.5 + smooth(x, y, z)) + 1e-312 * u(rng); // float64 subnormals
                     }));
    out.emplace_back("tiny", doubleVolume([&](std::size_t x, std::size_t y, std::size_t z, auto&) {
                         return 1e-300 * smooth(x, y, z); // zero in float32
                     }));
    out.emplace_back("beyond-float", doubleVolume([&](std::size_t x, std::size_t y, std::size_t z, auto&) {
                         return 1e300 * (2 + smooth(x, y, z)) * (x < 10 ? -1 : 1); // Inf in float32
                     }));
    out.emplace_back("dynamic-range", doubleVolume([&](auto, auto, auto, auto& rng) {
                         // magnitudes log-uniform over 1e-300 .. 1e300, random signs, some exact zeros
                         const double r = u(rng);
                         if (std::abs(r) < 0.05) return 0.0;
                         return std::pow(10.0, 600 * (0.5 * u(rng))) * (r < 0 ? -1 : 1);
                     }));
    out.emplace_back("non-finite", doubleVolume([&](std::size_t x, std::size_t y, std::size_t z, auto& rng) {
                         const double r = u(rng);
                         if (r > 0.95) return std::numeric_limits<double>::infinity();
                         if (r < -0.95) return -std::numeric_limits<double>::infinity();
                         if (std::abs(r) < 0.03)
                             return std::bit_cast<double>(0x7ff8000000001234ull); // NaN, payload in low bits
                         if (std::abs(r) < 0.06) return -0.0;
                         return 100 * smooth(x, y, z);
                     }));
    return out;
}

std::uint64_t bitsOf(double v) {
    return std::bit_cast<std::uint64_t>(v);
}

// Every voxel bit for bit.
void expectBitExact(const Volume& in, const Volume& out, const std::string& what) {
    ASSERT_EQ(out.type(), ScalarType::Float64) << what;
    ASSERT_EQ(out.dims(), in.dims()) << what;
    const auto a = in.values<double>(), b = out.values<double>();
    std::size_t wrong = 0;
    for (std::size_t i = 0; i < a.size(); ++i)
        wrong += bitsOf(a[i]) != bitsOf(b[i]);
    EXPECT_EQ(wrong, 0u) << what;
}

std::pair<double, double> finiteRange(std::span<const double> a) {
    double lo = INFINITY, hi = -INFINITY;
    for (double v : a)
        if (std::isfinite(v)) {
            lo = std::min(lo, v);
            hi = std::max(hi, v);
        }
    return {lo, hi};
}

// The bound of `mode` on every voxel, in double; NaN/Inf and zeros bit for bit.
void expectWithinBound(const Volume& in, const Volume& out, RateMode mode, double target,
                       const std::string& what) {
    ASSERT_EQ(out.type(), ScalarType::Float64) << what;
    const auto a = in.values<double>(), b = out.values<double>();
    const auto [lo, hi] = finiteRange(a);
    const double halfRange = 0.5 * hi - 0.5 * lo; // PSNR from errors relative to the range: no overflow
    std::size_t wrong = 0, finite = 0;
    double sq = 0;
    for (std::size_t i = 0; i < a.size(); ++i) {
        const double x = a[i], y = b[i];
        if (!std::isfinite(x)) {
            wrong += bitsOf(x) != bitsOf(y);
            continue;
        }
        const double err = std::abs(x - y);
        // PSNR is over every finite voxel, zeros included (a zero's error counts like any other).
        ++finite;
        if (halfRange > 0) sq += (0.5 * err / halfRange) * (0.5 * err / halfRange);
        if (x == 0) {
            wrong +=
                bitsOf(x) != bitsOf(y) && !(mode != RateMode::PwRelError && y != 0 &&
                                            std::abs(y) <= (mode == RateMode::MaxError ? target : INFINITY));
            continue;
        }
        switch (mode) {
        case RateMode::MaxError:
            wrong += !(err <= target);
            break;
        case RateMode::RelError:
            wrong += !(err <= target * hi - target * lo);
            break;
        case RateMode::PwRelError:
            wrong += !(err <= target * std::abs(x));
            break;
        default:
            break;
        }
    }
    EXPECT_EQ(wrong, 0u) << what;
    if (mode == RateMode::Psnr && finite > 0 && halfRange > 0) {
        const double mse = sq / double(finite); // of errors / range
        EXPECT_TRUE(mse == 0 || -10 * std::log10(mse) >= target)
            << what << ": " << -10 * std::log10(mse) << " dB against " << target;
    }
}

const char* modeName(RateMode m) {
    return m == RateMode::MaxError   ? "max-error"
           : m == RateMode::RelError ? "rel-error"
           : m == RateMode::Psnr     ? "psnr"
                                     : "pw-rel-error";
}

// A lossy target per mode: for max-error a thousandth of the volume's finite range (1 for flat volumes).
double targetFor(RateMode m, const Volume& v) {
    if (m == RateMode::MaxError) {
        const auto [lo, hi] = finiteRange(v.values<double>());
        const double r = 1e-3 * hi - 1e-3 * lo;
        return r > 0 && std::isfinite(r) ? r : 1.0;
    }
    return m == RateMode::Psnr ? 60.0 : m == RateMode::PwRelError ? 1e-2 : 1e-3;
}

} // namespace

TEST(CodecFloat64, LosslessIsBitExactOnAdversarialVolumes) {
    for (const auto& [name, v] : adversarialVolumes()) {
        const std::vector<std::byte> bytes =
            encodeVolume(test::computeContext(), v, test::smallBrickOptions(RateMode::Lossless, 0));
        const VczReader r(bytes, name);
        EXPECT_TRUE(r.header().float64) << name;
        EXPECT_EQ(r.header().type, ScalarType::Float32) << name << ": the bricks hold the float32 layer";
        expectBitExact(v, r.decode(test::computeContext()), name);
    }
}

TEST(CodecFloat64, EveryLossyBoundHoldsOnEveryVoxelInDouble) {
    for (const auto& [name, v] : adversarialVolumes())
        for (RateMode mode : {RateMode::MaxError, RateMode::RelError, RateMode::PwRelError, RateMode::Psnr}) {
            const double target = targetFor(mode, v);
            EncodeReport rep;
            const std::vector<std::byte> bytes =
                encodeVolume(test::computeContext(), v, test::smallBrickOptions(mode, target), &rep);
            const Volume out = decodeVolume(test::computeContext(), bytes);
            expectWithinBound(v, out, mode, target, name + " " + modeName(mode));
            EXPECT_EQ(rep.bytes, bytes.size()) << name;
        }
}

TEST(CodecFloat64, SmoothDataCompressesAndMeetsTheBoundWithFewExactVoxels) {
    const Volume v = doubleVolume([](std::size_t x, std::size_t y, std::size_t z, auto&) {
        return 1000 * smooth(x, y, z) + 1e-9 * double(x * y);
    });
    for (RateMode mode : {RateMode::MaxError, RateMode::RelError, RateMode::PwRelError}) {
        const double target = mode == RateMode::MaxError ? 1.0 : 1e-3;
        EncodeReport rep;
        const auto bytes =
            encodeVolume(test::computeContext(), v, test::smallBrickOptions(mode, target), &rep);
        expectWithinBound(v, decodeVolume(test::computeContext(), bytes), mode, target, modeName(mode));
        EXPECT_LT(bytes.size(), v.byteSize() / 4) << modeName(mode);
    }
    const auto exact =
        encodeVolume(test::computeContext(), v, test::smallBrickOptions(RateMode::Lossless, 0));
    EXPECT_LT(exact.size(), v.byteSize()) << "byte planes of the XOR residual compress";
}

TEST(CodecFloat64, RegionsLevelsAndBricksDecode) {
    const Volume v = adversarialVolumes()[7].second; // non-finite
    for (RateMode mode : {RateMode::Lossless, RateMode::MaxError}) {
        const auto bytes =
            encodeVolume(test::computeContext(), v, test::smallBrickOptions(mode, targetFor(mode, v)));
        const VczReader r(bytes, "f64");
        const Volume whole = r.decode(test::computeContext());
        DecodeOptions o;
        o.region = Region{{3, 2, 1}, {20, 17, 9}};
        expectBitExact(whole.cropped(o.region->lo, o.region->hi), r.decode(test::computeContext(), o),
                       "region");
        o.region.reset();
        o.level = 1;
        const Volume coarse = r.decode(test::computeContext(), o);
        EXPECT_EQ(coarse.type(), ScalarType::Float64);
        EXPECT_EQ(coarse.dims(), (Dims{11, 9, 7}));
        // Renderers read bricks of the float32 layer.
        EXPECT_EQ(r.decodeBrick(test::computeContext(), 0, 0).type(), ScalarType::Float32);
    }
}

TEST(CodecFloat64, SeriesKeepEveryFrame) {
    TimeSeries ts;
    for (unsigned k = 0; k < 3; ++k)
        ts.frames.push_back(doubleVolume([k](std::size_t x, std::size_t y, std::size_t z,
                                             auto&) { return smooth(x + k, y, z) * 1e5 + 1e-7 * double(z); },
                                         k));
    ts.times = {0.5, 1.0, 1.5};
    for (RateMode mode : {RateMode::Lossless, RateMode::RelError, RateMode::PwRelError}) {
        const double target = mode == RateMode::PwRelError ? 1e-2 : 1e-4;
        const auto bytes = encodeSeries(test::computeContext(), ts, test::smallBrickOptions(mode, target));
        const VczReader r(bytes, "series");
        EXPECT_TRUE(r.header().float64);
        const TimeSeries back = decodeAllFrames(r, test::computeContext());
        ASSERT_EQ(back.frames.size(), 3u);
        EXPECT_EQ(back.times, ts.times);
        for (std::size_t f = 0; f < 3; ++f)
            if (mode == RateMode::Lossless)
                expectBitExact(ts.frames[f], back.frames[f], "frame " + std::to_string(f));
            else
                expectWithinBound(ts.frames[f], back.frames[f], mode, target, "frame " + std::to_string(f));
    }
}

TEST(CodecFloat64, UnboundedModesAreRefusedAndFloat32FilesStayAsTheyWere) {
    const Volume v = adversarialVolumes()[2].second;
    EXPECT_THROW(encodeVolume(test::computeContext(), v, test::smallBrickOptions(RateMode::Bpv, 2)),
                 UsageError);
    CodecOptions step = test::smallBrickOptions(RateMode::MaxError, 1e-3);
    step.step = 0.01;
    EXPECT_THROW(encodeVolume(test::computeContext(), v, step), UsageError);
    EXPECT_THROW(encodeVolume(test::computeContext(), v, test::smallBrickOptions(RateMode::PwRelError, 1.0)),
                 UsageError);
    // A float32 volume is coded as before: no float64 layer, version 6 or 7.
    const Volume f = v.convertedTo(ScalarType::Float32);
    const auto bytes =
        encodeVolume(test::computeContext(), f, test::smallBrickOptions(RateMode::Lossless, 0));
    const VczReader r(bytes, "f32");
    EXPECT_FALSE(r.header().float64);
    EXPECT_LE(r.header().version, kVczVersionVoxelBricks);
    EXPECT_EQ(r.decode(test::computeContext()).type(), ScalarType::Float32);
}

TEST(CodecFloat64, DamagedFloat64LayerIsAnIoError) {
    const Volume v = adversarialVolumes()[7].second;
    const auto bytes =
        encodeVolume(test::computeContext(), v, test::smallBrickOptions(RateMode::Lossless, 0));
    const VczReader good(bytes, "f64");
    const VczFrame& frame = good.header().frames[0];
    ASSERT_GT(frame.auxSize, 0u);
    // Every byte of the float64 layer flipped in turn: the checksum names it, nothing crashes.
    for (std::uint64_t k = 0; k < frame.auxSize; k += std::max<std::uint64_t>(1, frame.auxSize / 64)) {
        std::vector<std::byte> bad = bytes;
        bad[frame.auxOffset + k] ^= std::byte{0x5a};
        EXPECT_THROW(decodeVolume(test::computeContext(), bad, {}, "bad.vcz"), IoError) << k;
    }
    for (std::size_t cut : {bytes.size() - 1, std::size_t(frame.auxOffset + 1)}) {
        std::vector<std::byte> shorter(bytes.begin(), bytes.begin() + std::ptrdiff_t(cut));
        EXPECT_THROW(decodeVolume(test::computeContext(), shorter, {}, "short.vcz"), IoError) << cut;
    }
}

// Writers that carry float64 write it, and their readers give it back bit for bit.
TEST(CodecFloat64, WritersAndReadersKeepFloat64) {
    const fs::path dir = test::tempDir("codec_float64_io");
    const Volume v = adversarialVolumes()[7].second;
    for (const char* name : {"v.nii", "v.nii.gz", "v.nrrd", "v.nhdr", "v.npy", "v.vti"}) {
        writeVolumeFile(v, dir / name);
        const Volume back = readVolume(dir / name);
        expectBitExact(v, back, name);
    }
}

// Real float64 data: Isabel's wind speed (step 30), every voxel checked, and the file smaller than the
// float64 voxels.
TEST(CodecFloat64, IsabelKeepsFloat64AndEveryBound) {
    std::filesystem::path data;
    VOLCL_REQUIRE_SHARED_DATA(data);
    const Volume v = readVolume(data / "timevarying/isabel/isabel_30.vti");
    ASSERT_EQ(v.type(), ScalarType::Float64);
    CodecOptions lossless;
    const auto exact = encodeVolume(test::computeContext(), v, lossless);
    expectBitExact(v, decodeVolume(test::computeContext(), exact), "isabel lossless");
    EXPECT_LT(exact.size(), v.byteSize());
    for (RateMode mode : {RateMode::RelError, RateMode::PwRelError, RateMode::Psnr}) {
        CodecOptions o;
        o.rate = mode;
        o.target = mode == RateMode::Psnr ? 50 : 1e-3;
        const auto bytes = encodeVolume(test::computeContext(), v, o);
        expectWithinBound(v, decodeVolume(test::computeContext(), bytes), mode, o.target,
                          std::string("isabel ") + modeName(mode));
        EXPECT_LT(bytes.size(), exact.size()) << modeName(mode);
    }
}
