// Global sub-voxel translation: the Keys-cubic shift (exact for whole voxels, independent of the thread
// count, the synthetic series' resampler) and the Lucas-Kanade estimate of a known translation.
#include "TestUtil.hpp"
#include "host/Error.hpp"
#include "wavelet/predict/GlobalShift.hpp"
#include "wavelet/predict/TranslatedSeries.hpp"

#include <cmath>

using namespace volcl;

namespace {

Volume smooth(Dims d) {
    return test::makeFloatVolume(d, [](double x, double y, double z) {
        return 100 + 40 * std::sin(0.31 * x) * std::cos(0.23 * y) + 30 * std::exp(-0.02 * (z - 9) * (z - 9)) +
               0.5 * x * y / 10;
    });
}

} // namespace

TEST(GlobalShift, WholeVoxelShiftMovesVoxelsExactly) {
    const Volume v = smooth({20, 18, 16});
    const Volume s = cubicShifted(v, {2, -1, 3});
    const Dims d = v.dims();
    for (std::size_t z = 0; z < d.z; ++z)
        for (std::size_t y = 0; y < d.y; ++y)
            for (std::size_t x = 0; x < d.x; ++x) {
                // out(p) = v(p - shift), clamp-to-edge outside.
                const long sx = std::clamp<long>(long(x) - 2, 0, long(d.x) - 1);
                const long sy = std::clamp<long>(long(y) + 1, 0, long(d.y) - 1);
                const long sz = std::clamp<long>(long(z) - 3, 0, long(d.z) - 1);
                ASSERT_NEAR(s.valueAt(s.index(x, y, z)), v.valueAt(v.index(sx, sy, sz)), 1e-4)
                    << x << "," << y << "," << z;
            }
}

TEST(GlobalShift, SameBitsForAnyThreadCount) {
    const Volume v = smooth({33, 17, 9});
    const Volume one = cubicShifted(v, {0.37, -0.81, 0.5}, 1), two = cubicShifted(v, {0.37, -0.81, 0.5}, 2);
    EXPECT_TRUE(one == two);
}

TEST(GlobalShift, TranslatedSeriesIsTheCubicShift) {
    const Volume v = smooth({24, 20, 12});
    const TimeSeries ts = translatedSeries(v, 3, {0.7, -0.4, 0.3});
    const Volume s = cubicShifted(v, {1.4, -0.8, 0.6});
    EXPECT_TRUE(ts.frames[2] == s);
}

TEST(GlobalShift, RecoversAKnownSubVoxelTranslation) {
    const Volume v = smooth({48, 40, 32});
    for (std::array<double, 3> t :
         {std::array<double, 3>{0.7, -0.4, 0.3}, {-1.25, 0.5, 0.0}, {0.0, 0.0, 0.0}}) {
        const Volume moved = cubicShifted(v, t);
        // Started half a voxel off, as the half-voxel block vectors may leave it.
        const GlobalShift g = estimateGlobalShift(moved, v, {t[0] + 0.5, t[1] - 0.5, t[2]});
        const std::array<double, 3> got = g.voxels();
        for (int c = 0; c < 3; ++c)
            EXPECT_NEAR(got[std::size_t(c)], t[std::size_t(c)], 1.0 / kGlobalShiftUnits)
                << "component " << c << " of " << t[0] << "," << t[1] << "," << t[2];
    }
}

TEST(GlobalShift, ConstantAndThinVolumesKeepTheStart) {
    Volume c({16, 16, 16}, ScalarType::UInt8);
    for (auto& x : c.values<std::uint8_t>())
        x = 7;
    EXPECT_TRUE(estimateGlobalShift(c, c, {0, 0, 0}).zero());
    // A 2-voxel-thin axis has no usable gradient: that component stays at its start (here 0).
    const Volume thin = smooth({32, 32, 2});
    const GlobalShift g = estimateGlobalShift(cubicShifted(thin, {0.5, 0, 0}), thin, {0, 0, 0});
    EXPECT_EQ(g.z, 0);
    EXPECT_NEAR(g.voxels()[0], 0.5, 1.0 / kGlobalShiftUnits);
    EXPECT_THROW(estimateGlobalShift(thin, c, {0, 0, 0}), DataError);
}

TEST(GlobalShift, LargeMotionIsClampedToTheStoredRange) {
    const Volume v = smooth({24, 24, 24});
    const GlobalShift g = estimateGlobalShift(v, v, {100, -100, 0});
    EXPECT_LE(std::abs(int(g.x)), kGlobalShiftMaxVoxels * kGlobalShiftUnits);
    EXPECT_LE(std::abs(int(g.y)), kGlobalShiftMaxVoxels * kGlobalShiftUnits);
}
