// Lossy modes on float32 volumes of subnormal, tiny, huge (to FLT_MAX) and mixed magnitudes: bounds hold.
#include "core/Error.hpp"
#include "core/Format.hpp"
#include "tests/CodecTestOptions.hpp"
#include "tests/TestUtil.hpp"
#include "wavelet/Codec.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

using namespace volcl;

namespace {

// A smooth field with noise, scaled to `scale`, or (scale 0) magnitudes spread log-uniformly over 1e-40 ..
// 3e38 with random signs.
Volume magnitudeVolume(double scale, unsigned seed) {
    Volume v({20, 18, 13}, ScalarType::Float32);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-1, 1);
    auto s = v.values<float>();
    for (std::size_t z = 0; z < 13; ++z)
        for (std::size_t y = 0; y < 18; ++y)
            for (std::size_t x = 0; x < 20; ++x) {
                double a;
                if (scale == 0) {
                    a = std::pow(10.0, -40 + 78.4 * (0.5 + 0.5 * u(rng))) * (u(rng) < 0 ? -1 : 1);
                } else {
                    a = scale * (0.5 + 0.3 * std::sin(0.4 * double(x)) * std::cos(0.3 * double(y)) +
                                 0.1 * std::sin(0.5 * double(z)) + 0.05 * u(rng));
                }
                s[v.index(x, y, z)] = static_cast<float>(a);
            }
    return v;
}

struct Errors {
    double maxAbs = 0, sumSq = 0, lo = 0, hi = 0;
    bool exact = true;
};

// Errors of `out` against `in`, computed in double from the decoded voxels.
Errors errorsOf(const Volume& in, const Volume& out) {
    Errors e;
    auto a = in.values<float>();
    auto b = out.values<float>();
    e.lo = e.hi = double(a[0]);
    for (std::size_t i = 0; i < a.size(); ++i) {
        const double d = std::abs(double(b[i]) - double(a[i]));
        e.maxAbs = std::max(e.maxAbs, d);
        e.sumSq += d * d;
        e.exact = e.exact && b[i] == a[i];
        e.lo = std::min(e.lo, double(a[i]));
        e.hi = std::max(e.hi, double(a[i]));
    }
    return e;
}

// The file, or nothing (with a failure naming the case) when the encoder throws.
std::vector<std::byte> encodeOrFail(const Volume& v, const CodecOptions& o, const std::string& what) {
    try {
        return encodeVolume(test::computeContext(), v, o);
    } catch (const std::exception& e) {
        ADD_FAILURE() << what << ": " << e.what();
        return {};
    }
}

struct Case {
    std::string name;
    double scale;
};

const std::vector<Case> kCases{{"subnormal 1e-40", 1e-40},
                               {"tiny 1e-30", 1e-30},
                               {"huge 1e30", 1e30},
                               {"near FLT_MAX 3e38", 3e38},
                               {"mixed 1e-40..3e38", 0}};

} // namespace

TEST(CodecMagnitudes, MaxErrorHoldsOnEveryVoxelAtEveryMagnitude) {
    ComputeContext& cc = test::computeContext();
    for (const Case& c : kCases) {
        const Volume v = magnitudeVolume(c.scale, 3);
        const Errors range = errorsOf(v, v);
        // A bound relative to the range, and one far below it (most voxels then stored exactly).
        for (double e : {1e-3 * (range.hi - range.lo), 1e-7 * (range.hi - range.lo)}) {
            if (c.scale == 0 && e < 1e-3) e = 1e-3; // mixed: an absolute bound on values of every magnitude
            const auto file = encodeOrFail(v, test::smallBrickOptions(RateMode::MaxError, e),
                                           c.name + " E=" + formatNumber(e));
            if (file.empty()) continue;
            const Errors got = errorsOf(v, decodeVolume(cc, file));
            EXPECT_LE(got.maxAbs, e) << c.name << " E=" << e << " (exact: " << got.exact << ")";
        }
    }
}

TEST(CodecMagnitudes, PsnrTargetHoldsAtEveryMagnitude) {
    ComputeContext& cc = test::computeContext();
    for (const Case& c : kCases) {
        const Volume v = magnitudeVolume(c.scale, 4);
        for (double target : {30.0, 60.0}) {
            const auto file = encodeOrFail(v, test::smallBrickOptions(RateMode::Psnr, target),
                                           c.name + " psnr " + formatNumber(target));
            if (file.empty()) continue;
            const Errors got = errorsOf(v, decodeVolume(cc, file));
            const double r = got.hi - got.lo, mse = got.sumSq / double(v.voxelCount());
            const double psnr =
                mse == 0 ? std::numeric_limits<double>::infinity() : 10 * std::log10(r * r / mse);
            EXPECT_GE(psnr, target) << c.name << " (exact: " << got.exact << ")";
        }
    }
}

TEST(CodecMagnitudes, BitsPerVoxelBudgetHoldsAtEveryMagnitude) {
    ComputeContext& cc = test::computeContext();
    for (const Case& c : kCases) {
        const Volume v = magnitudeVolume(c.scale, 5);
        for (double bpv : {2.0, 8.0}) {
            const auto file = encodeOrFail(v, test::smallBrickOptions(RateMode::Bpv, bpv),
                                           c.name + " bpv " + formatNumber(bpv));
            if (file.empty()) continue;
            EXPECT_LE(double(file.size()) * 8 / double(v.voxelCount()), bpv) << c.name;
            const Volume out = decodeVolume(cc, file);
            for (float x : out.values<float>())
                ASSERT_TRUE(std::isfinite(x)) << c.name << " bpv " << bpv;
        }
    }
}

// A series shares the first frame's steps and predicts later frames from earlier ones (P frames whose
// prediction can overflow float near FLT_MAX): every frame keeps its bound.
TEST(CodecMagnitudes, SeriesFramesHoldTheirBoundsAtEveryMagnitude) {
    ComputeContext& cc = test::computeContext();
    for (const Case& c : kCases) {
        TimeSeries series;
        for (unsigned k = 0; k < 3; ++k) {
            Volume v = magnitudeVolume(c.scale, 6);
            for (float& x : v.values<float>())
                x *= 1.0f - 0.05f * float(k); // a slowly fading copy: P frames pay
            series.frames.push_back(std::move(v));
        }
        const Errors range = errorsOf(series.frames[0], series.frames[0]);
        const double e = c.scale == 0 ? 1e-3 : 1e-3 * (range.hi - range.lo);
        for (const auto& [rate, target] : {std::pair{RateMode::MaxError, e}, std::pair{RateMode::Psnr, 40.0},
                                           std::pair{RateMode::Bpv, 4.0}}) {
            const std::string what = c.name + " series rate " + std::to_string(int(rate));
            std::vector<std::byte> file;
            try {
                file = encodeSeries(cc, series, test::smallBrickOptions(rate, target));
            } catch (const std::exception& x) {
                ADD_FAILURE() << what << ": " << x.what();
                continue;
            }
            const TimeSeries out = decodeAllFrames(VczReader(file, "series"), cc);
            ASSERT_EQ(out.frames.size(), series.frames.size()) << what;
            if (rate == RateMode::Bpv) {
                const double voxels = double(series.frames[0].voxelCount() * series.frames.size());
                EXPECT_LE(double(file.size()) * 8 / voxels, target) << what;
            }
            for (std::size_t k = 0; k < out.frames.size(); ++k) {
                const Errors got = errorsOf(series.frames[k], out.frames[k]);
                if (rate == RateMode::MaxError) EXPECT_LE(got.maxAbs, e) << what << " frame " << k;
                if (rate == RateMode::Psnr) {
                    const double r = got.hi - got.lo, mse = got.sumSq / double(series.frames[k].voxelCount());
                    // The series' frames are held to the target within kPsnrToleranceDb (0.5 dB).
                    EXPECT_GE(mse == 0 ? 1e9 : 10 * std::log10(r * r / mse), target - 0.5)
                        << what << " frame " << k;
                }
                for (float x : out.frames[k].values<float>())
                    ASSERT_TRUE(std::isfinite(x)) << what << " frame " << k;
            }
        }
    }
}
