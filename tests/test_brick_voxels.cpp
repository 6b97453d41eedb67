// The reconstruction-to-voxel conversion: round to nearest even, clamp to the type, infinities to its bounds
// and NaN (a forged quantisation step) to 0 as the motion kernels give it, never through an undefined
// float-to-int conversion (fuzz_vcz found NaN reaching it).
#include "wavelet/BrickVoxels.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <limits>

using volcl::codec::toVoxel;

namespace {

template <class T> void expectNonFiniteValues() {
    constexpr float nan = std::numeric_limits<float>::quiet_NaN(),
                    inf = std::numeric_limits<float>::infinity();
    EXPECT_EQ(toVoxel<T>(nan), T(0));
    EXPECT_EQ(toVoxel<T>(-nan), T(0));
    EXPECT_EQ(toVoxel<T>(inf), std::numeric_limits<T>::max());
    EXPECT_EQ(toVoxel<T>(-inf), std::numeric_limits<T>::min());
    EXPECT_EQ(toVoxel<T>(3e38f), std::numeric_limits<T>::max());
    EXPECT_EQ(toVoxel<T>(-3e38f), std::numeric_limits<T>::min());
}

} // namespace

TEST(ToVoxel, RoundsToNearestEvenAndClampsIntegers) {
    EXPECT_EQ(toVoxel<std::uint8_t>(2.5f), 2);
    EXPECT_EQ(toVoxel<std::uint8_t>(3.5f), 4);
    EXPECT_EQ(toVoxel<std::uint8_t>(254.6f), 255);
    EXPECT_EQ(toVoxel<std::uint8_t>(255.6f), 255);
    EXPECT_EQ(toVoxel<std::uint8_t>(-0.7f), 0);
    EXPECT_EQ(toVoxel<std::int16_t>(-2.5f), -2);
    EXPECT_EQ(toVoxel<std::int16_t>(-32768.9f), -32768);
    EXPECT_EQ(toVoxel<std::uint16_t>(65535.4f), 65535);
    EXPECT_EQ(toVoxel<float>(1.25f), 1.25f);
}

TEST(ToVoxel, NanBecomesZeroAndInfinitiesTheTypesBounds) {
    expectNonFiniteValues<std::uint8_t>();
    expectNonFiniteValues<std::uint16_t>();
    expectNonFiniteValues<std::int16_t>();
}
