// Phantom kernels against their double-precision references, including degenerate sizes.
#include "TestUtil.hpp"
#include "host/phantoms/Phantoms.hpp"

#include <cmath>

using namespace volcl;

namespace {
// Tolerance: float sin/cos on arguments up to 2*pi*fM (~38): a few ulp of the argument.
constexpr double kMarschnerLobbTolerance = 1e-5;
} // namespace

class MarschnerLobbSizes : public ::testing::TestWithParam<Dims> {};

TEST_P(MarschnerLobbSizes, KernelMatchesReference) {
    Dims d = GetParam();
    Volume gpu = generateMarschnerLobb(test::computeContext(), d);
    Volume ref = marschnerLobbReference(d);
    auto a = gpu.values<float>();
    auto b = ref.values<float>();
    double maxErr = 0;
    for (std::size_t i = 0; i < a.size(); ++i) {
        ASSERT_TRUE(std::isfinite(a[i]));
        ASSERT_GE(a[i], -1e-6f);
        ASSERT_LE(a[i], 1.0f + 1e-6f);
        maxErr = std::max(maxErr, std::abs(double(a[i]) - double(b[i])));
    }
    EXPECT_LE(maxErr, kMarschnerLobbTolerance);
}

INSTANTIATE_TEST_SUITE_P(Phantoms, MarschnerLobbSizes,
                         ::testing::Values(Dims{1, 1, 1}, Dims{41, 41, 41}, Dims{17, 3, 29}, Dims{1, 64, 1},
                                           Dims{100, 7, 2}));

TEST(MarschnerLobb, AnalyticValues) {
    // Centre axis r = 0: cos(2 pi fM cos 0) = cos(12 pi) = 1; z = 0: sin 0 = 0 -> (1 + 2 alpha) / (2 + 2 alpha).
    EXPECT_NEAR(marschnerLobbValue(0, 0, 0), 1.5 / 2.5, 1e-15);
    // z = 1: 1 - sin(pi/2) = 0 -> alpha * 2 / 2.5 = 0.2.
    EXPECT_NEAR(marschnerLobbValue(0, 0, 1), 0.2, 1e-15);
}

class SheppLoganSizes : public ::testing::TestWithParam<Dims> {};

TEST_P(SheppLoganSizes, KernelMatchesReferenceOffSurfaces) {
    Dims d = GetParam();
    Volume gpu = generateSheppLogan(test::computeContext(), d);
    Volume ref = sheppLoganReference(d);
    auto a = gpu.values<float>();
    auto b = ref.values<float>();
    std::size_t surface = 0;
    for (std::size_t k = 0; k < d.z; ++k)
        for (std::size_t j = 0; j < d.y; ++j)
            for (std::size_t i = 0; i < d.x; ++i) {
                std::size_t n = gpu.index(i, j, k);
                ASSERT_TRUE(std::isfinite(a[n]));
                ASSERT_GE(a[n], -1e-6f);
                ASSERT_LE(a[n], 1.0f + 1e-6f);
                double margin = sheppLoganBoundaryMargin(phantomCoordinate(i, d.x), phantomCoordinate(j, d.y),
                                                         phantomCoordinate(k, d.z));
                if (margin <= 1e-5) {
                    ++surface;
                    continue; // on a surface float and double may classify differently
                }
                ASSERT_NEAR(a[n], b[n], 1e-6) << "voxel " << i << "," << j << "," << k;
            }
    EXPECT_LT(surface, std::max<std::size_t>(1, a.size() / 1000)) << "surface voxels must be rare";
}

INSTANTIATE_TEST_SUITE_P(Phantoms, SheppLoganSizes,
                         ::testing::Values(Dims{1, 1, 1}, Dims{64, 64, 64}, Dims{31, 47, 13},
                                           Dims{128, 1, 1}));

TEST(SheppLogan, KnownRegions) {
    Volume ref = sheppLoganReference({65, 65, 65});
    auto v = ref.values<float>();
    // Outside the skull: 0. Centre of the brain (inside ellipsoids 1 and 2 only): 1 - 0.8 = 0.2.
    EXPECT_EQ(v[ref.index(0, 0, 0)], 0.0f);
    EXPECT_NEAR(v[ref.index(32, 32, 32)], 0.2f, 1e-6);
}
