// EXR header check: claims a file cannot back (attribute sizes, data windows, offset tables) are refused
// before OpenEXR allocates from them; valid files pass.
#include "core/Error.hpp"
#include "host/image/ExrHeaderCheck.hpp"
#include "host/image/ImageIo.hpp"
#include "host/tf/TransferFunction.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

namespace {

namespace fs = std::filesystem;

fs::path tmpDir() {
    fs::path d = fs::path(VOLCL_TEST_TMP_DIR) / "exr-header";
    fs::create_directories(d);
    return d;
}

std::string fileBytes(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

fs::path writeBytes(const std::string& name, const std::string& bytes) {
    const fs::path p = tmpDir() / name;
    std::ofstream(p, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
    return p;
}

// A valid 16x8 RGBA float EXR written by volcl itself (zip compression: 16 lines per chunk).
std::string validExr() {
    volcl::ImageBuffer img(16, 8, {"R", "G", "B", "A"});
    for (std::size_t i = 0; i < img.pixels.size(); ++i)
        img.pixels[i] = float(i) * 0.25f;
    const fs::path p = tmpDir() / "valid.exr";
    volcl::writeImage(img, p);
    return fileBytes(p);
}

// The offset of the dataWindow attribute's 16-byte value in `exr`.
std::size_t dataWindowValue(const std::string& exr) {
    const std::string key = std::string("dataWindow") + '\0' + "box2i" + '\0';
    const std::size_t at = exr.find(key);
    EXPECT_NE(at, std::string::npos);
    return at + key.size() + 4;
}

std::string withDataWindow(std::string exr, std::int32_t x0, std::int32_t y0, std::int32_t x1,
                           std::int32_t y1) {
    const std::int32_t box[4] = {x0, y0, x1, y1};
    std::memcpy(exr.data() + dataWindowValue(exr), box, 16);
    return exr;
}

std::string refusal(const fs::path& p, std::size_t budget = 0) {
    try {
        volcl::checkExrHeaders(p, budget);
    } catch (const volcl::IoError& e) {
        return e.what();
    }
    return "";
}

TEST(ExrHeaderCheck, ValidFilesPassAndStillRead) {
    const fs::path p = writeBytes("ok.exr", validExr());
    EXPECT_EQ(refusal(p), "");
    const volcl::ImageBuffer back = volcl::readImage(p);
    EXPECT_EQ(back.width, 16);
    EXPECT_EQ(back.height, 8);
    EXPECT_FLOAT_EQ(back.pixels.back(), float(back.pixels.size() - 1) * 0.25f);
}

TEST(ExrHeaderCheck, NonExrFilesAreLeftToTheImageLibrary) {
    EXPECT_EQ(refusal(writeBytes("not.exr", "\x89PNG\r\n\x1a\n not an exr at all")), "");
    EXPECT_EQ(refusal(writeBytes("tiny.exr", "v/1")), "");
}

// The fuzzer's finding: an 812-byte file whose string attribute claims 1.5 GB made OpenEXR allocate 1.6 GB.
TEST(ExrHeaderCheck, AttributeLargerThanTheFileIsRefused) {
    const fs::path finding =
        fs::path(VOLCL_SOURCE_DIR) / "fuzz/regressions/fuzz_tf_exr/huge-string-attribute.exr";
    ASSERT_TRUE(fs::exists(finding));
    const std::string why = refusal(finding);
    EXPECT_NE(why.find(finding.string()), std::string::npos) << why;
    EXPECT_NE(why.find("claims 1543503971 bytes"), std::string::npos) << why;
    // And through the public reader, one line naming the file.
    try {
        volcl::readImage(finding, 16u << 20);
        FAIL() << "the forged EXR was read";
    } catch (const volcl::IoError& e) {
        EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos);
        EXPECT_NE(std::string(e.what()).find("corrupt EXR header"), std::string::npos) << e.what();
    }
}

TEST(ExrHeaderCheck, DataWindowTheOffsetTableCannotBackIsRefused) {
    // 16 x 10^6 lines at 16 lines per chunk need a 500 kB offset table; the file has a few hundred bytes.
    const fs::path p = writeBytes("tall.exr", withDataWindow(validExr(), 0, 0, 15, 999999));
    const std::string why = refusal(p);
    EXPECT_NE(why.find("offset tables need 500000 bytes"), std::string::npos) << why;
}

TEST(ExrHeaderCheck, DataWindowAboveTheBudgetIsRefused) {
    const fs::path p = writeBytes("wide.exr", withDataWindow(validExr(), 0, 0, 99999, 7));
    const std::string why = refusal(p, 1u << 20);
    EXPECT_NE(why.find("memory budget"), std::string::npos) << why;
    EXPECT_NE(why.find("100000x8"), std::string::npos) << why;
}

TEST(ExrHeaderCheck, EmptyOrInvertedWindowsAreRefused) {
    const std::string exr = validExr();
    EXPECT_NE(refusal(writeBytes("inverted.exr", withDataWindow(exr, 10, 0, 0, 7))).find("empty or inverted"),
              std::string::npos);
    // The extreme corners: the width is computed in double, so INT_MIN..INT_MAX does not overflow.
    const std::string why =
        refusal(writeBytes("extreme.exr", withDataWindow(exr, INT32_MIN, INT32_MIN, INT32_MAX, INT32_MAX)));
    EXPECT_NE(why.find("memory budget"), std::string::npos) << why;
}

TEST(ExrHeaderCheck, TruncatedHeadersAreRefused) {
    const std::string exr = validExr();
    const std::size_t headerEnd = dataWindowValue(exr) + 16;
    for (std::size_t cut : {std::size_t(9), std::size_t(40), headerEnd - 3}) {
        const std::string why = refusal(writeBytes("cut.exr", exr.substr(0, cut)));
        EXPECT_NE(why.find("corrupt EXR header"), std::string::npos) << "cut at " << cut << ": " << why;
    }
}

TEST(ExrHeaderCheck, NegativeAttributeSizeIsRefused) {
    std::string exr = validExr();
    const std::size_t sizeAt = dataWindowValue(exr) - 4;
    const std::int32_t negative = -16;
    std::memcpy(exr.data() + sizeAt, &negative, 4);
    EXPECT_NE(refusal(writeBytes("negative.exr", exr)).find("negative size"), std::string::npos);
}

} // namespace

// An attribute of a fixed-layout type, or a channel list, whose stated size differs from its value: OpenEXR
// reads the value's own layout and would go on from another byte than the check (a fuzzed file, kept in
// fuzz/regressions/fuzz_tf_exr, then made it allocate 846 MB for an attribute the check never saw).
TEST(ExrHeaderCheck, MisstatedAttributeSizesAreRefused) {
    const std::string exr = validExr();
    // Grows the attribute `key`'s stated size by one and inserts a zero byte after its value.
    auto grown = [&](const std::string& key, std::size_t valueBytes) {
        std::string out = exr;
        const std::size_t at = out.find(key);
        EXPECT_NE(at, std::string::npos) << key;
        std::int32_t size = 0;
        std::memcpy(&size, out.data() + at + key.size(), 4);
        EXPECT_EQ(valueBytes == 0 ? size : std::int32_t(valueBytes), size) << key;
        ++size;
        std::memcpy(out.data() + at + key.size(), &size, 4);
        out.insert(at + key.size() + 4 + std::size_t(size - 1), 1, '\0');
        return out;
    };
    const std::string compression = std::string("compression") + '\0' + "compression" + '\0';
    const std::string channels = std::string("channels") + '\0' + "chlist" + '\0';
    EXPECT_NE(
        refusal(writeBytes("compression2.exr", grown(compression, 1))).find("states 2 bytes, the type has 1"),
        std::string::npos);
    EXPECT_NE(refusal(writeBytes("chlist.exr", grown(channels, 0))).find("channel list ends 1 bytes before"),
              std::string::npos);
    for (const char* name : {"compression2.exr", "chlist.exr"})
        EXPECT_THROW(volcl::readImage(tmpDir() / name), volcl::IoError);
}

// OpenEXR sizes its decoding buffers by the chunk, not the data window: a 1-pixel-high ZIP image still gets
// 16 lines per buffer. The fuzzer's 693-byte strip (kept in fuzz/regressions/fuzz_tf_exr) claims 589,825
// half RGBA pixels per line, 9.4 MB as floats, within the strip budget of 16 MiB; decoding it took 1 GB.
TEST(ExrHeaderCheck, DecodingBuffersOfWideChunksCountAgainstTheBudget) {
    const fs::path finding =
        fs::path(VOLCL_SOURCE_DIR) / "fuzz/regressions/fuzz_tf_exr/oom-wide-zip-strip-line-buffers.exr";
    ASSERT_TRUE(fs::exists(finding));
    const std::string why = refusal(finding, 16u << 20);
    EXPECT_NE(why.find(finding.string()), std::string::npos) << why;
    EXPECT_NE(why.find("589825x1 (16 lines per chunk)"), std::string::npos) << why;
    EXPECT_NE(why.find("memory budget"), std::string::npos) << why;
    EXPECT_THROW(volcl::TransferFunction::fromFile(finding, {0.0, 1.0}), volcl::IoError);
    // Without a compression attribute OpenEXR uses its default, ZIP (16 lines): a 311-byte file claiming a
    // 132,736-pixel strip passed as uncompressed (1 line) and decoded into a TF whose 256^2 table took 15 s.
    const fs::path noCompression =
        fs::path(VOLCL_SOURCE_DIR) /
        "fuzz/regressions/fuzz_tf_exr/timeout-zip-strip-without-compression-attribute.exr";
    ASSERT_TRUE(fs::exists(noCompression));
    EXPECT_NE(refusal(noCompression, 34u << 20).find("132736x1 (16 lines per chunk)"), std::string::npos);

    // A valid 40000x1 RGBA float strip, ZIP-compressed as volcl writes EXR: 1.28 MB of pixels (as stored and
    // as floats), 10.24 MB per 16-line chunk.
    volcl::ImageBuffer strip(40000, 1, {"R", "G", "B", "A"});
    for (std::size_t i = 0; i < strip.pixels.size(); ++i)
        strip.pixels[i] = float(i % 1000) / 1000.0f;
    const fs::path wide = tmpDir() / "wide-strip.exr";
    volcl::writeImage(strip, wide);
    const std::size_t pixels = 2 * 40000 * 16, chunk = 40000 * 16 * 16;
    EXPECT_NE(refusal(wide, pixels + chunk).find("16 lines per chunk"), std::string::npos);
    EXPECT_EQ(refusal(wide, pixels + 4 * chunk), "");
    const volcl::ImageBuffer back = volcl::readImage(wide, pixels + 4 * chunk);
    ASSERT_EQ(back.pixels.size(), strip.pixels.size());
    EXPECT_EQ(back.pixels, strip.pixels);
}

// Read as stored, then converted: 8-bit PNG values become v / 255 and half EXR values their float value,
// as OpenImageIO's own conversion gives them.
TEST(ExrHeaderCheck, StoredTypesAreConvertedToFloat) {
    volcl::ImageBuffer img(7, 3, {"R", "G", "B", "A"});
    for (std::size_t i = 0; i < img.pixels.size(); ++i)
        img.pixels[i] = float(i) / float(img.pixels.size());
    const fs::path half = tmpDir() / "half.exr", png = tmpDir() / "eight-bit.png";
    volcl::writeImage(img, half, {.halfFloat = true});
    volcl::writeImage(img, png);
    const volcl::ImageBuffer h = volcl::readImage(half), p = volcl::readImage(png);
    ASSERT_EQ(h.pixels.size(), img.pixels.size());
    ASSERT_EQ(p.pixels.size(), img.pixels.size());
    for (std::size_t i = 0; i < img.pixels.size(); ++i) {
        EXPECT_NEAR(h.pixels[i], img.pixels[i], 1e-3f) << i;
        EXPECT_FLOAT_EQ(p.pixels[i] * 255.0f, std::round(p.pixels[i] * 255.0f)) << i;
        EXPECT_NEAR(p.pixels[i], img.pixels[i], 0.5f / 255.0f + 1e-6f) << i;
    }
}
