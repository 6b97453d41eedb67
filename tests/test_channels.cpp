// Multi-channel volumes: readers and writers keeping components, and the multi-channel ray marcher against
// its double reference and an analytic two-channel oracle on the hard cases.
#include "TestUtil.hpp"

#include "core/Channels.hpp"
#include "core/Error.hpp"
#include "host/io/VolumeIo.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/grid/ChannelRenderer.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>

namespace {

using namespace volcl;
using volcl::test::computeContext;
using volcl::test::makeFloatVolume;
using volcl::test::maxAbsDiff;
using volcl::test::orthoScene;
using volcl::test::tempDir;

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

/// `count` channels of `type` on a 5 x 4 x 3 grid with distinct values per channel and voxel.
ChannelVolume patterned(std::size_t count, ScalarType type) {
    ChannelVolume cv;
    for (std::size_t c = 0; c < count; ++c) {
        Volume v({5, 4, 3}, type);
        v.spacing = {0.5, 1.0, 2.0};
        v.origin = {1.0, -2.0, 3.0};
        for (std::size_t n = 0; n < v.voxelCount(); ++n) {
            const double value = double((n * 7 + c * 31) % 200);
            if (type == ScalarType::UInt8)
                v.values<std::uint8_t>()[n] = std::uint8_t(value);
            else if (type == ScalarType::UInt16)
                v.values<std::uint16_t>()[n] = std::uint16_t(value * 300);
            else if (type == ScalarType::Int16)
                v.values<std::int16_t>()[n] = std::int16_t(value - 100);
            else
                v.values<float>()[n] = float(value * 0.25 - 7.5);
        }
        cv.channels.push_back(std::move(v));
    }
    return cv;
}

void expectSameChannels(const ChannelVolume& a, const ChannelVolume& b) {
    ASSERT_EQ(a.count(), b.count());
    for (std::size_t c = 0; c < a.count(); ++c) {
        EXPECT_EQ(a.channels[c].dims(), b.channels[c].dims());
        EXPECT_EQ(a.channels[c].type(), b.channels[c].type());
        EXPECT_TRUE(std::equal(a.channels[c].bytes().begin(), a.channels[c].bytes().end(),
                               b.channels[c].bytes().begin()))
            << "channel " << c;
        for (int k = 0; k < 3; ++k) {
            EXPECT_NEAR(a.channels[c].spacing[k], b.channels[c].spacing[k], 1e-6);
            EXPECT_NEAR(a.channels[c].origin[k], b.channels[c].origin[k], 1e-6);
        }
    }
}

TEST(ChannelIo, NrrdNiftiVtiRoundTripsAreExact) {
    const auto dir = tempDir("channels_roundtrip");
    for (const char* name : {"c.nrrd", "c.nhdr", "c.nii", "c.nii.gz", "c.vti"})
        for (ScalarType t : {ScalarType::UInt8, ScalarType::UInt16, ScalarType::Int16, ScalarType::Float32})
            for (std::size_t count : {2u, 3u, 4u}) {
                SCOPED_TRACE(std::string(name) + " " + std::string(scalarTypeName(t)) + " x" +
                             std::to_string(count));
                const ChannelVolume cv = patterned(count, t);
                writeChannelsFile(cv, dir / name);
                expectSameChannels(cv, readVolumeChannels(dir / name));
            }
}

TEST(ChannelIo, NrrdColourKindIsKept) {
    const auto dir = tempDir("channels_colour");
    ChannelVolume cv = patterned(3, ScalarType::UInt8);
    cv.color = true;
    writeChannelsFile(cv, dir / "rgb.nrrd");
    const std::string header = volcl::test::readFile(dir / "rgb.nrrd").substr(0, 400);
    EXPECT_NE(header.find("kinds: RGB-color domain domain domain"), std::string::npos) << header;
    EXPECT_TRUE(readVolumeChannels(dir / "rgb.nrrd").color);
}

TEST(ChannelIo, ScalarToolsChooseOneChannelOrAreRefused) {
    const auto dir = tempDir("channels_choose");
    const ChannelVolume cv = patterned(3, ScalarType::Int16);
    for (const char* name : {"c.nrrd", "c.nii.gz", "c.vti"}) {
        SCOPED_TRACE(name);
        writeChannelsFile(cv, dir / name);
        try {
            readVolumeFile(dir / name);
            ADD_FAILURE() << "a multi-channel file read as one scalar volume";
        } catch (const DataError& e) {
            EXPECT_NE(std::string(e.what()).find("has 3 channels"), std::string::npos) << e.what();
            EXPECT_NE(std::string(e.what()).find("--channel"), std::string::npos) << e.what();
        }
        ReadOptions o;
        o.channel = 1;
        const TimeSeries one = readVolumeFile(dir / name, o);
        ASSERT_EQ(one.frames.size(), 1u);
        EXPECT_TRUE(std::equal(one.frames[0].bytes().begin(), one.frames[0].bytes().end(),
                               cv.channels[1].bytes().begin()));
        o.channel = 3;
        EXPECT_THROW(readVolumeFile(dir / name, o), UsageError);
    }
    writeVolumeFile(cv.channels[0], dir / "scalar.nrrd");
    ReadOptions o;
    o.channel = 0;
    EXPECT_EQ(readVolumeFile(dir / "scalar.nrrd", o).frames.size(), 1u);
    o.channel = 1;
    EXPECT_THROW(readVolumeFile(dir / "scalar.nrrd", o), UsageError);
    EXPECT_EQ(readVolumeChannels(dir / "scalar.nrrd").count(), 1u);
}

TEST(ChannelIo, MetaImageChannelsAndNiftiRgb24Read) {
    const auto dir = tempDir("channels_mha_rgb");
    // MetaImage: 2 interleaved float channels on 3 x 2 x 1.
    std::string mha = "ObjectType = Image\nNDims = 3\nDimSize = 3 2 1\nElementNumberOfChannels = 2\n"
                      "ElementType = MET_FLOAT\nElementSpacing = 1 1 1\nElementDataFile = LOCAL\n";
    std::vector<float> values;
    for (int n = 0; n < 6; ++n) {
        values.push_back(float(n));
        values.push_back(float(100 + n));
    }
    mha.append(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(float));
    volcl::test::writeFile(dir / "two.mha", mha);
    const ChannelVolume m = readVolumeChannels(dir / "two.mha");
    ASSERT_EQ(m.count(), 2u);
    EXPECT_EQ(m.channels[0].values<float>()[4], 4.0f);
    EXPECT_EQ(m.channels[1].values<float>()[4], 104.0f);

    // NIfTI RGB24: a 3-channel uint8 NIfTI rewritten as datatype 128 with interleaved samples.
    const ChannelVolume rgb = patterned(3, ScalarType::UInt8);
    writeChannelsFile(rgb, dir / "planar.nii");
    std::string bytes = volcl::test::readFile(dir / "planar.nii");
    auto put16 = [&](std::size_t at, std::int16_t v) { std::memcpy(bytes.data() + at, &v, 2); };
    put16(40, 3);   // dim[0]
    put16(50, 1);   // dim[5]
    put16(70, 128); // RGB24
    put16(72, 24);
    const std::size_t n = rgb.channels[0].voxelCount();
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t c = 0; c < 3; ++c)
            bytes[352 + 3 * i + c] = char(rgb.channels[c].values<std::uint8_t>()[i]);
    volcl::test::writeFile(dir / "rgb24.nii", bytes);
    const ChannelVolume back = readVolumeChannels(dir / "rgb24.nii");
    EXPECT_TRUE(back.color);
    expectSameChannels(rgb, [&] {
        ChannelVolume b = back;
        for (Volume& v : b.channels) { // the NIfTI grid keeps the spacing; NIfTI has no origin shift here
            v.origin = rgb.channels[0].origin;
        }
        return b;
    }());
}

TEST(ChannelIo, WritersRefuseMixedTypesAndOtherFormats) {
    const auto dir = tempDir("channels_refuse");
    ChannelVolume cv = patterned(2, ScalarType::UInt8);
    cv.channels[1] = cv.channels[1].convertedTo(ScalarType::Float32);
    EXPECT_THROW(writeChannelsFile(cv, dir / "mixed.nrrd"), Error);
    EXPECT_THROW(writeChannelsFile(patterned(2, ScalarType::UInt8), dir / "c.raw"), UsageError);
    EXPECT_FALSE(std::filesystem::exists(dir / "mixed.nrrd"));
}

// ---- rendering --------------------------------------------------------------------------------------

/// tau rising linearly from 0 at `lo` to `tauHi` at `hi`, one colour.
TransferFunction rampTf(double lo, double hi, double tauHi, std::array<double, 3> rgb) {
    TransferFunction tf;
    tf.domain = {lo, hi};
    tf.color = {{lo, rgb}, {hi, rgb}};
    tf.extinction = {{lo, 0.0}, {hi, tauHi}};
    return tf;
}

/// Channel 0 (float32): s = x over 17 x 13 x 9 voxels. Channel 1 (uint8): 200 on the one-voxel plane z = 4,
/// 0 elsewhere, so trilinear reconstruction gives the tent 200 max(0, 1 - |z - 4|) exactly, as s = x.
ChannelVolume rampAndPlane() {
    ChannelVolume cv;
    cv.channels.push_back(makeFloatVolume({17, 13, 9}, [](double x, double, double) { return x; }));
    Volume plane({17, 13, 9}, ScalarType::UInt8);
    for (std::size_t j = 0; j < 13; ++j)
        for (std::size_t i = 0; i < 17; ++i)
            plane.values<std::uint8_t>()[plane.index(i, j, 4)] = 200;
    cv.channels.push_back(std::move(plane));
    return cv;
}

ChannelStyle rampPlaneStyle() {
    ChannelStyle st;
    st.layers.push_back({rampTf(0, 16, 0.3, {1.0, 0.2, 0.0}), true});
    st.layers.push_back({rampTf(0, 200, 2.0, {0.0, 0.4, 1.0}), true});
    return st;
}

/// The analytic oracle: the fields of rampAndPlane() evaluated in closed form (no grid, no trilinear
/// interpolation) along each pixel's ray, integrated by fine point sampling (T decays as exp(-sigma dz),
/// emission sum_c tau_c c_c T dz): shares neither the kernel's segment formula nor its sampling.
ImageBuffer oracle(const ChannelStyle& st, const Scene& scene) {
    ImageBuffer img(scene.width, scene.height, {"R", "G", "B", "A"});
    const Camera& cam = *scene.camera;
    for (int py = 0; py < scene.height; ++py)
        for (int px = 0; px < scene.width; ++px) {
            const CameraRay ray = cameraRay(cam, scene.width, scene.height, px, py);
            const double x = ray.origin[0], y = ray.origin[1];
            double rgb[3] = {0, 0, 0}, T = 1.0;
            if (x >= 0 && x <= 16 && y >= 0 && y <= 12) {
                const int m = 80000;
                const double dz = 8.0 / m;
                for (int i = 0; i < m; ++i) {
                    const double z = (i + 0.5) * dz;
                    const double s[2] = {x, 200.0 * std::max(0.0, 1.0 - std::abs(z - 4.0))};
                    double sigma = 0, e[3] = {0, 0, 0};
                    for (int c = 0; c < 2; ++c) {
                        if (!st.layers[std::size_t(c)].visible) continue;
                        const TransferFunction& tf = st.layers[std::size_t(c)].tf;
                        const double tau = tf.extinctionAt(s[c]);
                        const auto col = tf.colorAt(s[c]);
                        sigma += tau;
                        for (int k = 0; k < 3; ++k)
                            e[k] += tau * col[std::size_t(k)];
                    }
                    for (int k = 0; k < 3; ++k)
                        rgb[k] += T * e[k] * dz;
                    T *= std::exp(-sigma * dz);
                }
            }
            for (int k = 0; k < 3; ++k)
                img.at(px, py, k) = float(rgb[k]);
            img.at(px, py, 3) = float(1.0 - T);
        }
    return img;
}

/// orthoScene over the 17 x 13 x 9 grid, pixels landing on exact x, y voxel positions (within the box).
Scene rampPlaneScene(double step) {
    Scene s = orthoScene({17, 13, 9}, 12.0, 8, 6);
    s.step = step;
    return s;
}

TEST(ChannelRender, TwoTypesAndAThinPlaneMatchTheAnalyticOracle) {
    const ChannelVolume cv = rampAndPlane();
    const ChannelStyle st = rampPlaneStyle();
    const Scene scene = rampPlaneScene(0.02);
    ChannelRenderer r(computeContext(), cv, st, scene);
    const ImageBuffer gpu = r.render();
    const ImageBuffer exact = oracle(st, scene);
    EXPECT_LT(maxAbsDiff(gpu, exact), 2e-3);
    ReferenceOptions ro;
    ro.step = 0.02;
    EXPECT_LT(maxAbsDiff(referenceChannelRender(cv, st, scene, ro), exact), 1e-3);
    // The plane is seen: its blue adds to the ramp's red.
    EXPECT_GT(gpu.at(4, 3, 2), 0.1f);
}

TEST(ChannelRender, AnEmptyOrHiddenChannelLeavesTheOtherAlone) {
    ChannelVolume cv = rampAndPlane();
    ChannelStyle st = rampPlaneStyle();
    const Scene scene = rampPlaneScene(0.05);
    ChannelStyle alone = st;
    alone.layers[1].visible = false;
    ChannelVolume empty = cv;
    empty.channels[1] = Volume({17, 13, 9}, ScalarType::UInt8); // all zero: tau 0 everywhere
    const ImageBuffer hidden = ChannelRenderer(computeContext(), cv, alone, scene).render();
    const ImageBuffer zero = ChannelRenderer(computeContext(), empty, st, scene).render();
    EXPECT_LT(maxAbsDiff(hidden, zero), 1e-6);
    EXPECT_LT(maxAbsDiff(hidden, oracle(alone, scene)), 2e-3);
    EXPECT_EQ(hidden.at(4, 3, 2), 0.0f);
}

TEST(ChannelRender, NanChannelFollowsTheNanRule) {
    // Channel 1 holds NaN on the plane z = 4: samples in z in [3, 5) are non-finite (a cell with a NaN corner),
    // and take the NaN colour; channel 0 is unaffected.
    ChannelVolume cv = rampAndPlane();
    cv.channels[1] =
        makeFloatVolume({17, 13, 9}, [](double, double, double z) { return z == 4 ? kNaN : 0.0; });
    ChannelStyle st = rampPlaneStyle();
    Scene scene = rampPlaneScene(0.05);
    std::vector<float> green;
    for (double a : {0.0, 0.5}) {
        scene.nanColor = {0.0, 1.0, 0.0, a};
        ChannelRenderer r(computeContext(), cv, st, scene);
        const ImageBuffer gpu = r.render();
        ReferenceOptions ro;
        ro.step = 0.05;
        const ImageBuffer ref = referenceChannelRender(cv, st, scene, ro);
        EXPECT_LT(maxAbsDiff(gpu, ref), 1e-4) << "nan alpha " << a;
        for (float v : gpu.pixels)
            ASSERT_TRUE(std::isfinite(v));
        // Closed form along a ray at x: channel 0's tau0 = 0.3 x / 16 over z in [0, 8], plus the NaN
        // extinction tauN = -ln(1 - a) over z in [3, 5).
        const double x = cameraRay(*scene.camera, 8, 6, 4, 3).origin[0];
        const double tau0 = 0.3 * x / 16, tauN = -std::log1p(-a);
        const double alpha = 1.0 - std::exp(-tau0 * 8 - tauN * 2);
        EXPECT_NEAR(gpu.at(4, 3, 3), alpha, 2e-3) << "nan alpha " << a;
        EXPECT_EQ(gpu.at(4, 3, 2), 0.0f); // neither the ramp's colour nor the NaN colour has blue
        green.push_back(gpu.at(4, 3, 1));
    }
    EXPECT_GT(green[1], green[0] + 0.05f); // the NaN colour's green shows only when it has opacity
}

TEST(ChannelRender, FourChannelsAndEveryBlendMatchTheReference) {
    ChannelVolume cv;
    cv.channels.push_back(makeFloatVolume({9, 8, 7}, [](double x, double, double) { return x; }));
    Volume u8({9, 8, 7}, ScalarType::UInt8), u16({9, 8, 7}, ScalarType::UInt16),
        i16({9, 8, 7}, ScalarType::Int16);
    for (std::size_t n = 0; n < u8.voxelCount(); ++n) {
        u8.values<std::uint8_t>()[n] = std::uint8_t((n * 37) % 256);
        u16.values<std::uint16_t>()[n] = std::uint16_t((n * 911) % 65536);
        i16.values<std::int16_t>()[n] = std::int16_t(int((n * 53) % 2000) - 1000);
    }
    cv.channels.push_back(u8);
    cv.channels.push_back(u16);
    cv.channels.push_back(i16);
    ChannelStyle st;
    st.layers.push_back({rampTf(0, 8, 0.2, {1, 0, 0}), true});
    st.layers.push_back({rampTf(0, 255, 0.3, {0, 1, 0}), true});
    st.layers.push_back({rampTf(0, 65535, 0.1, {0, 0, 1}), true});
    st.layers.push_back({rampTf(-1000, 1000, 0.4, {1, 1, 0}), true});
    Scene scene = orthoScene({9, 8, 7}, 9.0, 10, 8);
    scene.step = 0.1;
    Camera c = *scene.camera; // oblique, so rays cross cells in every direction
    c.eye = {-20.0, 30.0, -40.0};
    scene.camera = c;
    ReferenceOptions ro;
    ro.step = 0.1;
    for (ChannelBlend blend : {ChannelBlend::Additive, ChannelBlend::Maximum, ChannelBlend::DirectColor}) {
        SCOPED_TRACE(std::string(channelBlendName(blend)));
        st.blend = blend;
        scene.mode = blend == ChannelBlend::Maximum ? RenderMode::Mip : RenderMode::Dvr;
        ChannelVolume in = cv;
        ChannelStyle style = st;
        if (blend == ChannelBlend::DirectColor) // RGBA of uint8 colour, opacity from alpha through layer 0
            for (std::size_t k = 0; k < 4; ++k)
                in.channels[k] = u8;
        if (blend == ChannelBlend::DirectColor) style.layers[0].tf = rampTf(0, 1, 1.5, {1, 1, 1});
        const ImageBuffer gpu = ChannelRenderer(computeContext(), in, style, scene).render();
        const ImageBuffer ref = referenceChannelRender(in, style, scene, ro);
        EXPECT_LT(maxAbsDiff(gpu, ref), 2e-4);
        double sum = 0;
        for (float v : gpu.pixels)
            sum += v;
        EXPECT_GT(sum, 1.0); // something is drawn
    }
}

TEST(ChannelRender, UnsupportedScenesAreRefusedInOneLine) {
    const ChannelVolume cv = rampAndPlane();
    const ChannelStyle st = rampPlaneStyle();
    Scene s = rampPlaneScene(0.5);
    s.effects.shading = true;
    EXPECT_THROW(checkChannelScene(cv, st, s), UsageError);
    s = rampPlaneScene(0.5);
    s.mode = RenderMode::Iso;
    EXPECT_THROW(checkChannelScene(cv, st, s), UsageError);
    ChannelStyle one = st;
    one.layers.pop_back();
    EXPECT_THROW(checkChannelScene(cv, one, rampPlaneScene(0.5)), UsageError);
    ChannelStyle direct = st;
    direct.blend = ChannelBlend::DirectColor;
    EXPECT_THROW(checkChannelScene(cv, direct, rampPlaneScene(0.5)), UsageError); // 2 channels are no colour
    ChannelVolume five;
    for (int c = 0; c < 5; ++c)
        five.channels.push_back(cv.channels[0]);
    ChannelStyle fiveStyle;
    fiveStyle.layers.assign(5, st.layers[0]);
    EXPECT_THROW(checkChannelScene(five, fiveStyle, rampPlaneScene(0.5)), UsageError);
}

} // namespace
