// Global sub-voxel translation: the Keys-cubic shift (exact for whole voxels, independent of the thread
// count, the synthetic series' resampler) and the Lucas-Kanade estimate of a known translation.
#include "TestUtil.hpp"
#include "core/Error.hpp"
#include "wavelet/predict/GlobalShift.hpp"
#include "wavelet/predict/TranslatedSeries.hpp"

#include <array>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

using namespace volcl;

namespace {

Volume smooth(Dims d) {
    return test::makeFloatVolume(d, [](double x, double y, double z) {
        return 100 + 40 * std::sin(0.31 * x) * std::cos(0.23 * y) + 30 * std::exp(-0.02 * (z - 9) * (z - 9)) +
               0.5 * x * y / 10;
    });
}

// The shift written the plain way: every tap clamped, one axis after another over doubles, each voxel's sum
// 0 + w0 a0 + w1 a1 + w2 a2 + w3 a3 in that order, then rounded to float. cubicShifted must give the same
// bits (decoders of existing files rebuild the encoder's prediction from it).
Volume plainShifted(const Volume& v, std::array<double, 3> shift) {
    const Dims d = v.dims();
    const std::vector<float> f = v.toFloat();
    std::vector<double> a(f.begin(), f.end());
    const std::size_t n[3] = {d.x, d.y, d.z}, stride[3] = {1, d.x, d.x * d.y};
    for (int axis = 0; axis < 3; ++axis) {
        if (shift[std::size_t(axis)] == 0) continue;
        const double start = -shift[std::size_t(axis)], fl = std::floor(start), t = start - fl;
        auto keys = [](double u) {
            u = std::abs(u);
            if (u < 1) return 1.5 * u * u * u - 2.5 * u * u + 1;
            if (u < 2) return -0.5 * u * u * u + 2.5 * u * u - 4 * u + 2;
            return 0.0;
        };
        const double w[4] = {keys(1 + t), keys(t), keys(1 - t), keys(2 - t)};
        const std::vector<double> src = a;
        for (std::size_t i = 0; i < a.size(); ++i) {
            const std::size_t pos = (i / stride[axis]) % n[axis], rest = i - pos * stride[axis];
            double acc = 0;
            for (int k = 0; k < 4; ++k) {
                const long p = std::clamp<long>(long(pos) + long(fl) - 1 + k, 0, long(n[axis]) - 1);
                acc += w[k] * src[rest + std::size_t(p) * stride[axis]];
            }
            a[i] = acc;
        }
    }
    Volume out(d, ScalarType::Float32);
    for (std::size_t i = 0; i < a.size(); ++i)
        out.values<float>()[i] = static_cast<float>(a[i]);
    return out;
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

// The fast path (rows read as stored, unclamped interiors, the z pass writing floats) against the plain one:
// every voxel type, lines shorter than the four taps, zero components, shifts past the edge, 1 and 3 threads.
TEST(GlobalShift, FastShiftGivesThePlainShiftsBits) {
    std::mt19937 rng(11);
    const std::array<Dims, 5> dims = {Dims{1, 1, 1}, Dims{2, 3, 5}, Dims{7, 1, 9}, Dims{33, 17, 9},
                                      Dims{64, 5, 3}};
    const std::array<std::array<double, 3>, 6> shifts = {{{0, 0, 0},
                                                          {0.40625, -0.28125, 0.15625},
                                                          {2.5, -3.75, 0},
                                                          {-16, 16, 0.03125},
                                                          {0, 0.5, -0.96875},
                                                          {40.25, -40.5, 3.0}}};
    for (const ScalarType type :
         {ScalarType::UInt8, ScalarType::UInt16, ScalarType::Int16, ScalarType::Float32})
        for (const Dims& d : dims) {
            Volume v(d, type);
            for (std::size_t i = 0; i < v.voxelCount(); ++i) {
                const std::uint32_t r = rng();
                switch (type) {
                case ScalarType::UInt8:
                    v.values<std::uint8_t>()[i] = std::uint8_t(r);
                    break;
                case ScalarType::UInt16:
                    v.values<std::uint16_t>()[i] = std::uint16_t(r);
                    break;
                case ScalarType::Int16:
                    v.values<std::int16_t>()[i] = std::int16_t(r);
                    break;
                case ScalarType::Float32:
                    v.values<float>()[i] = float(std::ldexp(double(r) - 2e9, -int(r % 40)));
                    break;
                }
            }
            for (const auto& s : shifts) {
                const Volume want = plainShifted(v, s);
                for (const unsigned threads : {1u, 3u}) {
                    const Volume got = cubicShifted(v, s, threads);
                    ASSERT_EQ(got.type(), ScalarType::Float32);
                    ASSERT_EQ(std::memcmp(got.bytes().data(), want.bytes().data(), want.byteSize()), 0)
                        << scalarTypeName(type) << " " << d.x << "x" << d.y << "x" << d.z << " shift " << s[0]
                        << "," << s[1] << "," << s[2] << " threads " << threads;
                }
            }
        }
}
