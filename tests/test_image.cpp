// Image I/O tests: EXR channels and attributes, half option, 8-bit PNG, atomic failures, sRGB display
// encoding.
#include "core/Error.hpp"
#include "host/image/ImageIo.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <csignal>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>

#include <sys/resource.h>

namespace {

namespace fs = std::filesystem;
using volcl::ImageBuffer;

fs::path tmpDir() {
    fs::path d = fs::path(VOLCL_TEST_TMP_DIR) / "image";
    fs::create_directories(d);
    return d;
}

std::string fileText(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// Names of the files in a directory (to check that no temporary stays behind).
std::vector<std::string> listing(const fs::path& d) {
    std::vector<std::string> out;
    for (const auto& e : fs::directory_iterator(d))
        out.push_back(e.path().filename().string());
    std::sort(out.begin(), out.end());
    return out;
}

ImageBuffer pattern(int w, int h, std::vector<std::string> channels) {
    ImageBuffer img(w, h, std::move(channels));
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < img.channelCount(); ++c)
                img.at(x, y, c) =
                    0.001f * float(x) - 0.37f * float(y) + 10.0f * float(c) + 1e-7f * float(x * y);
    return img;
}

TEST(ImageIo, ExrRoundTripKeepsChannelsPixelsAndAttributes) {
    ImageBuffer img = pattern(7, 3, {"R", "G", "B", "A", "depth"});
    img.at(6, 2, 4) = std::numeric_limits<float>::infinity(); // "no hit" depth survives as-is
    img.attributes.push_back({"volcl:method", std::string("exact")});
    img.attributes.push_back({"volcl:step", 0.25f});
    img.attributes.push_back({"volcl:lengths", 16});
    img.attributes.push_back({"volcl:domain", std::array<float, 2>{-3.5f, 1024.0f}});
    img.attributes.push_back({"volcl:tf", std::string(R"({"domain": [0, 1], "color": []})")});
    const fs::path path = tmpDir() / "roundtrip.exr";
    volcl::writeImage(img, path);
    ImageBuffer back = volcl::readImage(path);
    EXPECT_EQ(back.width, 7);
    EXPECT_EQ(back.height, 3);
    EXPECT_EQ(back.channels, img.channels);
    ASSERT_EQ(back.pixels.size(), img.pixels.size());
    for (std::size_t i = 0; i < img.pixels.size(); ++i)
        EXPECT_EQ(back.pixels[i], img.pixels[i]) << i;

    const auto* method = back.findAttribute("volcl:method");
    ASSERT_NE(method, nullptr);
    EXPECT_EQ(std::get<std::string>(method->value), "exact");
    const auto* step = back.findAttribute("volcl:step");
    ASSERT_NE(step, nullptr);
    EXPECT_EQ(std::get<float>(step->value), 0.25f);
    const auto* lengths = back.findAttribute("volcl:lengths");
    ASSERT_NE(lengths, nullptr);
    EXPECT_EQ(std::get<int>(lengths->value), 16);
    const auto* domain = back.findAttribute("volcl:domain");
    ASSERT_NE(domain, nullptr);
    EXPECT_EQ((std::get<std::array<float, 2>>(domain->value)), (std::array<float, 2>{-3.5f, 1024.0f}));
    const auto* tf = back.findAttribute("volcl:tf");
    ASSERT_NE(tf, nullptr);
    EXPECT_EQ(std::get<std::string>(tf->value), R"({"domain": [0, 1], "color": []})");
    EXPECT_EQ(back.findAttribute("volcl:absent"), nullptr);
}

TEST(ImageIo, HalfOptionStoresHalfPrecision) {
    ImageBuffer img = pattern(64, 64, {"R", "G", "B", "A"});
    img.at(0, 0, 0) = 0.5f;
    img.at(1, 0, 0) = 65504.0f;
    const fs::path full = tmpDir() / "full.exr";
    const fs::path half = tmpDir() / "half.exr";
    volcl::writeImage(img, full);
    volcl::writeImage(img, half, {.halfFloat = true});
    ImageBuffer back = volcl::readImage(half);
    EXPECT_EQ(back.at(0, 0, 0), 0.5f);
    EXPECT_EQ(back.at(1, 0, 0), 65504.0f);
    bool anyRounded = false;
    for (std::size_t i = 0; i < img.pixels.size(); ++i) {
        const float a = img.pixels[i], b = back.pixels[i];
        EXPECT_LE(std::abs(a - b), std::abs(a) * (1.0f / 2048.0f) + 6e-8f) << i;
        anyRounded |= a != b;
    }
    EXPECT_TRUE(anyRounded) << "half file holds full floats";
    EXPECT_LT(fs::file_size(half), fs::file_size(full));

    // A value half cannot hold is refused, and the existing file stays as it was.
    const std::string before = fileText(half);
    img.at(3, 3, 1) = 1e6f;
    EXPECT_THROW(volcl::writeImage(img, half, {.halfFloat = true}), volcl::DataError);
    EXPECT_EQ(fileText(half), before);
}

TEST(ImageIo, PngIsEightBitClampedAndRounded) {
    ImageBuffer img(5, 2, {"R", "G", "B", "A"});
    for (int x = 0; x < 5; ++x)
        for (int c = 0; c < 4; ++c)
            img.at(x, 0, c) = float(x * 60 + c) / 255.0f;
    img.at(0, 1, 0) = -3.0f;
    img.at(1, 1, 0) = 7.0f;
    img.at(2, 1, 0) = std::numeric_limits<float>::quiet_NaN();
    img.at(3, 1, 0) = 0.5f; // 127.5 rounds to 128
    const fs::path path = tmpDir() / "eight.png";
    volcl::writeImage(img, path);
    ImageBuffer back = volcl::readImage(path);
    ASSERT_EQ(back.channelCount(), 4);
    for (int x = 0; x < 5; ++x)
        for (int c = 0; c < 4; ++c)
            EXPECT_NEAR(back.at(x, 0, c), float(x * 60 + c) / 255.0f, 1e-7f);
    EXPECT_EQ(back.at(0, 1, 0), 0.0f);
    EXPECT_EQ(back.at(1, 1, 0), 1.0f);
    EXPECT_EQ(back.at(2, 1, 0), 0.0f);
    EXPECT_NEAR(back.at(3, 1, 0), 128.0f / 255.0f, 1e-7f);

    ImageBuffer gray(3, 1, {"Y"});
    gray.at(1, 0, 0) = 1.0f;
    volcl::writeImage(gray, tmpDir() / "gray.png");
    EXPECT_EQ(volcl::readImage(tmpDir() / "gray.png").at(1, 0, 0), 1.0f);
    ImageBuffer five(2, 2, {"R", "G", "B", "A", "Z"});
    EXPECT_THROW(volcl::writeImage(five, tmpDir() / "five.png"), volcl::UsageError);
}

TEST(ImageIo, FailedWritesLeaveNothingBehind) {
    const fs::path dir = tmpDir() / "atomic";
    fs::remove_all(dir);
    fs::create_directories(dir);
    ImageBuffer img = pattern(4, 4, {"R", "G", "B", "A"});
    // Missing directory.
    EXPECT_THROW(volcl::writeImage(img, dir / "no-such-dir" / "x.exr"), volcl::IoError);
    // Unsupported format.
    EXPECT_THROW(volcl::writeImage(img, dir / "x.bmp"), volcl::UsageError);
    // A directory sits where the file should go: the rename fails and the temporary is removed.
    fs::create_directories(dir / "taken.exr" / "inside");
    EXPECT_THROW(volcl::writeImage(img, dir / "taken.exr"), volcl::IoError);
    EXPECT_TRUE(fs::is_directory(dir / "taken.exr" / "inside"));
    // Inconsistent buffer.
    ImageBuffer broken = img;
    broken.pixels.pop_back();
    EXPECT_THROW(volcl::writeImage(broken, dir / "broken.exr"), volcl::UsageError);
    EXPECT_EQ(listing(dir), std::vector<std::string>{"taken.exr"});
}

// OpenImageIO's own file writes do not report a short write: a PNG cut by a full disk or the file size
// limit became a 0-byte or truncated file and success. Now the cut fails the write, the old file stays
// and no temporary remains.
TEST(ImageIo, WritesCutShortByTheFileSizeLimitFail) {
    const fs::path dir = tmpDir() / "size-limit";
    fs::remove_all(dir);
    fs::create_directories(dir);
    ImageBuffer noise(128, 128, {"R", "G", "B", "A"}); // does not compress: about 64 KB as PNG
    std::uint32_t state = 12345;
    for (float& v : noise.pixels) {
        state = state * 1664525u + 1013904223u;
        v = float(state >> 8) / float(1u << 24);
    }
    for (const char* name : {"keep.png", "keep.exr"}) {
        std::ofstream(dir / name) << "previous";
        struct rlimit old {};
        ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &old), 0);
        const auto oldHandler = std::signal(SIGXFSZ, SIG_IGN);
        struct rlimit small = old;
        small.rlim_cur = 16384;
        ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &small), 0);
        bool refused = false;
        try {
            volcl::writeImage(noise, dir / name);
        } catch (const volcl::IoError& e) {
            refused = std::string(e.what()).find(name) != std::string::npos;
        }
        ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &old), 0);
        std::signal(SIGXFSZ, oldHandler);
        EXPECT_TRUE(refused) << name;
        EXPECT_EQ(fileText(dir / name), "previous") << name;
    }
    EXPECT_EQ(listing(dir), (std::vector<std::string>{"keep.exr", "keep.png"}));
    // Without the limit both are written whole and read back.
    volcl::writeImage(noise, dir / "keep.png");
    EXPECT_EQ(volcl::readImage(dir / "keep.png").width, 128);
}

TEST(ImageIo, UnreadableFilesAreRefused) {
    const fs::path dir = tmpDir();
    EXPECT_THROW(volcl::readImage(dir / "missing.exr"), volcl::IoError);
    {
        std::ofstream out(dir / "garbage.exr", std::ios::binary);
        out << "this is not an image at all, just some text that pretends to be one";
    }
    EXPECT_THROW(volcl::readImage(dir / "garbage.exr"), volcl::IoError);
    // A truncated EXR: the header survives, the pixel data does not.
    volcl::writeImage(pattern(64, 64, {"R", "G", "B", "A"}), dir / "whole.exr");
    const std::string whole = fileText(dir / "whole.exr");
    {
        std::ofstream out(dir / "truncated.exr", std::ios::binary);
        out.write(whole.data(), static_cast<std::streamsize>(whole.size() / 2));
    }
    EXPECT_THROW(volcl::readImage(dir / "truncated.exr"), volcl::IoError);
}

// The extension picks the one reader: a file it does not parse is corrupt, even when another format would
// read it (OpenImageIO's open() tries every format in turn, dozens of opens for one garbage file).
TEST(ImageIo, TheExtensionChoosesTheReader) {
    const fs::path dir = tmpDir();
    volcl::writeImage(pattern(8, 4, {"R", "G", "B", "A"}), dir / "real.exr");
    fs::copy_file(dir / "real.exr", dir / "exr-named.png", fs::copy_options::overwrite_existing);
    fs::copy_file(dir / "real.exr", dir / "UPPER.EXR", fs::copy_options::overwrite_existing);
    fs::copy_file(dir / "real.exr", dir / "no-extension", fs::copy_options::overwrite_existing);
    EXPECT_EQ(volcl::readImage(dir / "UPPER.EXR").width, 8);
    for (const char* name : {"exr-named.png", "no-extension"}) {
        try {
            (void)volcl::readImage(dir / name);
            ADD_FAILURE() << name << " was read";
        } catch (const volcl::IoError& e) {
            const std::string what = e.what();
            EXPECT_NE(what.find(name), std::string::npos) << what;
            EXPECT_EQ(what.find('\n'), std::string::npos) << what;
        }
    }
}

TEST(ImageIo, ImageBufferRefusesEmptyShapes) {
    EXPECT_THROW(ImageBuffer(0, 4, {"R"}), volcl::UsageError);
    EXPECT_THROW(ImageBuffer(4, -1, {"R"}), volcl::UsageError);
    EXPECT_THROW(ImageBuffer(4, 4, {}), volcl::UsageError);
    ImageBuffer one(1, 1, {"A"});
    EXPECT_EQ(one.pixels.size(), 1u);
}

double srgbReference(double x) {
    return x <= 0.0031308 ? 12.92 * x : 1.055 * std::pow(x, 1.0 / 2.4) - 0.055;
}

TEST(ImageIo, LinearToSrgbIsTheExactPiecewiseCurve) {
    EXPECT_EQ(volcl::linearToSrgb(0.0f), 0.0f);
    EXPECT_EQ(volcl::linearToSrgb(1.0f), 1.0f);
    EXPECT_EQ(volcl::linearToSrgb(-1.0f), 0.0f);
    EXPECT_EQ(volcl::linearToSrgb(5.0f), 1.0f);
    EXPECT_EQ(volcl::linearToSrgb(std::numeric_limits<float>::quiet_NaN()), 0.0f);
    EXPECT_EQ(volcl::linearToSrgb(std::numeric_limits<float>::infinity()), 1.0f);
    for (int i = 0; i <= 10000; ++i) {
        const float x = float(i) / 10000.0f;
        EXPECT_NEAR(volcl::linearToSrgb(x), srgbReference(x), 2e-7) << x;
    }
    // The two pieces meet: no visible jump at the threshold.
    EXPECT_NEAR(volcl::linearToSrgb(0.0031308f), volcl::linearToSrgb(std::nextafter(0.0031308f, 1.0f)), 1e-6);
    EXPECT_NEAR(volcl::linearToSrgb(0.5f), 0.735356983, 1e-6);
}

TEST(ImageIo, CompositeOverBackground) {
    ImageBuffer img(3, 1, {"R", "G", "B", "A"});
    // Pixel 0 transparent, pixel 1 opaque red, pixel 2 half-covered by associated (0.25, 0, 0).
    img.at(1, 0, 0) = 1.0f;
    img.at(1, 0, 3) = 1.0f;
    img.at(2, 0, 0) = 0.25f;
    img.at(2, 0, 3) = 0.5f;
    img.attributes.push_back({"volcl:method", std::string("dvr")});
    ImageBuffer out = volcl::compositeOverSrgb(img, {0.0, 0.0, 1.0, 1.0});
    EXPECT_EQ(out.channels, (std::vector<std::string>{"R", "G", "B", "A"}));
    EXPECT_EQ(out.at(0, 0, 2), 1.0f);
    EXPECT_EQ(out.at(0, 0, 0), 0.0f);
    EXPECT_EQ(out.at(0, 0, 3), 1.0f);
    EXPECT_EQ(out.at(1, 0, 0), 1.0f);
    EXPECT_EQ(out.at(1, 0, 2), 0.0f);
    EXPECT_NEAR(out.at(2, 0, 0), srgbReference(0.25), 1e-6);
    EXPECT_NEAR(out.at(2, 0, 2), srgbReference(0.5), 1e-6);
    ASSERT_NE(out.findAttribute("volcl:method"), nullptr);

    // Transparent background: alpha stays the image's and colour is un-premultiplied for display.
    ImageBuffer clear = volcl::compositeOverSrgb(img, {1.0, 1.0, 1.0, 0.0});
    EXPECT_EQ(clear.at(0, 0, 3), 0.0f);
    EXPECT_EQ(clear.at(2, 0, 3), 0.5f);
    EXPECT_NEAR(clear.at(2, 0, 0), srgbReference(0.5), 1e-6);
    ImageBuffer noAlpha(1, 1, {"R", "G", "B"});
    EXPECT_THROW(volcl::compositeOverSrgb(noAlpha, {0, 0, 0, 1}), volcl::UsageError);
}

} // namespace
