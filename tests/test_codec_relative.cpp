// The relative bounds (--rel-error, --pw-rel-error) checked on every voxel, in double, from the decoded
// volumes: adversarial float32 and integer volumes, series, regions and the shared Isabel and fingering data.
#include "core/Error.hpp"
#include "host/io/VolumeIo.hpp"
#include "tests/CodecTestOptions.hpp"
#include "tests/TestUtil.hpp"
#include "wavelet/Codec.hpp"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <utility>
#include <vector>

using namespace volcl;

namespace {

constexpr Dims kDims{21, 18, 13};

Volume floatVolume(const std::function<float(std::size_t, std::size_t, std::size_t, std::mt19937&)>& f,
                   unsigned seed = 7) {
    return test::generatedVolume<float>(kDims, f, seed);
}

double smooth(std::size_t x, std::size_t y, std::size_t z) {
    return test::smoothWave(x, y, z);
}

// The adversarial float32 volumes, each named.
std::vector<std::pair<std::string, Volume>> adversarialVolumes() {
    std::vector<std::pair<std::string, Volume>> out;
    std::uniform_real_distribution<double> u(-1, 1);
    out.emplace_back("zeros", floatVolume([](auto, auto, auto, auto&) { return 0.0f; }));
    out.emplace_back("constant", floatVolume([](auto, auto, auto, auto&) { return -3.25f; }));
    out.emplace_back("mixed-signs", floatVolume([](std::size_t x, std::size_t y, std::size_t z, auto&) {
                         return float(smooth(x, y, z)); // crosses zero everywhere
                     }));
    out.emplace_back("half-zeros", floatVolume([](std::size_t x, std::size_t y, std::size_t z, auto&) {
                         return x < 10 ? 0.0f : float(2 + smooth(x, y, z));
                     }));
    out.emplace_back("denormals", floatVolume([&](std::size_t x, std::size_t y, std::size_t z, auto& rng) {
                         return float(1e-40 * (1.5 + smooth(x, y, z)) + 1e-41 * u(rng));
                     }));
    out.emplace_back("dynamic-range", floatVolume([&](auto, auto, auto, auto& rng) {
                         // magnitudes log-uniform over 1e-40 .. 3e38, random signs, some exact zeros
                         const double r = u(rng);
                         if (std::abs(r) < 0.05) return 0.0f;
                         return float(std::pow(10.0, -40 + 78.4 * (0.5 + 0.5 * u(rng))) * (r < 0 ? -1 : 1));
                     }));
    out.emplace_back("non-finite", floatVolume([&](std::size_t x, std::size_t y, std::size_t z, auto& rng) {
                         const double r = u(rng);
                         if (r > 0.95) return std::numeric_limits<float>::infinity();
                         if (r < -0.95) return -std::numeric_limits<float>::infinity();
                         if (std::abs(r) < 0.03)
                             return std::bit_cast<float>(0x7fc01234u); // NaN with a payload
                         if (std::abs(r) < 0.06) return 0.0f;
                         return float(100 * smooth(x, y, z));
                     }));
    return out;
}

// The range of the finite voxels of `v`.
std::pair<double, double> finiteRange(const Volume& v) {
    double lo = INFINITY, hi = -INFINITY;
    for (std::size_t i = 0; i < v.voxelCount(); ++i)
        if (const double a = v.valueAt(i); std::isfinite(a)) {
            lo = std::min(lo, a);
            hi = std::max(hi, a);
        }
    return {lo, hi};
}

// Every voxel of `out` against `in`: NaN/Inf bit for bit, the finite ones within the mode's bound (relative:
// to the finite range of `frame`, the whole frame `in` may be a region of); for --pw-rel-error zeros exact
// and signs kept. Returns the voxels checked against a bound.
std::size_t expectWithinBound(const Volume& in, const Volume& out, RateMode mode, double r,
                              const std::string& what, const Volume* frame = nullptr) {
    EXPECT_EQ(out.type(), in.type()) << what;
    EXPECT_EQ(out.dims(), in.dims()) << what;
    const auto [lo, hi] = finiteRange(frame ? *frame : in);
    const double absolute = mode == RateMode::RelError ? r * (hi - lo) : 0.0;
    std::size_t failures = 0, checked = 0;
    for (std::size_t i = 0; i < in.voxelCount() && failures < 5; ++i) {
        const double a = in.valueAt(i), b = out.valueAt(i);
        if (!std::isfinite(a)) {
            const bool same =
                in.type() == ScalarType::Float32 && std::bit_cast<std::uint32_t>(in.values<float>()[i]) ==
                                                        std::bit_cast<std::uint32_t>(out.values<float>()[i]);
            if (!same) ADD_FAILURE() << what << ": non-finite voxel " << i << " changed (" << b << ")";
            failures += !same;
            continue;
        }
        ++checked;
        const double limit = mode == RateMode::RelError ? absolute : r * std::abs(a);
        bool ok = std::abs(b - a) <= limit;
        if (mode == RateMode::PwRelError) ok = ok && (a == 0 ? b == 0 : std::signbit(a) == std::signbit(b));
        if (!ok) {
            ADD_FAILURE() << what << ": voxel " << i << " is " << b << " for " << a << " (bound " << limit
                          << ")";
            ++failures;
        }
    }
    return checked;
}

void roundTrip(const Volume& v, RateMode mode, double r, const std::string& what, EntropyMode entropy) {
    CodecOptions o = test::smallBrickOptions(mode, r);
    o.entropy = entropy;
    std::vector<std::byte> bytes;
    try {
        bytes = encodeVolume(test::computeContext(), v, o);
    } catch (const std::exception& e) {
        ADD_FAILURE() << what << ": " << e.what();
        return;
    }
    const Volume out = decodeVolume(test::computeContext(), bytes);
    expectWithinBound(v, out, mode, r, what);
}

const char* modeName(RateMode m) {
    return m == RateMode::RelError ? "rel-error" : "pw-rel-error";
}

} // namespace

TEST(CodecRelative, AdversarialFloatVolumesHoldBothBoundsOnEveryVoxel) {
    for (const auto& [name, v] : adversarialVolumes())
        for (RateMode mode : {RateMode::RelError, RateMode::PwRelError})
            for (double r : {1e-1, 1e-3, 1e-6})
                for (EntropyMode e : {EntropyMode::Dense, EntropyMode::Fast})
                    roundTrip(v, mode, r,
                              name + " " + modeName(mode) + " " + std::to_string(r) + " " +
                                  std::string(entropyName(e)),
                              e);
}

TEST(CodecRelative, IntegerVolumesHoldBothBounds) {
    for (ScalarType t : {ScalarType::UInt8, ScalarType::UInt16, ScalarType::Int16}) {
        const double scale = t == ScalarType::UInt8 ? 120 : 20000;
        const double offset = t == ScalarType::Int16 ? 0 : scale + 5;
        const Volume v = floatVolume([&](std::size_t x, std::size_t y, std::size_t z, auto&) {
                             return float(offset + scale * smooth(x, y, z));
                         }).convertedTo(t);
        for (RateMode mode : {RateMode::RelError, RateMode::PwRelError})
            for (double r : {0.05, 0.002})
                roundTrip(v, mode, r,
                          std::string(scalarTypeName(t)) + " " + modeName(mode) + " " + std::to_string(r),
                          EntropyMode::Dense);
    }
}

TEST(CodecRelative, PointwiseBoundHoldsThroughMotionCompensatedSeriesAndRegions) {
    TimeSeries ts;
    for (int t = 0; t < 4; ++t)
        ts.frames.push_back(floatVolume([t](std::size_t x, std::size_t y, std::size_t z, auto&) {
            return float(std::sin(0.4 * double(x) + 0.3 * t) * std::cos(0.3 * double(y)) + 0.1 * double(z) -
                         0.4);
        }));
    for (RateMode mode : {RateMode::RelError, RateMode::PwRelError}) {
        CodecOptions o = test::smallBrickOptions(mode, 0.01);
        o.gop = 4;
        o.bFrames = 1;
        std::vector<FrameReport> reports;
        const std::vector<std::byte> bytes = encodeSeries(test::computeContext(), ts, o, &reports);
        bool predicted = false;
        for (const FrameReport& f : reports)
            predicted = predicted || f.type != FrameType::I;
        EXPECT_TRUE(predicted) << modeName(mode) << ": the series codes P/B frames";
        for (std::size_t k = 0; k < ts.frames.size(); ++k) {
            DecodeOptions d;
            d.frame = k;
            expectWithinBound(ts.frames[k], decodeVolume(test::computeContext(), bytes, d), mode, 0.01,
                              std::string(modeName(mode)) + " frame " + std::to_string(k));
            // A region applies the corrections that fall into it.
            d.region = Region{{3, 2, 1}, {19, 17, 12}};
            const Volume part = decodeVolume(test::computeContext(), bytes, d);
            expectWithinBound(ts.frames[k].cropped(d.region->lo, d.region->hi), part, mode, 0.01,
                              std::string(modeName(mode)) + " region of frame " + std::to_string(k),
                              &ts.frames[k]);
        }
    }
}

TEST(CodecRelative, BadBoundsAreRefused) {
    const Volume v = adversarialVolumes()[2].second;
    for (double r : {0.0, -0.1, 1.0, 2.0, double(NAN), double(INFINITY)})
        EXPECT_THROW(
            encodeVolume(test::computeContext(), v, test::smallBrickOptions(RateMode::PwRelError, r)),
            UsageError)
            << r;
    for (double r : {0.0, -0.1, double(NAN)})
        EXPECT_THROW(encodeVolume(test::computeContext(), v, test::smallBrickOptions(RateMode::RelError, r)),
                     UsageError)
            << r;
}

// Real float data: Isabel's wind speed (step 30) and a viscous-fingering step, every voxel checked.
TEST(CodecRelative, SharedFloatVolumesHoldBothBoundsOnEveryVoxel) {
    std::filesystem::path data;
    VOLCL_REQUIRE_SHARED_DATA(data);
    for (const char* name :
         {"timevarying/isabel/isabel_30.vti", "timevarying/viscousfingers/010_density_010_064_2.0.vti"}) {
        const std::filesystem::path p = data / name;
        if (!std::filesystem::exists(p)) {
            ADD_FAILURE() << p << " is missing from the shared data";
            continue;
        }
        const Volume v = readVolume(p);
        for (RateMode mode : {RateMode::RelError, RateMode::PwRelError}) {
            CodecOptions o;
            o.rate = mode;
            o.target = 1e-3;
            const std::vector<std::byte> bytes = encodeVolume(test::computeContext(), v, o);
            const std::size_t checked =
                expectWithinBound(v, decodeVolume(test::computeContext(), bytes), mode, 1e-3,
                                  std::string(name) + " " + modeName(mode));
            EXPECT_EQ(checked, v.voxelCount()) << name;
            EXPECT_LT(bytes.size(), v.byteSize()) << name << " " << modeName(mode);
        }
    }
}
