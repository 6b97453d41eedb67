// Lossy coding of float volumes with NaN/Inf voxels: kept bit for bit, the finite voxels bounded, checked in
// double on the decoded volume.
#include "core/Error.hpp"
#include "tests/CodecTestOptions.hpp"
#include "tests/TestUtil.hpp"
#include "wavelet/Codec.hpp"
#include "wavelet/container/LodStatistics.hpp"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <set>

using namespace volcl;

namespace {

constexpr Dims kDims{40, 36, 30};

float fromBits(std::uint32_t b) {
    return std::bit_cast<float>(b);
}

/// A smooth field (0..1000) with a 7^3 block of quiet NaN, a plane strip of +Inf, scattered -Inf and a NaN
/// with its own payload.
Volume holedVolume() {
    Volume v(kDims, ScalarType::Float32);
    auto s = v.values<float>();
    for (std::size_t z = 0; z < kDims.z; ++z)
        for (std::size_t y = 0; y < kDims.y; ++y)
            for (std::size_t x = 0; x < kDims.x; ++x)
                s[v.index(x, y, z)] =
                    float(500.0 + 300.0 * std::sin(0.21 * double(x)) * std::cos(0.17 * double(y)) +
                          150.0 * std::sin(0.13 * double(z)) + 7.0 * std::sin(double(x * y + z)));
    for (std::size_t z = 10; z < 17; ++z)
        for (std::size_t y = 12; y < 19; ++y)
            for (std::size_t x = 14; x < 21; ++x)
                s[v.index(x, y, z)] = std::numeric_limits<float>::quiet_NaN();
    for (std::size_t x = 0; x < kDims.x; ++x)
        s[v.index(x, 30, 25)] = std::numeric_limits<float>::infinity();
    for (std::size_t i = 5; i < s.size(); i += 997)
        s[i] = -std::numeric_limits<float>::infinity();
    s[v.index(39, 35, 29)] = fromBits(0x7fc12345u); // quiet NaN with a payload, in the last brick's corner
    return v;
}

struct FiniteError {
    double maxErr = 0, psnr = 0;
};

/// Checks every non-finite voxel's bits and every finite voxel's finiteness; returns the max error and PSNR
/// over the finite voxels (range of the finite input values), in double.
FiniteError checkDecoded(const Volume& in, const Volume& out, const std::string& what) {
    const auto a = in.values<float>(), b = out.values<float>();
    double lo = INFINITY, hi = -INFINITY, sumSq = 0, maxErr = 0;
    std::size_t n = 0;
    for (std::size_t i = 0; i < a.size(); ++i) {
        if (!std::isfinite(a[i])) {
            EXPECT_EQ(std::bit_cast<std::uint32_t>(b[i]), std::bit_cast<std::uint32_t>(a[i]))
                << what << " voxel " << i;
            continue;
        }
        EXPECT_TRUE(std::isfinite(b[i])) << what << " voxel " << i;
        lo = std::min(lo, double(a[i]));
        hi = std::max(hi, double(a[i]));
        const double e = std::abs(double(b[i]) - double(a[i]));
        maxErr = std::max(maxErr, e);
        sumSq += e * e;
        ++n;
    }
    const double rmse = std::sqrt(sumSq / double(n));
    return {maxErr, rmse == 0 ? INFINITY : 20.0 * std::log10((hi - lo) / rmse)};
}

TEST(CodecNan, EveryLossyModeKeepsNonFiniteVoxelsAndBoundsTheRest) {
    ComputeContext& cc = test::computeContext();
    const Volume v = holedVolume();
    const double voxels = double(v.voxelCount());
    for (double e : {0.25, 2.0}) {
        const auto bytes = encodeVolume(cc, v, test::smallBrickOptions(RateMode::MaxError, e));
        const FiniteError fe = checkDecoded(v, decodeVolume(cc, bytes), "max-error");
        EXPECT_LE(fe.maxErr, e) << "max-error " << e;
    }
    for (double p : {40.0, 60.0}) {
        const auto bytes = encodeVolume(cc, v, test::smallBrickOptions(RateMode::Psnr, p));
        const FiniteError fe = checkDecoded(v, decodeVolume(cc, bytes), "psnr");
        EXPECT_GE(fe.psnr, p) << "psnr " << p;
    }
    for (double r : {1.0, 3.0}) {
        const auto bytes = encodeVolume(cc, v, test::smallBrickOptions(RateMode::Bpv, r));
        checkDecoded(v, decodeVolume(cc, bytes), "bpv");
        EXPECT_LE(double(bytes.size()) * 8.0 / voxels, r) << "bpv " << r;
    }
    CodecOptions fixed = test::smallBrickOptions(RateMode::Psnr, 40);
    fixed.step = 4.0;
    fixed.measureError = false; // the direct path, which codes no corrections of its own
    checkDecoded(v, decodeVolume(cc, encodeVolume(cc, v, fixed)), "fixed step");
}

TEST(CodecNan, NonFiniteBricksListedAndStatisticsFinite) {
    ComputeContext& cc = test::computeContext();
    const Volume v = holedVolume();
    TimeSeries one;
    one.frames.push_back(v);
    const auto bytes =
        encodeWithLodStatistics(cc, one, test::smallBrickOptions(RateMode::MaxError, 1.0), "holed");
    const VczReader reader(bytes, "holed");
    const VczHeader& h = reader.header();
    // The bricks holding a non-finite voxel, found here by brute force over voxel positions.
    std::set<std::size_t> want;
    const auto s = v.values<float>();
    const Dims g = h.brickGrid();
    for (std::size_t z = 0; z < kDims.z; ++z)
        for (std::size_t y = 0; y < kDims.y; ++y)
            for (std::size_t x = 0; x < kDims.x; ++x)
                if (!std::isfinite(s[v.index(x, y, z)])) want.insert((z / 16 * g.y + y / 16) * g.x + x / 16);
    const std::vector<std::size_t> listed = vczNonFiniteBricks(h, 0);
    EXPECT_EQ(std::set<std::size_t>(listed.begin(), listed.end()), want);
    EXPECT_TRUE(vczNonFiniteBricks(h, 1).empty());
    // Index ranges and level-of-detail statistics ignore the NaN/Inf voxels.
    for (const VczBrickEntry& e : h.bricks[0]) {
        EXPECT_TRUE(std::isfinite(e.min) && std::isfinite(e.max));
        EXPECT_GE(e.min, 0.0);
        EXPECT_LE(e.max, 1000.0);
    }
    const std::optional<LodStatistics> st = LodStatistics::fromHeader(h, "holed");
    ASSERT_TRUE(st);
    for (const BrickLevelStats& b : st->frames[0]) {
        EXPECT_TRUE(std::isfinite(b.error) && std::isfinite(b.rms) && std::isfinite(b.min) &&
                    std::isfinite(b.max));
        EXPECT_LE(b.max, 1000.0f);
    }
    // The finite error at level 0 is the coding error: within the bound.
    for (std::size_t b = 0; b < h.brickCount(); ++b)
        EXPECT_LE(st->at(0, b, 0).error, 1.0f + 1e-6f) << "brick " << b;
}

TEST(CodecNan, SeriesWithMotionNamesTheFrameAndTheWayOut) {
    ComputeContext& cc = test::computeContext();
    TimeSeries ts;
    ts.frames = {holedVolume(), holedVolume()};
    CodecOptions o = test::smallBrickOptions(RateMode::MaxError, 1.0);
    try {
        encodeSeries(cc, ts, o);
        ADD_FAILURE() << "motion prediction accepted NaN frames";
    } catch (const DataError& e) {
        EXPECT_NE(std::string(e.what()).find("--motion none"), std::string::npos) << e.what();
    }
    o.motion = MotionMode::None;
    const TimeSeries out = decodeAllFrames(VczReader(encodeSeries(cc, ts, o), "series"), cc, 2, nullptr);
    ASSERT_EQ(out.frames.size(), 2u);
    for (const Volume& f : out.frames)
        EXPECT_LE(checkDecoded(ts.frames[0], f, "series").maxErr, 1.0);
}

} // namespace
