// The streaming encoder against the in-memory one: a volume coded brick row by brick row gives the same
// .vcz bytes but for the preamble's padding (statistics included) for ragged edges, uint8 and uint16; a
// cloud generated piece by piece equals the whole cloud; options the stream cannot code are refused.
#include "TestUtil.hpp"
#include "VczTestUtil.hpp"

#include "core/Error.hpp"
#include "host/phantoms/Cloud.hpp"
#include "wavelet/Codec.hpp"
#include "wavelet/container/LodStatistics.hpp"
#include "wavelet/stream/StreamEncoder.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <sstream>

using namespace volcl;

namespace {

// A source reading boxes out of a volume held in memory (the reference needs the whole volume anyway).
VolumeSource sourceOf(const Volume& v) {
    VolumeSource s;
    s.dims = v.dims();
    s.type = v.type();
    s.spacing = v.spacing;
    s.origin = v.origin;
    s.fill = [&v](Dims lo, Volume& out) {
        const Dims d = out.dims();
        out = v.cropped(lo, {lo.x + d.x, lo.y + d.y, lo.z + d.z});
    };
    return s;
}

std::vector<std::byte> streamed(const Volume& v, const CodecOptions& o, bool stats,
                                StreamEncodeReport* r = nullptr) {
    std::stringstream out(std::ios::in | std::ios::out | std::ios::binary);
    const StreamEncodeReport rep =
        encodeStreaming(test::computeContext(), sourceOf(v), o, stats, out, "stream.vcz");
    if (r) *r = rep;
    const std::string s = out.str();
    std::vector<std::byte> bytes(s.size());
    std::memcpy(bytes.data(), s.data(), s.size());
    return bytes;
}

std::vector<std::byte> inMemory(const Volume& v, const CodecOptions& o, bool stats) {
    std::vector<std::byte> b = encodeVolume(test::computeContext(), v, o);
    return stats ? addLodStatistics(test::computeContext(), std::move(b), std::span(&v, 1), "memory.vcz") : b;
}

CloudParams smallCloud() {
    CloudParams p;
    p.dims = {70, 45, 38}; // ragged against 16^3 bricks on every axis
    p.frequency = 3;
    return p;
}

} // namespace

TEST(StreamEncode, CloudRegionsEqualTheWholeCloud) {
    const CloudParams p = smallCloud();
    const Volume whole = generateCloud(p);
    Volume part({23, 17, 9}, ScalarType::UInt8);
    generateCloudRegion(p, {40, 20, 25}, part);
    Volume crop = whole.cropped({40, 20, 25}, {63, 37, 34});
    crop.origin = part.origin;
    EXPECT_TRUE(crop == part);
}

TEST(StreamEncode, ByteIdenticalToTheInMemoryEncoderButForPadding) {
    Volume cloud = generateCloud(smallCloud());
    cloud.spacing = {0.5, 1.0, 2.0};
    cloud.origin = {-3.0, 4.0, 1.5};
    CodecOptions o;
    o.brick = {16, 16, 16};
    o.levels = 3;
    o.metadata["note"] = "kept";
    StreamEncodeReport r;
    const std::vector<std::byte> s = streamed(cloud, o, true, &r);
    EXPECT_EQ(r.rows, 3u * 3u); // ceil(45/16) x ceil(38/16)
    EXPECT_EQ(r.rowBytes, 70u * 16u * 16u);
    EXPECT_EQ(r.bytes, s.size());
    // The streamed preamble is padded to the room reserved before coding; without it the files are equal.
    EXPECT_TRUE(test::rewrittenVcz(s, "s.vcz") == inMemory(cloud, o, true));
    EXPECT_TRUE(test::rewrittenVcz(streamed(cloud, o, false), "s.vcz") == inMemory(cloud, o, false));

    // uint16 with the fast entropy coder and a non-cubic brick: still the same file, and it decodes exactly.
    Volume wide(cloud.dims(), ScalarType::UInt16);
    for (std::size_t i = 0; i < cloud.voxelCount(); ++i)
        wide.values<std::uint16_t>()[i] = std::uint16_t(cloud.values<std::uint8_t>()[i] * 257 + i % 7);
    o.entropy = EntropyMode::Fast;
    o.brick = {32, 16, 8};
    const std::vector<std::byte> s16 = streamed(wide, o, true);
    EXPECT_TRUE(test::rewrittenVcz(s16, "s16.vcz") == inMemory(wide, o, true));
    EXPECT_TRUE(decodeVolume(test::computeContext(), s16) == wide);
}

TEST(StreamEncode, OneBrickAndRefusals) {
    const Volume v = generateCloud({.dims = {9, 5, 3}});
    CodecOptions o;
    o.brick = {16, 16, 16};
    EXPECT_TRUE(test::rewrittenVcz(streamed(v, o, true), "one.vcz") == inMemory(v, o, true));
    o.rate = RateMode::MaxError;
    o.target = 2;
    EXPECT_THROW(streamed(v, o, true), UsageError);
    Volume f(v.dims(), ScalarType::Float32);
    EXPECT_THROW(streamed(f, CodecOptions{}, true), UsageError);
}
