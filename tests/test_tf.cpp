// Transfer function tests: JSON and ParaView import, strips, steps, validation, packed and kernel sampling.
#include "core/Error.hpp"
#include "core/runtime/ClRuntime.hpp"
#include "host/image/ImageIo.hpp"
#include "host/tf/TransferFunction.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>

namespace {

using volcl::TransferFunction;

const char* kContractExample = R"({
  "domain": [0, 255],
  "color":      [[0, 0.0, 0.0, 0.0], [128, 1.0, 0.6, 0.2], [255, 1.0, 1.0, 1.0]],
  "extinction": [[0, 0.0], [60, 0.0], [80, 0.8], [255, 0.05]]
})";

std::filesystem::path tmpDir() {
    std::filesystem::path d = std::filesystem::path(VOLCL_TEST_TMP_DIR) / "tf";
    std::filesystem::create_directories(d);
    return d;
}

/// A TF with steps in both channels (at float-exact positions), a step at each end and uneven spacing.
TransferFunction steppedTf() {
    TransferFunction tf;
    tf.domain = {-10.0, 300.0};
    tf.color = {{-4.0, {0.0, 0.0, 1.0}},  {-4.0, {0.2, 0.1, 0.9}},  {17.5, {0.4, 0.9, 0.3}},
                {100.0, {1.0, 0.5, 0.0}}, {100.0, {0.0, 1.0, 0.0}}, {250.25, {0.3, 0.3, 0.3}}};
    tf.extinction = {{0.0, 0.0},    {60.0, 0.0},  {80.0, 0.8}, {80.0, 3.5},
                     {123.0, 0.05}, {255.0, 2.0}, {255.0, 0.0}};
    tf.validate();
    return tf;
}

TEST(TransferFunction, ContractExampleValues) {
    TransferFunction tf = TransferFunction::fromJson(kContractExample);
    EXPECT_EQ(tf.domain[0], 0.0);
    EXPECT_EQ(tf.domain[1], 255.0);
    EXPECT_DOUBLE_EQ(tf.extinctionAt(70.0), 0.4);
    EXPECT_DOUBLE_EQ(tf.extinctionAt(60.0), 0.0);
    auto c = tf.colorAt(64.0);
    EXPECT_DOUBLE_EQ(c[0], 0.5);
    EXPECT_DOUBLE_EQ(c[1], 0.3);
    EXPECT_DOUBLE_EQ(c[2], 0.1);
    EXPECT_DOUBLE_EQ(tf.maxExtinction(), 0.8);
    EXPECT_DOUBLE_EQ(tf.maxColor(), 1.0);
    EXPECT_EQ(tf.breakpoints(), (std::vector<double>{0, 60, 80, 128, 255}));
}

TEST(TransferFunction, OutOfDomainIsConstant) {
    TransferFunction tf = TransferFunction::fromJson(kContractExample);
    EXPECT_EQ(tf.extinctionAt(-1e300), 0.0);
    EXPECT_EQ(tf.extinctionAt(1e300), 0.05);
    EXPECT_EQ(tf.colorAt(-5.0), (std::array<double, 3>{0, 0, 0}));
    EXPECT_EQ(tf.colorAt(1e9), (std::array<double, 3>{1, 1, 1}));
    const auto knots = tf.packKnots();
    for (float s : {-1e30f, -std::numeric_limits<float>::infinity(), -1.0f}) {
        auto v = TransferFunction::sampleFloat(knots, s);
        EXPECT_EQ(v, (std::array<float, 4>{0, 0, 0, 0})) << s;
    }
    for (float s : {256.0f, 1e30f, std::numeric_limits<float>::infinity()}) {
        auto v = TransferFunction::sampleFloat(knots, s);
        EXPECT_EQ(v, (std::array<float, 4>{1, 1, 1, 0.05f})) << s;
    }
    // NaN data takes the first knot's value (documented in cl/common/tf_lookup.h: the search ends at 0).
    auto v = TransferFunction::sampleFloat(knots, std::numeric_limits<float>::quiet_NaN());
    for (float x : v)
        EXPECT_TRUE(std::isfinite(x));
}

TEST(TransferFunction, CanonicalJsonRoundTripIsExact) {
    TransferFunction tf = steppedTf();
    tf.extinction[4].tau = 0.1 + 1e-13; // not representable in short decimal form
    TransferFunction back = TransferFunction::fromJson(tf.toJson());
    EXPECT_EQ(back.domain, tf.domain);
    ASSERT_EQ(back.color.size(), tf.color.size());
    ASSERT_EQ(back.extinction.size(), tf.extinction.size());
    for (std::size_t i = 0; i < tf.color.size(); ++i) {
        EXPECT_EQ(back.color[i].s, tf.color[i].s);
        EXPECT_EQ(back.color[i].rgb, tf.color[i].rgb);
    }
    for (std::size_t i = 0; i < tf.extinction.size(); ++i) {
        EXPECT_EQ(back.extinction[i].s, tf.extinction[i].s);
        EXPECT_EQ(back.extinction[i].tau, tf.extinction[i].tau);
    }
    EXPECT_EQ(back.toJson(), tf.toJson());
}

TEST(TransferFunction, FileRoundTripAndMissingFile) {
    auto path = tmpDir() / "roundtrip.json";
    {
        std::ofstream out(path);
        out << steppedTf().toJson();
    }
    TransferFunction back = TransferFunction::fromFile(path);
    EXPECT_EQ(back.toJson(), steppedTf().toJson());
    EXPECT_THROW(TransferFunction::fromFile(tmpDir() / "does-not-exist.json"), volcl::IoError);
    auto bad = tmpDir() / "bad.json";
    {
        std::ofstream out(bad);
        out << "{\"domain\": [0, 1], \"color\": [[0, 1, 1, 1]], \"extinction\": [[0, -1]]}";
    }
    try {
        TransferFunction::fromFile(bad);
        FAIL() << "negative tau accepted";
    } catch (const volcl::DataError& e) {
        EXPECT_NE(std::string(e.what()).find("bad.json"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("negative"), std::string::npos) << e.what();
    }
}

TEST(TransferFunction, StepsHoldEarlierValueAtTheStepAndLaterAbove) {
    TransferFunction tf = steppedTf();
    EXPECT_DOUBLE_EQ(tf.extinctionAt(80.0), 0.8);
    EXPECT_NEAR(tf.extinctionAt(std::nextafter(80.0, 100.0)), 3.5, 1e-12);
    EXPECT_DOUBLE_EQ(tf.extinctionAt(255.0), 2.0);
    EXPECT_EQ(tf.extinctionAt(std::nextafter(255.0, 300.0)), 0.0);
    // Step at the first colour point: at and below it the earlier point, above it the later.
    EXPECT_EQ(tf.colorAt(-4.0), (std::array<double, 3>{0.0, 0.0, 1.0}));
    EXPECT_EQ(tf.colorAt(-100.0), (std::array<double, 3>{0.0, 0.0, 1.0}));
    EXPECT_NEAR(tf.colorAt(std::nextafter(-4.0, 0.0))[0], 0.2, 1e-12);

    const auto knots = tf.packKnots();
    auto at = [&](float s) { return TransferFunction::sampleFloat(knots, s); };
    EXPECT_FLOAT_EQ(at(80.0f)[3], 0.8f);
    EXPECT_FLOAT_EQ(at(std::nextafter(80.0f, 100.0f))[3], 3.5f);
    EXPECT_FLOAT_EQ(at(255.0f)[3], 2.0f);
    EXPECT_EQ(at(std::nextafter(255.0f, 300.0f))[3], 0.0f);
    EXPECT_EQ(at(-4.0f)[2], 1.0f);
    EXPECT_EQ(at(-5.0f)[2], 1.0f);
    EXPECT_FLOAT_EQ(at(std::nextafter(-4.0f, 0.0f))[0], 0.2f);
    EXPECT_FLOAT_EQ(at(100.0f)[0], 1.0f);
    EXPECT_NEAR(at(std::nextafter(100.0f, 200.0f))[0], 0.0f, 1e-6f);
}

TEST(TransferFunction, SinglePointAndStepOnlyFunctions) {
    TransferFunction tf;
    tf.domain = {0, 1};
    tf.color = {{0.5, {0.25, 0.5, 0.75}}};
    tf.extinction = {{0.5, 0.0}, {0.5, 2.0}};
    const auto knots = tf.packKnots();
    EXPECT_EQ(tf.extinctionAt(0.5), 0.0);
    EXPECT_EQ(tf.extinctionAt(0.75), 2.0);
    EXPECT_EQ(TransferFunction::sampleFloat(knots, 0.5f)[3], 0.0f);
    EXPECT_EQ(TransferFunction::sampleFloat(knots, 0.0f)[3], 0.0f);
    EXPECT_EQ(TransferFunction::sampleFloat(knots, 0.75f)[3], 2.0f);
    EXPECT_EQ(TransferFunction::sampleFloat(knots, 0.75f)[1], 0.5f);
}

/// Double-precision value of the TF at exactly the float sample position, as (r, g, b, tau).
std::array<double, 4> reference(const TransferFunction& tf, float s) {
    auto c = tf.colorAt(double(s));
    return {c[0], c[1], c[2], tf.extinctionAt(double(s))};
}

TEST(TransferFunction, PackedFloatSamplingMatchesDoubleReference) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    // Random TF with 40 colour and 55 extinction points on uneven positions (float-exact s, so that the
    // sample position is the same in both evaluations), plus the fixed stepped TF.
    TransferFunction rnd;
    rnd.domain = {-1000.0, 3000.0};
    double s = -1000.0;
    for (int i = 0; i < 40; ++i, s += std::ldexp(std::floor(u(rng) * 4096.0) + 1.0, -6))
        rnd.color.push_back({s, {u(rng), u(rng) * 5.0, u(rng)}});
    s = -800.0;
    for (int i = 0; i < 55; ++i, s += std::ldexp(std::floor(u(rng) * 4096.0), -6))
        rnd.extinction.push_back({s, u(rng) * 40.0});
    for (const TransferFunction& tf : {rnd, steppedTf(), TransferFunction::fromJson(kContractExample)}) {
        const auto knots = tf.packKnots();
        double maxRel = 0.0;
        for (int i = 0; i < 200000; ++i) {
            const float x = static_cast<float>(-1200.0 + 4400.0 * u(rng));
            const auto got = TransferFunction::sampleFloat(knots, x);
            const auto ref = reference(tf, x);
            for (int c = 0; c < 4; ++c) {
                const double scale = c < 3 ? tf.maxColor() : tf.maxExtinction();
                maxRel = std::max(maxRel, std::abs(double(got[c]) - ref[c]) / scale);
            }
        }
        // float value + d * slope: a few float ulps of the channel's scale.
        EXPECT_LT(maxRel, 4e-6);
    }
}

TEST(TransferFunction, HostAndKernelSamplingAreBitIdentical) {
    volcl::ComputeContext cc;
    for (const TransferFunction& tf : {steppedTf(), TransferFunction::fromJson(kContractExample)}) {
        const auto knots = tf.packKnots();
        std::vector<float> xs;
        std::mt19937 rng(11);
        std::uniform_real_distribution<float> u(-50.0f, 320.0f);
        for (int i = 0; i < 100000; ++i)
            xs.push_back(u(rng));
        // Every knot, its float neighbours below and the next few above: where steps and rounding bite.
        for (const auto& k : knots) {
            xs.push_back(std::nextafter(k.s, -1e9f));
            float x = k.s;
            for (int i = 0; i < 4; ++i, x = std::nextafter(x, 1e9f))
                xs.push_back(x);
        }
        const float inf = std::numeric_limits<float>::infinity();
        for (float x : {0.0f, -0.0f, inf, -inf, std::numeric_limits<float>::quiet_NaN(), 1e-40f, -1e-40f,
                        3e38f, -3e38f})
            xs.push_back(x);

        auto dKnots = cc.upload(knots);
        auto dS = cc.upload(xs);
        auto dOut = cc.allocate<cl_float4>(xs.size());
        auto k = cc.kernel("render/tf_sample.cl", "tf_sample_points");
        volcl::setArgs(k, dKnots, cl_uint(knots.size()), dS, dOut, cl_uint(xs.size()));
        cc.launch1d(k, xs.size(), 64);
        const auto out = cc.download(dOut);
        std::size_t mismatches = 0;
        for (std::size_t i = 0; i < xs.size(); ++i) {
            const auto host = TransferFunction::sampleFloat(knots, xs[i]);
            if (std::memcmp(host.data(), &out[i], sizeof(float) * 4) != 0) {
                if (mismatches++ < 5)
                    ADD_FAILURE() << "s=" << xs[i] << " host " << host[0] << "," << host[3] << " kernel "
                                  << out[i].s[0] << "," << out[i].s[3];
            }
        }
        EXPECT_EQ(mismatches, 0u) << "of " << xs.size();
    }
}

TEST(TransferFunction, ParaViewImportLinear) {
    const char* pv = R"([{
      "ColorSpace": "RGB", "Name": "test",
      "RGBPoints": [0, 0, 0, 1,  50, 0.5, 0.5, 0.5,  100, 1, 0, 0],
      "Points": [0, 0, 0.5, 0,  40, 0.5, 0.5, 0,  100, 1, 0.5, 0]
    }])";
    TransferFunction tf = TransferFunction::fromJson(pv);
    EXPECT_EQ(tf.domain, (std::array<double, 2>{0, 100}));
    EXPECT_EQ(tf.extinction.size(), 3u);
    EXPECT_DOUBLE_EQ(tf.extinctionAt(40.0), std::log(2.0));
    EXPECT_DOUBLE_EQ(tf.extinctionAt(20.0), 0.5 * std::log(2.0));
    EXPECT_EQ(tf.extinctionAt(100.0), volcl::kMaxImportedExtinction);
    EXPECT_DOUBLE_EQ(tf.colorAt(75.0)[0], 0.75);
    EXPECT_DOUBLE_EQ(tf.colorAt(25.0)[2], 0.75);
    // Same map as a bare object.
    const char* bare =
        R"({"RGBPoints": [0, 0, 0, 1, 100, 1, 0, 0], "Points": [0, 0.2, 0.5, 0, 100, 0.2, 0.5, 0]})";
    TransferFunction b = TransferFunction::fromJson(bare);
    EXPECT_DOUBLE_EQ(b.extinctionAt(33.0), -std::log(0.8));
}

TEST(TransferFunction, ParaViewMidpointAndSharpness) {
    // Node 0: midpoint 0.25, linear; node 1: sharpness 1 (step at the midpoint); node 2: curved hermite.
    const char* pv = R"({"ColorSpace": "RGB", "RGBPoints": [0, 1, 1, 1, 300, 1, 1, 1],
      "Points": [0, 0, 0.25, 0,  100, 0.6, 0.5, 1.0,  200, 0.2, 0.5, 0.5,  300, 0.9, 0.5, 0]})";
    TransferFunction tf = TransferFunction::fromParaView(pv);
    auto opacity = [&](double s) { return 1.0 - std::exp(-tf.extinctionAt(s)); };
    EXPECT_NEAR(opacity(25.0), 0.3, 1e-12);  // midpoint value is the mean, reached at 25% of the interval
    EXPECT_NEAR(opacity(150.0), 0.6, 1e-12); // piecewise constant: the first value up to the midpoint
    EXPECT_NEAR(opacity(150.0 + 1e-9), 0.2, 1e-12);
    EXPECT_NEAR(opacity(250.0), 0.55, 1e-12); // hermite curve passes the mean at the midpoint
    // The hermite curve is steeper than linear near its midpoint and flatter near its ends.
    EXPECT_LT(opacity(205.0) - 0.2, 0.35 * 0.05);
    for (double s = 200.0; s < 300.0; s += 0.5) {
        EXPECT_GE(opacity(s + 0.5), opacity(s) - 1e-12);
        EXPECT_LE(opacity(s), 0.9 + 1e-12);
    }
}

TEST(TransferFunction, ParaViewRefusals) {
    EXPECT_THROW(
        TransferFunction::fromJson(R"([{"ColorSpace": "Lab/CIEDE2000", "RGBPoints": [0,0,0,1, 1,1,0,0]}])"),
        volcl::DataError);
    EXPECT_THROW(TransferFunction::fromJson(R"({"RGBPoints": [0, 0, 0]})"), volcl::DataError);
    EXPECT_THROW(TransferFunction::fromJson(R"({"RGBPoints": [0,0,0,1], "Points": [0, 1.5, 0.5, 0]})"),
                 volcl::DataError);
    EXPECT_THROW(TransferFunction::fromJson(R"({"RGBPoints": [5,0,0,1], "Points": [5, 0.5, 0.5, 0]})"),
                 volcl::DataError);
    EXPECT_THROW(TransferFunction::fromJson(
                     R"({"RGBPoints": [0,0,0,1, 9,1,1,1], "Points": [5,0.1,0.5,0, 1,0.2,0.5,0]})"),
                 volcl::DataError);
}

TEST(TransferFunction, RgbaStripImport) {
    std::vector<std::array<float, 4>> px = {{0, 0, 0, 0}, {1, 0.5f, 0, 0.5f}, {1, 1, 1, 1}};
    TransferFunction tf = TransferFunction::fromRgbaStrip(px, {10.0, 30.0});
    EXPECT_EQ(tf.breakpoints(), (std::vector<double>{10, 20, 30}));
    EXPECT_DOUBLE_EQ(tf.extinctionAt(20.0), std::log(2.0));
    EXPECT_EQ(tf.extinctionAt(30.0), volcl::kMaxImportedExtinction);
    EXPECT_DOUBLE_EQ(tf.colorAt(15.0)[1], 0.25);
    EXPECT_THROW(TransferFunction::fromRgbaStrip({}, {0, 1}), volcl::DataError);
    EXPECT_THROW(TransferFunction::fromRgbaStrip(px, {1, 1}), volcl::DataError);
    EXPECT_THROW(TransferFunction::fromRgbaStrip({{0, 0, 0, -0.1f}}, {0, 1}), volcl::DataError);
    EXPECT_THROW(TransferFunction::fromRgbaStrip({{0, NAN, 0, 0.1f}}, {0, 1}), volcl::DataError);

    // Through image files: an 8-bit PNG strip and an EXR strip.
    volcl::ImageBuffer img(256, 1, {"R", "G", "B", "A"});
    for (int x = 0; x < 256; ++x) {
        img.at(x, 0, 0) = x / 255.0f;
        img.at(x, 0, 3) = x < 128 ? 0.0f : 128.0f / 255.0f; // exact in 8 bits
    }
    volcl::writeImage(img, tmpDir() / "strip.png");
    volcl::writeImage(img, tmpDir() / "strip.exr");
    for (const char* name : {"strip.png", "strip.exr"}) {
        TransferFunction s = TransferFunction::fromFile(tmpDir() / name, {0.0, 1000.0});
        EXPECT_EQ(s.color.size(), 256u);
        EXPECT_EQ(s.domain[1], 1000.0);
        EXPECT_NEAR(s.colorAt(500.0)[0], 0.5, 1e-6);
        EXPECT_NEAR(s.extinctionAt(900.0), -std::log1p(-128.0 / 255.0), 1e-6);
        EXPECT_EQ(s.extinctionAt(100.0), 0.0);
    }
    volcl::ImageBuffer tall(4, 2, {"R", "G", "B", "A"});
    volcl::writeImage(tall, tmpDir() / "tall.exr");
    EXPECT_THROW(TransferFunction::fromFile(tmpDir() / "tall.exr"), volcl::DataError);
}

// Work downstream grows with the points, so a file may state at most kMaxTransferFunctionPoints per list. The
// fuzzer's 311-byte ZIP strip claimed 132,736 pixels: an exact 256^2 table from it took 15 s.
TEST(TransferFunction, PointCountsAboveTheLimitAreRefusedBeforeWork) {
    const std::size_t limit = volcl::kMaxTransferFunctionPoints;
    auto refusal = [](auto read) {
        try {
            read();
        } catch (const volcl::DataError& e) {
            return std::string(e.what());
        }
        return std::string();
    };
    auto canonical = [](std::size_t colors, std::size_t extinctions) {
        std::string j = R"({"domain": [0, 1], "color": [)";
        for (std::size_t i = 0; i < colors; ++i)
            j += (i ? "," : "") + std::string("[0.5, 1, 1, 1]");
        j += R"(], "extinction": [)";
        for (std::size_t i = 0; i < extinctions; ++i)
            j += (i ? "," : "") + std::string("[0.5, 1]");
        return j + "]}";
    };
    EXPECT_EQ(refusal([&] { TransferFunction::fromJson(canonical(limit, 2)); }), "");
    EXPECT_NE(refusal([&] {
                  TransferFunction::fromJson(canonical(limit + 1, 2));
              }).find("'color' has 16385 points, more than the 16384"),
              std::string::npos);
    EXPECT_NE(
        refusal([&] { TransferFunction::fromJson(canonical(2, limit + 1)); }).find("'extinction' has 16385"),
        std::string::npos);
    std::string rgb = R"({"RGBPoints": [)";
    for (std::size_t i = 0; i <= limit; ++i)
        rgb += (i ? "," : "") + std::to_string(i) + ",1,0,0";
    EXPECT_NE(refusal([&] { TransferFunction::fromJson(rgb + "]}"); }).find("'RGBPoints' has 16385"),
              std::string::npos);
    std::string opacity = R"({"RGBPoints": [0,1,0,0, 1,0,1,0], "Points": [)";
    for (std::size_t i = 0; i <= limit; ++i)
        opacity += (i ? "," : "") + std::to_string(i) + ",0.5,0.5,0";
    EXPECT_NE(refusal([&] { TransferFunction::fromJson(opacity + "]}"); }).find("'Points' has 16385"),
              std::string::npos);

    for (const std::size_t width : {limit, limit + 1}) {
        volcl::ImageBuffer strip(int(width), 1, {"R", "G", "B", "A"});
        const auto path = tmpDir() / ("strip-" + std::to_string(width) + ".png");
        volcl::writeImage(strip, path);
        const std::string why = refusal([&] { TransferFunction::fromFile(path, {0.0, 1.0}); });
        if (width == limit) {
            EXPECT_EQ(why, "");
        } else {
            EXPECT_NE(why.find(path.string()), std::string::npos) << why;
            EXPECT_NE(why.find("RGBA strip has 16385 points"), std::string::npos) << why;
        }
    }
}

TEST(TransferFunction, InvalidInputIsRefusedWithClearMessages) {
    struct Case {
        const char* json;
        const char* expect;
    };
    const Case cases[] = {
        {"{not json", "invalid JSON"},
        {R"({"domain": [0, 1], "color": [[0, 1, 1, 1]]})", "extinction"},
        {R"({"domain": [0, 1], "color": [], "extinction": [[0, 1]]})", "no points"},
        {R"({"domain": [0, 1], "color": [[0, 1, 1, 1]], "extinction": []})", "no points"},
        {R"({"domain": [1, 1], "color": [[0, 1, 1, 1]], "extinction": [[0, 1]]})", "lo < hi"},
        {R"({"domain": [2, 1], "color": [[0, 1, 1, 1]], "extinction": [[0, 1]]})", "lo < hi"},
        {R"({"domain": [0, 1], "color": [[0, 1, 1, 1]], "extinction": [[0, -0.5]]})", "negative"},
        {R"({"domain": [0, 9], "color": [[5, 1, 1, 1], [2, 0, 0, 0]], "extinction": [[0, 1]]})", "sorted"},
        {R"({"domain": [0, 9], "color": [[0, 1, 1, 1]], "extinction": [[3, 1], [1, 1]]})", "sorted"},
        {R"({"domain": [0, 1], "color": [[0, 1, 1]], "extinction": [[0, 1]]})", "[s, r, g, b]"},
        {R"({"domain": [0, 1], "color": [[0, 1, "x", 1]], "extinction": [[0, 1]]})", "expected a number"},
        {R"({"domain": [0, 1], "colour": [[0, 1, 1, 1]], "extinction": [[0, 1]]})", "unknown key"},
        {R"({"domain": [0, 1], "color": [[0, 1, 1, 1]], "extinction": [[0, 1e300]]})", "finite float"},
        {R"([1, 2, 3])", "expected a JSON object"},
    };
    for (const auto& c : cases) {
        try {
            TransferFunction::fromJson(c.json);
            ADD_FAILURE() << "accepted: " << c.json;
        } catch (const volcl::DataError& e) {
            EXPECT_NE(std::string(e.what()).find(c.expect), std::string::npos) << e.what();
            EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << "message is not one line";
        }
    }
    // NaN cannot be written in JSON; set it through the API.
    TransferFunction tf = steppedTf();
    tf.extinction[2].tau = std::numeric_limits<double>::quiet_NaN();
    EXPECT_THROW(tf.validate(), volcl::DataError);
    EXPECT_THROW(tf.packKnots(), volcl::DataError);
    tf = steppedTf();
    tf.color[1].rgb[1] = std::numeric_limits<double>::infinity();
    EXPECT_THROW(tf.validate(), volcl::DataError);
    tf = steppedTf();
    tf.domain[0] = std::numeric_limits<double>::quiet_NaN();
    EXPECT_THROW(tf.validate(), volcl::DataError);
}

TEST(TransferFunction, PackKnotsLayout) {
    TransferFunction tf = TransferFunction::fromJson(kContractExample);
    const auto k = tf.packKnots();
    // Breakpoints 0, 60, 80, 128, 255 merged from both channels; no steps, so no extra knot.
    ASSERT_EQ(k.size(), 5u);
    EXPECT_EQ(k[2].s, 80.0f);
    EXPECT_FLOAT_EQ(k[2].value[3], 0.8f);
    EXPECT_FLOAT_EQ(k[2].slope[3], float((0.05 - 0.8) / 175.0));
    EXPECT_EQ(k[4].slope[0], 0.0f);
    EXPECT_EQ(k[4].slope[3], 0.0f);
}

} // namespace
