// Volume model: layout, types, conversion, cropping, statistics, series validation.
#include "core/Error.hpp"
#include "core/Volume.hpp"
#include "core/ZeroedBytes.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

using namespace volcl;

TEST(Volume, XFastestLayoutAndTypedAccess) {
    Volume v({3, 4, 5}, ScalarType::UInt16);
    EXPECT_EQ(v.voxelCount(), 60u);
    EXPECT_EQ(v.byteSize(), 120u);
    EXPECT_EQ(v.index(1, 0, 0), 1u);
    EXPECT_EQ(v.index(0, 1, 0), 3u);
    EXPECT_EQ(v.index(0, 0, 1), 12u);
    v.values<std::uint16_t>()[v.index(2, 3, 4)] = 65535;
    EXPECT_EQ(v.valueAt(59), 65535.0);
    EXPECT_THROW(v.values<float>(), DataError);
}

// Small blocks come from the heap, large ones from mapped pages: both must start zero and behave as values.
TEST(ZeroedBytes, SmallAndMappedBlocksAreZeroAndCopyDeeply) {
    for (std::size_t size :
         {std::size_t(1), std::size_t(4097), kHugePageBytes - 1, kHugePageBytes, 3 * kHugePageBytes + 5}) {
        ZeroedBytes b(size);
        ASSERT_EQ(b.size(), size);
        EXPECT_TRUE(std::all_of(b.data(), b.data() + size, [](std::byte v) { return v == std::byte{0}; }))
            << size;
        if (size >= kHugePageBytes)
            EXPECT_EQ(reinterpret_cast<std::uintptr_t>(b.data()) % kHugePageBytes, 0u);
        b.data()[size - 1] = std::byte{9};
        ZeroedBytes c(b);
        EXPECT_TRUE(c == b);
        c.data()[size - 1] = std::byte{1};
        EXPECT_FALSE(c == b);
        EXPECT_EQ(b.data()[size - 1], std::byte{9}); // the copy owns its own memory
        ZeroedBytes moved(std::move(c));
        EXPECT_TRUE(c.empty());
        EXPECT_EQ(moved.data()[size - 1], std::byte{1});
        moved = b; // copy-assign over a block of the same size
        EXPECT_TRUE(moved == b);
        moved = ZeroedBytes(3);
        EXPECT_EQ(moved.size(), 3u);
    }
    EXPECT_TRUE(ZeroedBytes() == ZeroedBytes(0));
}

TEST(Volume, LargeVolumesStartZero) {
    Volume v({256, 256, 33}, ScalarType::Float32); // 8.6 MB: mapped pages
    const auto f = v.values<float>();
    EXPECT_TRUE(std::all_of(f.begin(), f.end(), [](float x) { return x == 0.0f; }));
    Volume w = v;
    w.values<float>()[5] = 1.0f;
    EXPECT_FALSE(w == v);
    EXPECT_EQ(v.values<float>()[5], 0.0f);
}

TEST(Volume, DefaultsAreOriginZeroSpacingOne) {
    Volume v({1, 1, 1}, ScalarType::Float32);
    EXPECT_EQ(v.spacing, (std::array<double, 3>{1, 1, 1}));
    EXPECT_EQ(v.origin, (std::array<double, 3>{0, 0, 0}));
}

TEST(Volume, RefusesZeroAndOverflowingDims) {
    EXPECT_THROW(Volume({0, 1, 1}, ScalarType::UInt8), DataError);
    EXPECT_THROW(Volume({1, 0, 1}, ScalarType::UInt8), DataError);
    std::size_t huge = std::size_t(1) << 40;
    EXPECT_THROW(Volume({huge, huge, huge}, ScalarType::Float32), DataError);
}

TEST(Volume, ConversionClampsAndRounds) {
    Volume f({4, 1, 1}, ScalarType::Float32);
    auto v = f.values<float>();
    v[0] = -5.0f;
    v[1] = 2.5f;
    v[2] = 300.7f;
    v[3] = std::numeric_limits<float>::quiet_NaN();
    Volume u = f.convertedTo(ScalarType::UInt8);
    auto out = u.values<std::uint8_t>();
    EXPECT_EQ(out[0], 0);
    EXPECT_EQ(out[1], 2); // nearbyint: ties to even
    EXPECT_EQ(out[2], 255);
    EXPECT_EQ(out[3], 0);
    Volume s = f.convertedTo(ScalarType::Int16);
    EXPECT_EQ(s.values<std::int16_t>()[0], -5);
}

TEST(Volume, IntegerToFloatAndBackIsExact) {
    Volume a({7, 3, 2}, ScalarType::Int16);
    auto v = a.values<std::int16_t>();
    for (std::size_t i = 0; i < v.size(); ++i)
        v[i] = std::int16_t(int(i * 797) % 65536 - 32768);
    EXPECT_EQ(a.convertedTo(ScalarType::Float32).convertedTo(ScalarType::Int16), a);
}

TEST(Volume, CropMovesOriginAndCopiesRows) {
    Volume a({4, 3, 2}, ScalarType::UInt8);
    auto v = a.values<std::uint8_t>();
    for (std::size_t i = 0; i < v.size(); ++i)
        v[i] = std::uint8_t(i);
    a.spacing = {0.5, 2, 3};
    Volume c = a.cropped({1, 1, 1}, {3, 3, 2});
    EXPECT_EQ(c.dims(), (Dims{2, 2, 1}));
    EXPECT_EQ(c.origin, (std::array<double, 3>{0.5, 2, 3}));
    EXPECT_EQ(c.values<std::uint8_t>()[0], a.values<std::uint8_t>()[a.index(1, 1, 1)]);
    EXPECT_EQ(c.values<std::uint8_t>()[3], a.values<std::uint8_t>()[a.index(2, 2, 1)]);
    EXPECT_THROW(a.cropped({0, 0, 0}, {5, 1, 1}), UsageError);
    EXPECT_THROW(a.cropped({2, 0, 0}, {2, 1, 1}), UsageError);
}

TEST(Volume, StatsSkipNonFiniteAndFillHistogram) {
    Volume f({5, 1, 1}, ScalarType::Float32);
    auto v = f.values<float>();
    v[0] = 0;
    v[1] = 10;
    v[2] = 5;
    v[3] = NAN;
    v[4] = INFINITY;
    VolumeStats s = f.stats(2);
    EXPECT_EQ(s.min, 0);
    EXPECT_EQ(s.max, 10);
    EXPECT_DOUBLE_EQ(s.mean, 5);
    EXPECT_EQ(s.nanCount, 1u);
    EXPECT_EQ(s.infCount, 1u);
    ASSERT_EQ(s.histogram.size(), 2u);
    EXPECT_EQ(s.histogram[0] + s.histogram[1], 3u);
}

TEST(Volume, ConstantVolumeStats) {
    Volume c({2, 2, 2}, ScalarType::UInt8);
    VolumeStats s = c.stats(4);
    EXPECT_EQ(s.min, 0);
    EXPECT_EQ(s.max, 0);
    EXPECT_EQ(s.stddev, 0);
    EXPECT_EQ(s.histogram[0], 8u);
}

TEST(Volume, ParseScalarTypeNames) {
    EXPECT_EQ(parseScalarType("uchar"), ScalarType::UInt8);
    EXPECT_EQ(parseScalarType("UINT16"), ScalarType::UInt16);
    EXPECT_EQ(parseScalarType("short"), ScalarType::Int16);
    EXPECT_EQ(parseScalarType("float"), ScalarType::Float32);
    EXPECT_EQ(parseScalarType("double"), ScalarType::Float64);
    EXPECT_EQ(parseScalarType("f64"), ScalarType::Float64);
    EXPECT_THROW(parseScalarType("int64"), UsageError);
}

TEST(TimeSeries, ValidatesGrid) {
    TimeSeries ts;
    EXPECT_THROW(ts.validate(), DataError);
    ts.frames.emplace_back(Dims{2, 2, 2}, ScalarType::UInt8);
    ts.frames.emplace_back(Dims{2, 2, 2}, ScalarType::UInt8);
    EXPECT_NO_THROW(ts.validate());
    ts.frames[1].spacing[0] = 2;
    EXPECT_THROW(ts.validate(), DataError);
    ts.frames[1].spacing[0] = 1;
    ts.times = {0.0};
    EXPECT_THROW(ts.validate(), DataError);
}
