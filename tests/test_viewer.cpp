// Viewer tests: camera motion, the adaptive-quality controller, key actions and presets (no GL), then the
// headless EGL path: frames read back from OpenGL against the renderer's PNG encoding within 1/255.
#include "TestUtil.hpp"

#include "apps/viewer/AdaptiveQuality.hpp"
#include "apps/viewer/ClGlSharing.hpp"
#include "apps/viewer/GlPresenter.hpp"
#include "apps/viewer/HeadlessGl.hpp"
#include "apps/viewer/Overlay.hpp"
#include "apps/viewer/ViewerApp.hpp"
#include "apps/viewer/ViewerCamera.hpp"
#include "apps/viewer/ViewerSession.hpp"
#include "core/Error.hpp"
#include "core/Volume.hpp"
#include "host/image/ImageIo.hpp"
#include "host/io/VolumeIo.hpp"
#include "host/mesh/MeshGenerator.hpp"
#include "render/Reference.hpp"
#include "render/RenderInput.hpp"
#include "render/VecMath.hpp"
#include "render/grid/GridRenderer.hpp"
#include "render/mesh/KBufferRenderer.hpp"

#include <epoxy/gl.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <sstream>

using namespace volcl;
using namespace volcl::viewer;

namespace {

constexpr double kPi = 3.14159265358979323846;

void expectNear(const Vec3& a, const Vec3& b, double tol) {
    for (int i = 0; i < 3; ++i)
        EXPECT_NEAR(a[i], b[i], tol) << "component " << i;
}

Camera testCamera(Projection p) {
    Camera c;
    c.projection = p;
    c.eye = {10, 20, -100};
    c.target = {10, 20, 30};
    c.up = {0, 1, 0};
    c.height = 50;
    c.fovYDeg = 40;
    return c;
}

// Largest per-channel difference between two RGBA images of one size, in units of 1/255.
double maxDifference255(const ImageBuffer& a, const ImageBuffer& b) {
    EXPECT_EQ(a.width, b.width);
    EXPECT_EQ(a.height, b.height);
    double m = 0.0;
    for (int y = 0; y < a.height; ++y)
        for (int x = 0; x < a.width; ++x)
            for (int c = 0; c < 4; ++c)
                m = std::max(m, std::abs(double(a.at(x, y, c)) - double(b.at(x, y, c))) * 255.0);
    return m;
}

// The 8-bit values `volcl render` writes to PNG: compositeOverSrgb, then rounding to k/255.
ImageBuffer pngEncoding(const ImageBuffer& linear, const std::array<double, 4>& bg) {
    ImageBuffer d = compositeOverSrgb(linear, bg);
    for (float& v : d.pixels)
        v = std::round(std::clamp(v, 0.0f, 1.0f) * 255.0f) / 255.0f;
    return d;
}

// A smooth blob with a shell and a hard-edged block: gradients for shading, a discontinuity for clipping.
Volume phantom(Dims d) {
    Volume v(d, ScalarType::UInt8);
    auto a = v.values<std::uint8_t>();
    for (std::size_t k = 0; k < d.z; ++k)
        for (std::size_t j = 0; j < d.y; ++j)
            for (std::size_t i = 0; i < d.x; ++i) {
                const double x = (i + 0.5) / d.x - 0.5, y = (j + 0.5) / d.y - 0.5, z = (k + 0.5) / d.z - 0.5;
                const double r = std::sqrt(x * x + y * y + z * z);
                double s = 255.0 * std::exp(-r * r / 0.06);
                if (std::abs(x - 0.25) < 0.08 && std::abs(y + 0.2) < 0.1) s = 200.0;
                a[v.index(i, j, k)] = static_cast<std::uint8_t>(std::clamp(s, 0.0, 255.0));
            }
    return v;
}

TransferFunction phantomTf() {
    return TransferFunction::fromJson(R"({"domain": [0, 255],
        "color": [[0, 0.1, 0.2, 0.8], [100, 0.9, 0.5, 0.2], [255, 1.0, 1.0, 0.9]],
        "extinction": [[0, 0.0], [40, 0.0], [120, 0.15], [255, 0.4]]})");
}

} // namespace

// ---------------------------------------------------------------------------------------------------------
// Camera motion

TEST(ViewerCamera, FullOrbitReturnsToStartAndKeepsDistance) {
    CameraController cam(testCamera(Projection::Orthographic));
    const Camera start = cam.camera();
    const double dist = norm(sub(start.eye, start.target));
    for (int i = 0; i < 36; ++i) {
        cam.orbit(2.0 * kPi / 36.0, 0.0);
        EXPECT_NEAR(norm(sub(cam.camera().eye, cam.camera().target)), dist, 1e-9 * dist);
    }
    expectNear(cam.camera().eye, start.eye, 1e-9 * dist);
    expectNear(cam.camera().up, start.up, 1e-12);
}

TEST(ViewerCamera, YawQuarterTurnMatchesAnalyticRotation) {
    CameraController cam(testCamera(Projection::Orthographic));
    cam.orbit(kPi / 2.0, 0.0);
    // Eye was 130 units along -z from the target; yawing the scene right moves the eye to -x... check via
    // the rotation about +y by -90 degrees: (0, 0, -130) -> (130 * sin(-90), 0, -130 * cos(-90)) = (130, 0,
    // 0).
    expectNear(sub(cam.camera().eye, cam.camera().target), {130.0, 0.0, 0.0}, 1e-9);
}

TEST(ViewerCamera, PitchOverThePoleStaysOrthonormalAndFinite) {
    CameraController cam(testCamera(Projection::Perspective));
    for (int i = 0; i < 40; ++i)
        cam.orbit(0.01, kPi / 16.0); // 2.5 turns over the poles
    const Camera& c = cam.camera();
    const Vec3 f = normalized(sub(c.target, c.eye));
    EXPECT_NEAR(norm(c.up), 1.0, 1e-9);
    EXPECT_NEAR(dot(f, c.up), 0.0, 1e-9);
    for (double v : c.eye)
        EXPECT_TRUE(std::isfinite(v));
    // A ray through the centre pixel still points at the target.
    const CameraRay ray = cameraRay(c, 64, 64, 31.5, 31.5);
    expectNear(ray.direction, f, 1e-9);
}

TEST(ViewerCamera, UpParallelToViewIsRepaired) {
    Camera c = testCamera(Projection::Orthographic);
    c.up = {0, 0, 1}; // along the view direction
    CameraController cam(c);
    const Vec3 f = normalized(sub(cam.camera().target, cam.camera().eye));
    EXPECT_NEAR(dot(f, cam.camera().up), 0.0, 1e-12);
    EXPECT_NEAR(norm(cam.camera().up), 1.0, 1e-12);
}

TEST(ViewerCamera, PanMovesEyeAndTargetTogetherByViewHeightFractions) {
    CameraController cam(testCamera(Projection::Orthographic));
    const Camera before = cam.camera();
    cam.pan(0.1, 0.2); // content right and up: camera left (-r) and down (-u)
    const Vec3 moveEye = sub(cam.camera().eye, before.eye),
               moveTarget = sub(cam.camera().target, before.target);
    expectNear(moveEye, moveTarget, 1e-12);
    // f = +z, up = +y, r = cross(f, up) = (-1, 0, 0): moving along -r is +x.
    expectNear(moveEye, {0.1 * 50.0, -0.2 * 50.0, 0.0}, 1e-9);
}

TEST(ViewerCamera, ZoomScalesHeightOrDistance) {
    CameraController ortho(testCamera(Projection::Orthographic));
    ortho.zoom(0.5);
    EXPECT_DOUBLE_EQ(ortho.camera().height, 25.0);
    CameraController persp(testCamera(Projection::Perspective));
    const double h0 = persp.viewHeight();
    persp.zoom(0.5);
    EXPECT_NEAR(norm(sub(persp.camera().eye, persp.camera().target)), 65.0, 1e-9);
    EXPECT_NEAR(persp.viewHeight(), 0.5 * h0, 1e-9);
    EXPECT_NEAR(h0, 2.0 * 130.0 * std::tan(20.0 * kPi / 180.0), 1e-9);
}

TEST(ViewerCamera, RefusesDegenerateInput) {
    Camera c = testCamera(Projection::Orthographic);
    c.eye = c.target;
    EXPECT_THROW(CameraController{c}, UsageError);
    CameraController cam(testCamera(Projection::Orthographic));
    EXPECT_THROW(cam.zoom(0.0), UsageError);
    EXPECT_THROW(cam.zoom(-2.0), UsageError);
    EXPECT_THROW(cam.zoom(std::numeric_limits<double>::quiet_NaN()), UsageError);
    EXPECT_THROW(cam.zoom(std::numeric_limits<double>::infinity()), UsageError);
}

// ---------------------------------------------------------------------------------------------------------
// Adaptive quality

TEST(AdaptiveQuality, SplitKeepsTheRequestedWorkAndUsesTheStepLadder) {
    AdaptiveQuality aq;
    EXPECT_TRUE(aq.split(1.0).full());
    for (double w : {0.9, 0.5, 0.2, 0.1, 0.05, 0.01}) {
        const QualityLevel q = aq.split(w);
        EXPECT_NEAR(q.work(), w, 1e-12 * w) << "work " << w;
        EXPECT_GE(q.stepScale, 1.0);
        EXPECT_LE(q.stepScale, 4.0);
        EXPECT_LE(q.resolutionScale, 1.0);
        const double k = std::log2(q.stepScale) * 4.0; // on the 2^(k/4) ladder
        EXPECT_NEAR(k, std::round(k), 1e-9);
    }
    // Below the limits: the smallest frame at the largest step, never less.
    const QualityLevel tiny = aq.split(1e-9);
    EXPECT_DOUBLE_EQ(tiny.resolutionScale, 1.0 / 16.0);
    EXPECT_DOUBLE_EQ(tiny.stepScale, 4.0);
    EXPECT_NEAR(aq.split(1e-9).work(), aq.minWork(), 1e-15);
}

TEST(AdaptiveQuality, ConvergesToTheTargetOnAnAffineCostModel) {
    // Frame time = fixed overhead + cost proportional to work: the controller's fixed point is its aim,
    // 0.9 of the target.
    for (double fullMs : {150.0, 400.0, 1500.0}) {
        AdaptiveQuality aq({.targetMs = 100.0});
        const double overheadMs = 12.0;
        double ms = 0.0;
        for (int i = 0; i < 12; ++i) {
            const QualityLevel q = aq.next();
            ms = overheadMs + (fullMs - overheadMs) * q.work();
            aq.report(q, ms);
        }
        EXPECT_NEAR(ms, 90.0, 2.0) << "full-quality frame " << fullMs << " ms";
    }
}

TEST(AdaptiveQuality, HoldsTheTargetUnderNoise) {
    std::mt19937 rng(7);
    std::normal_distribution<double> noise(1.0, 0.15);
    AdaptiveQuality aq({.targetMs = 100.0});
    std::vector<double> times;
    for (int i = 0; i < 200; ++i) {
        const QualityLevel q = aq.next();
        const double ms = (5.0 + 600.0 * q.work()) * std::max(0.5, noise(rng));
        aq.report(q, ms);
        if (i >= 20) times.push_back(ms);
    }
    EXPECT_NEAR(percentile(times, 50), 100.0, 15.0);
    EXPECT_LE(percentile(times, 50), 100.0);
}

TEST(AdaptiveQuality, UnderNoiseFramesRarelyOvershootTheTargetBy20Percent) {
    // 15 % frame-time noise. Sized from the last frame alone and aimed at the target, ~19 % of the frames
    // landed past target + 20 % (each frame's time was the ratio of two noisy samples); with the cost
    // smoothed over frames and aimed at 0.9 of the target, about 5 %.
    std::mt19937 rng(11);
    std::normal_distribution<double> noise(1.0, 0.15);
    AdaptiveQuality aq({.targetMs = 100.0});
    int over = 0, counted = 0;
    for (int i = 0; i < 2000; ++i) {
        const QualityLevel q = aq.next();
        const double ms = (5.0 + 2500.0 * q.work()) * std::max(0.5, noise(rng));
        aq.report(q, ms);
        if (i < 20) continue;
        ++counted;
        if (ms > 120.0) ++over;
    }
    EXPECT_LT(double(over) / counted, 0.08) << over << " of " << counted << " frames over 120 ms";
}

TEST(AdaptiveQuality, AFullQualityFrameSeedsTheFirstInteractiveLevel) {
    AdaptiveQuality aq({.targetMs = 100.0});
    aq.seed(800.0);
    EXPECT_NEAR(aq.next().work(), 0.9 * 0.125, 1e-12); // aimed at 0.9 of the target
    aq.report(aq.next(), 100.0);
    // The cost estimate is the geometric mean of the seed's (800 ms per unit of work) and this frame's.
    const double cost = std::sqrt(800.0 * (100.0 / (0.9 * 0.125)));
    EXPECT_NEAR(aq.work(), 90.0 / cost, 1e-12);
    aq.seed(50.0); // after interactive history, full-quality frames no longer move the level
    EXPECT_NEAR(aq.work(), 90.0 / cost, 1e-12);
}

TEST(AdaptiveQuality, CheapScenesStayAtFullQuality) {
    AdaptiveQuality aq({.targetMs = 100.0});
    for (int i = 0; i < 5; ++i)
        aq.report(aq.next(), 20.0);
    EXPECT_TRUE(aq.next().full());
}

TEST(AdaptiveQuality, CutsAtOnceGrowsBoundedAndIgnoresBadTimes) {
    AdaptiveQuality aq({.targetMs = 100.0});
    aq.report(aq.next(), 1e6); // far over the target: straight to the floor
    EXPECT_DOUBLE_EQ(aq.work(), aq.minWork());
    aq.report(aq.next(), 1e-3); // a freak fast frame: at most 4x growth
    EXPECT_NEAR(aq.work(), 4.0 * aq.minWork(), 1e-15);
    const double w = aq.work();
    for (double bad :
         {0.0, -5.0, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()})
        aq.report(aq.next(), bad);
    EXPECT_DOUBLE_EQ(aq.work(), w);
    aq.setEnabled(false);
    EXPECT_TRUE(aq.next().full());
    aq.setEnabled(true);
    EXPECT_DOUBLE_EQ(aq.work(), w);
}

TEST(AdaptiveQuality, RefusesInvalidOptions) {
    EXPECT_THROW(AdaptiveQuality({.targetMs = 0.0}), UsageError);
    EXPECT_THROW(AdaptiveQuality({.targetMs = std::numeric_limits<double>::quiet_NaN()}), UsageError);
    EXPECT_THROW(AdaptiveQuality({.minResolutionScale = 0.0}), UsageError);
    EXPECT_THROW(AdaptiveQuality({.maxStepScale = 0.5}), UsageError);
    EXPECT_THROW(AdaptiveQuality({.maxGrowth = 1.0}), UsageError);
}

TEST(ViewerKeys, BindingsAndPercentile) {
    EXPECT_EQ(actionForKey('m'), ViewerAction::CycleMode);
    EXPECT_EQ(actionForKey('M'), ViewerAction::CycleMode);
    EXPECT_EQ(actionForKey('1'), ViewerAction::ToggleShading);
    EXPECT_EQ(actionForKey('5'), ViewerAction::ToggleIsosurfaces);
    EXPECT_EQ(actionForKey('q'), ViewerAction::Quit);
    EXPECT_FALSE(actionForKey('z').has_value());
    EXPECT_FALSE(actionForKey('\0').has_value());
    EXPECT_NE(keyBindingsHelp().find("orbit"), std::string::npos);
    EXPECT_DOUBLE_EQ(percentile({}, 50), 0.0);
    EXPECT_DOUBLE_EQ(percentile({3, 1, 2}, 50), 2.0);
    EXPECT_DOUBLE_EQ(percentile({1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11}, 90), 10.0);
    EXPECT_DOUBLE_EQ(percentile({5}, 90), 5.0);
}

TEST(ViewerPresets, ValidForEveryValueRange) {
    Volume u8 = phantom({9, 7, 5});
    Volume constant({4, 4, 4}, ScalarType::Float32); // min == max
    Volume negative({3, 3, 3}, ScalarType::Float32);
    auto n = negative.values<float>();
    for (std::size_t i = 0; i < n.size(); ++i)
        n[i] = -1e6f + 1e5f * float(i);
    for (const Volume* v : {&u8, &constant, &negative}) {
        const auto presets = transferFunctionPresets(*v, std::nullopt);
        ASSERT_EQ(presets.size(), 3u);
        for (const auto& p : presets) {
            EXPECT_NO_THROW(p.tf.validate()) << p.name;
            EXPECT_GT(p.tf.maxExtinction(), 0.0) << p.name;
            EXPECT_TRUE(std::isfinite(p.tf.maxExtinction())) << p.name;
        }
    }
    EXPECT_EQ(transferFunctionPresets(u8, phantomTf()).front().name, "scene");
}

// ---------------------------------------------------------------------------------------------------------
// OpenGL: headless EGL context, PBO upload, display encoding, read-back

// One EGL context for the GL tests of this process (contexts are per thread; gtest runs tests in order).
HeadlessGlContext& gl() {
    static HeadlessGlContext context;
    return context;
}

TEST(ViewerGl, HeadlessContextIsOpenGl33Core) {
    const std::string d = gl().description();
    EXPECT_NE(d.find("OpenGL"), std::string::npos) << d;
    std::cerr << "[ viewer ] " << d << '\n';
}

TEST(ViewerGl, PresenterMatchesCompositeOverSrgbOnHardValues) {
    gl();
    FramePresenter p;
    // Non-power-of-two frame with transparent, opaque, over-range, negative and denormal-ish values.
    const int w = 37, h = 23;
    ImageBuffer f(w, h, {"R", "G", "B", "A"});
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const float a = (x % 5 == 0) ? 0.0f : (x % 5 == 1) ? 1.0f : u(rng);
            for (int c = 0; c < 3; ++c)
                f.at(x, y, c) = a * u(rng);
            f.at(x, y, 3) = a;
        }
    f.at(1, 1, 0) = 7.5f;   // emission above 1 (bright, thin): clamps to white
    f.at(2, 1, 1) = -0.25f; // tiny negative from float rounding: black
    f.at(3, 1, 3) = 1.2f;   // alpha over 1: clamps
    f.at(4, 1, 2) = 1e-30f; // tiny positive
    for (const std::array<double, 4>& bg :
         {std::array<double, 4>{0, 0, 0, 1}, std::array<double, 4>{0.2, 0.5, 1.0, 1.0},
          std::array<double, 4>{1, 1, 1, 0}, std::array<double, 4>{0.3, 0.3, 0.3, 0.5}}) {
        OffscreenFramebuffer fb(w, h);
        p.upload(f);
        p.draw(w, h, bg);
        const ImageBuffer back = readFramebuffer(w, h);
        EXPECT_LE(maxDifference255(back, pngEncoding(f, bg)), 1.0) << "background " << bg[0] << "," << bg[3];
    }
}

TEST(ViewerGl, OnePixelFramesExtraChannelsAndMagnification) {
    gl();
    FramePresenter p;
    ImageBuffer one(1, 1, {"R", "G", "B", "A", "Z"}); // iso mode adds depth: skipped on upload
    one.pixels = {0.25f, 0.5f, 0.125f, 0.75f, 42.0f};
    OffscreenFramebuffer fb(1, 1);
    p.upload(one);
    p.draw(1, 1, {0, 0, 0, 1});
    EXPECT_LE(maxDifference255(readFramebuffer(1, 1), pngEncoding(one, {0, 0, 0, 1})), 1.0);

    // A constant 5x3 frame magnified onto 64x48 (adaptive quality) stays that constant everywhere.
    ImageBuffer c(5, 3, {"R", "G", "B", "A"});
    for (int i = 0; i < 15; ++i) {
        c.pixels[i * 4 + 0] = 0.3f;
        c.pixels[i * 4 + 1] = 0.1f;
        c.pixels[i * 4 + 2] = 0.05f;
        c.pixels[i * 4 + 3] = 0.6f;
    }
    fb.resize(64, 48);
    p.upload(c);
    p.draw(64, 48, {0, 0, 0, 1});
    const ImageBuffer big = readFramebuffer(64, 48);
    const ImageBuffer want = pngEncoding(c, {0, 0, 0, 1});
    double m = 0.0;
    for (int y = 0; y < 48; ++y)
        for (int x = 0; x < 64; ++x)
            for (int k = 0; k < 4; ++k)
                m = std::max(m, std::abs(double(big.at(x, y, k)) - double(want.at(0, 0, k))));
    EXPECT_LE(m * 255.0, 1.0);
}

TEST(ViewerGl, RefusesUnusableFrames) {
    gl();
    FramePresenter p;
    EXPECT_THROW(p.draw(4, 4, {0, 0, 0, 1}), Error); // nothing uploaded yet
    EXPECT_THROW(p.upload(ImageBuffer{}), Error);
    ImageBuffer noAlpha(2, 2, {"R", "G", "B"});
    EXPECT_THROW(p.upload(noAlpha), Error);
    EXPECT_THROW(OffscreenFramebuffer(0, 5), UsageError);
}

TEST(ViewerGl, TransportFollowsTheDeviceExtension) {
    ComputeContext& cc = test::computeContext();
    const FrameTransport t = availableTransport(cc.device());
    EXPECT_EQ(t == FrameTransport::ClGlSharing, cc.device().hasExtension("cl_khr_gl_sharing"));
    DeviceInfo fake = cc.device();
    fake.extensions = "cl_khr_fp64 cl_khr_gl_sharing";
    EXPECT_EQ(availableTransport(fake), FrameTransport::ClGlSharing);
    fake.extensions = "cl_khr_fp64 cl_khr_gl_sharing_ext";
    EXPECT_EQ(availableTransport(fake), FrameTransport::Pbo);
}

TEST(ViewerGl, TransportChoiceChecksTheExtensionFirst) {
    ComputeContext& cc = test::computeContext();
    DeviceInfo without = cc.device(), with = cc.device();
    without.extensions = "cl_khr_fp64 cl_khr_gl_sharing_ext";
    with.extensions = "cl_khr_fp64 cl_khr_gl_sharing";
    EXPECT_EQ(chooseTransport(TransportRequest::Auto, without), FrameTransport::Pbo);
    EXPECT_EQ(chooseTransport(TransportRequest::Auto, with), FrameTransport::ClGlSharing);
    EXPECT_EQ(chooseTransport(TransportRequest::Pbo, with), FrameTransport::Pbo);
    EXPECT_EQ(chooseTransport(TransportRequest::Share, with), FrameTransport::ClGlSharing);
    try {
        chooseTransport(TransportRequest::Share, without);
        ADD_FAILURE() << "share without cl_khr_gl_sharing was accepted";
    } catch (const UsageError&) {
        ADD_FAILURE() << "an unsupported device is a runtime error (exit 1), not a usage error";
    } catch (const Error& e) {
        const std::string m = e.what();
        EXPECT_NE(m.find("cl_khr_gl_sharing"), std::string::npos) << m;
        EXPECT_EQ(m.find('\n'), std::string::npos) << m;
    }
    EXPECT_EQ(parseTransportRequest("auto"), TransportRequest::Auto);
    EXPECT_EQ(parseTransportRequest("pbo"), TransportRequest::Pbo);
    EXPECT_EQ(parseTransportRequest("share"), TransportRequest::Share);
    EXPECT_THROW(parseTransportRequest("Share "), UsageError);
    EXPECT_THROW(parseTransportRequest(""), UsageError);
}

TEST(ViewerGl, SharedBufferRefusesADeviceWithoutTheExtension) {
    gl();
    ComputeContext& cc = test::computeContext();
    // The refusal must come before any GL entry point of the OpenCL platform is looked up or called
    // (PoCL aborts in them), so on such a device this is an exception, never a crash.
    if (!cc.device().hasExtension("cl_khr_gl_sharing")) {
        EXPECT_THROW(SharedFrameBuffer{cc}, Error);
    } else {
        EXPECT_NO_THROW(SharedFrameBuffer{cc});
    }
    // The properties name the current EGL context and its display.
    const std::vector<cl_context_properties> props = glSharingContextProperties();
    ASSERT_EQ(props.size(), 4u);
    EXPECT_EQ(props[0], CL_GL_CONTEXT_KHR);
    EXPECT_NE(props[1], 0);
    EXPECT_EQ(props[2], CL_EGL_DISPLAY_KHR);
    EXPECT_NE(props[3], 0);
}

// cl_khr_gl_sharing emulated with copies, so the shared-buffer frame path (buffer sizing, acquire, device
// copy, release, texture upload from the GL buffer, draw) runs on a device without the extension. Only the
// driver's zero-copy aliasing is not exercised: release copies the CL buffer into the GL buffer instead.
namespace emulated {
std::map<cl_mem, GLuint> glOf;
int creates = 0, acquires = 0, releases = 0;

cl_mem CL_API_CALL createFromGlBuffer(cl_context ctx, cl_mem_flags flags, cl_GLuint buffer, cl_int* err) {
    GLint size = 0;
    glBindBuffer(GL_COPY_READ_BUFFER, buffer);
    glGetBufferParameteriv(GL_COPY_READ_BUFFER, GL_BUFFER_SIZE, &size);
    glBindBuffer(GL_COPY_READ_BUFFER, 0);
    cl_mem m = clCreateBuffer(ctx, flags, std::size_t(size), nullptr, err);
    glOf[m] = buffer;
    ++creates;
    return m;
}
cl_int CL_API_CALL acquire(cl_command_queue, cl_uint, const cl_mem*, cl_uint, const cl_event*, cl_event*) {
    ++acquires;
    return CL_SUCCESS;
}
cl_int CL_API_CALL release(cl_command_queue q, cl_uint n, const cl_mem* mems, cl_uint, const cl_event*,
                           cl_event*) {
    ++releases;
    for (cl_uint i = 0; i < n; ++i) {
        std::size_t size = 0;
        clGetMemObjectInfo(mems[i], CL_MEM_SIZE, sizeof size, &size, nullptr);
        std::vector<unsigned char> host(size);
        const cl_int e = clEnqueueReadBuffer(q, mems[i], CL_TRUE, 0, size, host.data(), 0, nullptr, nullptr);
        if (e != CL_SUCCESS) return e;
        glBindBuffer(GL_COPY_WRITE_BUFFER, glOf.at(mems[i]));
        glBufferSubData(GL_COPY_WRITE_BUFFER, 0, GLsizeiptr(size), host.data());
        glBindBuffer(GL_COPY_WRITE_BUFFER, 0);
    }
    return CL_SUCCESS;
}
} // namespace emulated

TEST(ViewerGl, SharedBufferPathEqualsThePboPath) {
    gl();
    const Volume v = phantom({24, 20, 18});
    ViewerSession s(test::computeContext(), v, Scene{}, phantomTf(), {}, {});
    FramePresenter viaPbo, viaShare;
    SharedFrameBuffer shared(test::computeContext(),
                             {emulated::createFromGlBuffer, emulated::acquire, emulated::release});
    int frames = 0;
    // Two sizes and back: the shared buffer is re-made for each new size.
    for (const auto& [w, h] : {std::pair{48, 40}, std::pair{31, 57}, std::pair{48, 40}}) {
        const ViewerFrame f = s.renderFrame(w, h, false);
        OffscreenFramebuffer fb(w, h);
        viaPbo.upload(f.image);
        viaPbo.draw(w, h, {0.1, 0.2, 0.3, 1});
        const ImageBuffer a = readFramebuffer(w, h);
        shared.present(s.renderer().outputBuffer(), w, h, viaShare);
        viaShare.draw(w, h, {0.1, 0.2, 0.3, 1});
        const ImageBuffer b = readFramebuffer(w, h);
        ++frames;
        EXPECT_EQ(maxDifference255(a, b), 0.0) << w << "x" << h;
        double spread = 0.0;
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x)
                spread = std::max(spread, std::abs(double(b.at(x, y, 0) - b.at(0, 0, 0))));
        EXPECT_GT(spread, 0.05) << "the frame shows nothing";
    }
    EXPECT_EQ(emulated::creates, 3);
    EXPECT_EQ(emulated::acquires, frames);
    EXPECT_EQ(emulated::releases, frames);
    // A frame larger than the rendered buffer is refused before anything is enqueued.
    EXPECT_THROW(shared.present(s.renderer().outputBuffer(), 480, 400, viaShare), Error);
    EXPECT_EQ(emulated::acquires, frames);
    EXPECT_THROW((SharedFrameBuffer{test::computeContext(), ClGlEntryPoints{}}), Error);
}

// ---------------------------------------------------------------------------------------------------------
// Overlay: host text rasterisation, wrapping, and the blended panel in the top-left corner

TEST(ViewerOverlay, RasterisesGlyphsIntoTheirCells) {
    const TextMask m = rasteriseText({"|a", " ?", "\x01"});
    EXPECT_EQ(m.width, 2 * kGlyphWidth + 2 * kTextMargin);
    EXPECT_EQ(m.height, 3 * kGlyphHeight + 2 * kTextMargin);
    ASSERT_EQ(m.coverage.size(), std::size_t(m.width) * std::size_t(m.height));
    const auto cellCount = [&](int row, int col) {
        int n = 0;
        for (int y = 0; y < kGlyphHeight; ++y)
            for (int x = 0; x < kGlyphWidth; ++x)
                n += m.coverage[std::size_t(kTextMargin + row * kGlyphHeight + y) * std::size_t(m.width) +
                                std::size_t(kTextMargin + col * kGlyphWidth + x)] != 0;
        return n;
    };
    EXPECT_GE(cellCount(0, 0), 7);               // '|': a vertical bar
    EXPECT_GT(cellCount(0, 1), 5);               // 'a'
    EXPECT_EQ(cellCount(1, 0), 0);               // space
    EXPECT_GT(cellCount(1, 1), 5);               // '?'
    EXPECT_EQ(cellCount(2, 0), cellCount(1, 1)); // a control character is drawn as '?'
    EXPECT_EQ(cellCount(2, 1), 0);               // past the end of a short line: nothing
    // The margin stays empty.
    for (int x = 0; x < m.width; ++x)
        EXPECT_EQ(m.coverage[std::size_t(x)], 0) << x;
    EXPECT_EQ(rasteriseText({}).width, 0);
    EXPECT_EQ(rasteriseText({""}).coverage.size(), 0u);
}

TEST(ViewerOverlay, WrapsListsAtCommasWithinTheWidth) {
    const std::string list = "shading, shadows, clipping, isosurfaces 2, skipping, early termination";
    const auto lines = wrapList("compiled: ", list, 30);
    ASSERT_GT(lines.size(), 1u);
    std::string joined;
    for (const auto& l : lines) {
        EXPECT_LE(l.size(), 30u) << l;
        std::string t = l.substr(10); // the prefix, or its indentation
        joined += t;
        if (!joined.empty() && joined.back() == ',') joined += ' ';
    }
    EXPECT_EQ(lines.front().rfind("compiled: ", 0), 0u);
    EXPECT_EQ(joined, list);
    EXPECT_EQ(wrapList("x: ", "", 10), std::vector<std::string>{"x: "});
    // One item longer than the width stays whole rather than being cut.
    EXPECT_EQ(wrapList("", "abcdefghijkl", 5), std::vector<std::string>{"abcdefghijkl"});
}

TEST(ViewerOverlay, DrawsOnlyInsideItsPanelWithWhiteText) {
    gl();
    FramePresenter p;
    TextOverlay overlay;
    const int w = 160, h = 90;
    ImageBuffer f(w, h, {"R", "G", "B", "A"});
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            f.at(x, y, 0) = 0.4f * float(x) / float(w);
            f.at(x, y, 1) = 0.3f;
            f.at(x, y, 2) = 0.6f * float(y) / float(h);
            f.at(x, y, 3) = 0.8f;
        }
    OffscreenFramebuffer fb(w, h);
    p.upload(f);
    p.draw(w, h, {0, 0, 0, 1});
    const ImageBuffer plain = readFramebuffer(w, h);
    overlay.setText({"frame 12 ms", "mode dvr"});
    ASSERT_GT(overlay.width(), 0);
    ASSERT_LT(overlay.width(), w);
    ASSERT_LT(overlay.height(), h);
    overlay.draw(w, h);
    const ImageBuffer withText = readFramebuffer(w, h);
    const TextMask mask = rasteriseText({"frame 12 ms", "mode dvr"});
    int white = 0, darker = 0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const bool inside = x < mask.width && y < mask.height;
            for (int c = 0; c < 3; ++c) {
                if (!inside) {
                    ASSERT_EQ(withText.at(x, y, c), plain.at(x, y, c)) << x << "," << y;
                }
            }
            if (!inside) continue;
            const bool ink = mask.coverage[std::size_t(y) * std::size_t(mask.width) + std::size_t(x)] != 0;
            if (ink) {
                white += withText.at(x, y, 0) > 0.99f && withText.at(x, y, 1) > 0.99f &&
                         withText.at(x, y, 2) > 0.99f;
            } else {
                darker += withText.at(x, y, 1) < plain.at(x, y, 1) ? 1 : 0;
            }
        }
    int inkPixels = 0;
    for (unsigned char c : mask.coverage)
        inkPixels += c != 0;
    EXPECT_EQ(white, inkPixels);                             // every glyph pixel is white
    EXPECT_EQ(darker, mask.width * mask.height - inkPixels); // the panel darkens the rest
}

// ---------------------------------------------------------------------------------------------------------
// End to end: the frame read back from GL equals `volcl render`'s PNG for the same scene within 1/255,
// after resizes, effect toggles, mode switches, TF presets and interactive (coarse) frames in between.

namespace {

// Presents the session's full-quality frame at width x height and compares the read-back with a fresh
// GridRenderer on the same scene (what `volcl render` does), encoded as its PNG.
void expectMatchesRender(ViewerSession& s, FramePresenter& p, const Volume& v, const TransferFunction& tf,
                         int w, int h, const std::string& what) {
    const ViewerFrame f = s.renderFrame(w, h, false);
    ASSERT_EQ(f.image.width, w);
    ASSERT_EQ(f.image.height, h);
    OffscreenFramebuffer fb(w, h);
    p.upload(f.image);
    p.draw(w, h, s.currentScene().background);
    const ImageBuffer back = readFramebuffer(w, h);

    Scene scene = s.currentScene();
    scene.width = w;
    scene.height = h;
    GridRenderer fresh(test::computeContext(), v, tf, scene);
    const ImageBuffer ref = pngEncoding(fresh.render(), scene.background);
    EXPECT_LE(maxDifference255(back, ref), 1.0) << what << " (" << s.compiledSummary() << ")";
    // The frame is not trivially empty: some pixel differs from the background.
    double spread = 0.0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < 3; ++c)
                spread = std::max(spread, std::abs(double(back.at(x, y, c) - back.at(0, 0, c))));
    EXPECT_GT(spread, 0.05) << what << ": the frame shows nothing";
}

} // namespace

TEST(ViewerEndToEnd, ReadBackEqualsRenderAfterResizesAndToggles) {
    gl();
    FramePresenter p;
    const Volume v = phantom({40, 33, 29});
    TransferFunction tf = phantomTf();
    Scene scene;
    scene.width = 64;
    scene.height = 48;
    scene.step = 0.5;
    ViewerSession s(test::computeContext(), v, scene, tf, {}, {});
    expectMatchesRender(s, p, v, tf, 64, 48, "first frame");
    s.camera().orbit(0.6, 0.3);
    expectMatchesRender(s, p, v, tf, 45, 71, "resized to 45x71 after an orbit");
    // An interactive (coarse) frame in between must not leak into the next full frame.
    s.camera().orbit(0.2, 0.0);
    const ViewerFrame coarse = s.renderFrame(45, 71, true);
    EXPECT_GT(coarse.image.width, 0);
    s.apply(ViewerAction::ToggleShading);
    expectMatchesRender(s, p, v, tf, 45, 71, "shading on");
    // The summary (window title) describes the kernel of the frame just rendered.
    EXPECT_NE(s.compiledSummary().find("shading"), std::string::npos);
    s.apply(ViewerAction::ToggleShadows);
    expectMatchesRender(s, p, v, tf, 33, 33, "shadows on, resized to 33x33");
    EXPECT_NE(s.compiledSummary().find("shadows"), std::string::npos);
    s.apply(ViewerAction::ToggleShadows);
    s.apply(ViewerAction::ToggleShading);
    s.apply(ViewerAction::ToggleClipping);
    expectMatchesRender(s, p, v, tf, 64, 48, "clipping on");
    EXPECT_NE(s.compiledSummary().find("clipping"), std::string::npos);
    s.apply(ViewerAction::ToggleClipping);
    s.apply(ViewerAction::CycleMode); // mip
    expectMatchesRender(s, p, v, tf, 64, 48, "mip");
    s.apply(ViewerAction::CycleMode); // iso (adds a surface)
    expectMatchesRender(s, p, v, tf, 64, 48, "iso");
    EXPECT_NE(s.compiledSummary().find("isosurfaces"), std::string::npos);
    s.apply(ViewerAction::CycleMode); // xray
    expectMatchesRender(s, p, v, tf, 64, 48, "xray");
    s.apply(ViewerAction::CycleMode); // emission
    expectMatchesRender(s, p, v, tf, 64, 48, "emission");
    s.apply(ViewerAction::CycleMode); // back to dvr
    s.apply(ViewerAction::CycleTfPreset);
    EXPECT_EQ(s.tfPresetName(), "grey ramp");
    expectMatchesRender(s, p, v, transferFunctionPresets(v, tf)[1].tf, 64, 48, "grey ramp preset");
}

TEST(ViewerEndToEnd, InteractiveFramesAreCoarserAndReportedFramesSteerTheController) {
    gl();
    FramePresenter p;
    const Volume v = phantom({40, 33, 29});
    Scene scene;
    scene.step = 0.25;
    AdaptiveQualityOptions ao;
    ao.targetMs = 1.0; // far below what any frame takes: the controller must coarsen
    ViewerSession s(test::computeContext(), v, scene, phantomTf(), {}, ao);
    s.renderFrame(96, 96, false); // builds the kernel
    ViewerFrame f;
    for (int i = 0; i < 6; ++i) {
        f = s.renderFrame(96, 96, true);
        s.frameDone(f, 1000.0);
    }
    EXPECT_LT(f.image.width, 96);
    EXPECT_GT(f.level.stepScale, 1.0);
    EXPECT_NEAR(f.level.resolutionScale, double(f.image.width) / 96.0, 0.02);
    const ViewerFrame still = s.renderFrame(96, 96, false);
    EXPECT_EQ(still.image.width, 96);
    EXPECT_TRUE(still.level.full());
}

TEST(ViewerEndToEnd, AdaptiveQualityReactsWithPreintegration) {
    // Before: every step change rebuilt the 2D table, the frame counted as a structure change and was never
    // reported, so the controller held full quality however slow the frames were.
    const Volume v = phantom({40, 33, 29});
    Scene scene;
    scene.step = 0.25;
    scene.preintegration = Preintegration::Table2d;
    // Skipping on: with auto, a step in a new octave measures the skip choice and may recompile the kernel
    // (a structure change by design); this test is about the tables alone.
    scene.skipping = SkipMode::On;
    AdaptiveQualityOptions ao;
    ao.targetMs = 1.0;
    ViewerSession s(test::computeContext(), v, scene, phantomTf(), {}, ao);
    s.renderFrame(96, 96, false);
    ViewerFrame f;
    bool sawTable = false;
    // Scripted frame sequence: each interactive frame "took" 1000 ms plus its own table build.
    for (int i = 0; i < 6; ++i) {
        f = s.renderFrame(96, 96, true);
        sawTable = sawTable || f.tableMs > 0.0;
        EXPECT_FALSE(f.structureChanged) << "frame " << i;
        s.frameDone(f, 1000.0 + f.tableMs);
    }
    EXPECT_TRUE(sawTable); // the step did change, so tables were rebuilt on the way
    EXPECT_LT(f.image.width, 96);
    EXPECT_GT(f.level.stepScale, 1.0);
    // The table build is kept out of the measurement: a level reported at exactly the controller's aim
    // (0.9 of the target) plus a long table build keeps its work instead of shrinking.
    AdaptiveQualityOptions hold;
    hold.targetMs = 100.0;
    ViewerSession h(test::computeContext(), v, scene, phantomTf(), {}, hold);
    h.renderFrame(96, 96, false);
    h.frameDone(h.renderFrame(96, 96, true), 400.0); // coarsen once: the next frame needs a new table
    ViewerFrame g = h.renderFrame(96, 96, true);
    ASSERT_GT(g.tableMs, 0.0);
    h.frameDone(g, 90.0 + g.tableMs);
    const ViewerFrame after = h.renderFrame(96, 96, true);
    EXPECT_NEAR(after.level.work(), g.level.work(), 0.05 * g.level.work() + 1e-3);
}

TEST(ViewerEndToEnd, OverlayLinesNameLevelEffectsAndTransport) {
    const Volume v = phantom({20, 18, 16});
    Scene scene;
    scene.effects.shading = true;
    scene.lights.push_back(Light{});
    ViewerSession s(test::computeContext(), v, scene, phantomTf(), {}, {});
    const ViewerFrame f = s.renderFrame(40, 30, false);
    const auto lines = overlayLines(s, f, 123.0, FrameTransport::Pbo, 40);
    std::string all;
    for (const auto& l : lines) {
        EXPECT_LE(l.size(), 40u) << l;
        all += l + "\n";
    }
    EXPECT_NE(all.find("last frame 123 ms"), std::string::npos) << all;
    EXPECT_NE(all.find("8.1 fps"), std::string::npos) << all;
    EXPECT_NE(all.find("render 40x30 step"), std::string::npos) << all;
    EXPECT_NE(all.find("adaptive: target 100 ms"), std::string::npos) << all;
    EXPECT_NE(all.find("mode dvr"), std::string::npos) << all;
    EXPECT_NE(all.find("shading"), std::string::npos) << all;
    EXPECT_NE(all.find("transport: pixel buffer object"), std::string::npos) << all;
}

TEST(ViewerEndToEnd, ReloadKeepsTheCurrentTfOnABrokenFile) {
    const auto dir = test::tempDir("viewer_reload");
    const auto tfPath = dir / "tf.json";
    { std::ofstream(tfPath) << phantomTf().toJson(); }
    const Volume v = phantom({12, 10, 8});
    Scene scene;
    scene.width = scene.height = 16;
    ViewerSession s(test::computeContext(), v, scene, TransferFunction::fromFile(tfPath), tfPath, {});
    EXPECT_NE(s.apply(ViewerAction::ReloadTf).find("reloaded"), std::string::npos);
    {
        std::ofstream(tfPath) << "{\"domain\": [0, 255], \"color\": ["; // half-written by an editor
    }
    const std::string msg = s.apply(ViewerAction::ReloadTf);
    EXPECT_NE(msg.find("reload failed"), std::string::npos) << msg;
    EXPECT_NO_THROW(s.renderFrame(16, 16, false));
}

TEST(ViewerEndToEnd, HeadlessRunOnTheMriMatchesRender) {
    std::filesystem::path data;
    VOLCL_REQUIRE_SHARED_DATA(data);
    const auto path = data / "regular" / "t1_icbm_normal_1mm_pn0_rf0_180x216x180_uint8_1x1.bin-gz";
    if (!std::filesystem::exists(path)) GTEST_SKIP() << path << " is absent";
    const Volume v = readVolume(path);
    const TransferFunction tf = transferFunctionPresets(v, std::nullopt)[1].tf; // "hot above 30%"
    Scene scene;
    scene.width = 96;
    scene.height = 80;
    scene.step = 1.0;
    ViewerSession s(test::computeContext(), v, scene, tf, {}, {});
    HeadlessOptions o;
    o.width = 96;
    o.height = 80;
    o.frames = 4;
    o.orbitDegrees = 10.0;
    o.keys = "1";
    o.quiet = true;
    std::ostringstream log;
    const HeadlessResult r = runHeadless(s, o, log);
    ASSERT_EQ(r.frames.size(), 4u);
    EXPECT_FALSE(r.frames[0].interactive);
    EXPECT_TRUE(r.frames[1].interactive);
    EXPECT_FALSE(r.frames.back().interactive);
    Scene now = s.currentScene();
    GridRenderer fresh(test::computeContext(), v, tf, now);
    EXPECT_LE(maxDifference255(r.readback, pngEncoding(fresh.render(), now.background)), 1.0);
}

// Multiple scattering converges over still frames (4 more samples per pixel each) and starts over when the
// view moves; two still frames equal the renderer's 8-sample image.
TEST(ViewerSession, PathTracingAccumulatesWhileTheViewStandsStill) {
    const Volume v = phantom({24, 20, 18});
    const TransferFunction tf = phantomTf();
    Scene scene;
    scene.width = 16;
    scene.height = 16;
    scene.step = 0.5;
    scene.lights = {Light{LightKind::Directional, {0.3, 0.5, -0.8}, {1, 1, 1}, 2.0}};
    scene.effects.scattering = true;
    scene.effects.albedo = 0.9;
    scene.effects.scatteringOrder = ScatteringOrder::Multiple;
    ViewerSession s(test::computeContext(), v, scene, tf, {}, {});
    const ViewerFrame a = s.renderFrame(16, 16, false);
    ASSERT_TRUE(s.renderer().plan().pathTracing);
    const ViewerFrame b = s.renderFrame(16, 16, false);
    EXPECT_NE(a.image.pixels, b.image.pixels);
    Scene now = s.currentScene();
    now.effects.samples = 8;
    EXPECT_EQ(b.image.pixels, GridRenderer(test::computeContext(), v, tf, now).render().pixels);
    s.camera().orbit(0.3, 0.0);
    const ViewerFrame c = s.renderFrame(16, 16, false); // a new view: 4 samples again
    now = s.currentScene();
    now.effects.samples = 4;
    EXPECT_EQ(c.image.pixels, GridRenderer(test::computeContext(), v, tf, now).render().pixels);
}

TEST(ViewerSession, PreviewTiersWhileMovingThenRefineToTheRayMarcher) {
    // Scripted camera: an orbit of interactive frames, then the view stops. Moving frames use the preview tier
    // (shear-warp for the orthographic camera, discrete ray casting for a perspective one) under their own
    // controller; still frames blend the ray marcher's frame in and show it alone by the 5th frame.
    const Volume v = phantom({40, 33, 29});
    const TransferFunction tf = phantomTf();
    for (Projection projection : {Projection::Orthographic, Projection::Perspective}) {
        Scene scene;
        scene.step = 0.5;
        Camera cam = defaultCamera(v);
        cam.projection = projection;
        scene.camera = cam;
        AdaptiveQualityOptions ao;
        ao.previewTiers = true;
        ao.targetMs = 1.0; // far below any frame: the tier's controller must lower the resolution
        ViewerSession s(test::computeContext(), v, scene, tf, {}, ao);
        const GridMethod tier =
            projection == Projection::Orthographic ? GridMethod::ShearWarp : GridMethod::Drc;
        EXPECT_EQ(s.previewTier(), tier);
        s.frameDone(s.renderFrame(64, 64, false), 50.0);
        ViewerFrame f;
        for (int i = 0; i < 6; ++i) {
            s.camera().orbit(0.15, 0.05);
            f = s.renderFrame(64, 64, true);
            s.frameDone(f, 1000.0);
            EXPECT_EQ(f.level.tier, tier) << "frame " << i;
            EXPECT_EQ(f.level.stepScale, 1.0);
            EXPECT_EQ(f.refinePass, 0);
        }
        EXPECT_LT(f.image.width, 64) << "the tier's controller lowered the resolution";
        EXPECT_TRUE(s.refining());
        Scene now = s.currentScene();
        now.width = 64;
        now.height = 64;
        const ImageBuffer marched = GridRenderer(test::computeContext(), v, tf, now).render();
        double lastError = std::numeric_limits<double>::infinity();
        int frames = 0;
        while (s.refining()) {
            const ViewerFrame still = s.renderFrame(64, 64, false);
            s.frameDone(still, 500.0);
            ++frames;
            ASSERT_LE(frames, 5) << "refinement must end within 5 frames";
            EXPECT_EQ(still.refinePass, frames);
            ASSERT_EQ(still.image.width, 64);
            // Each pass is closer to the ray marcher's frame: no jump back, no jump ahead past it.
            const double e = imageRmse(still.image, marched);
            EXPECT_LE(e, lastError + 1e-7) << "pass " << frames;
            lastError = e;
        }
        EXPECT_EQ(frames, ViewerSession::kRefinePasses);
        EXPECT_LE(lastError, 1e-6) << "the refined frame is the ray marcher's";
        const ViewerFrame after = s.renderFrame(64, 64, false);
        EXPECT_TRUE(after.level.full());
        EXPECT_EQ(after.refinePass, 0);
        EXPECT_LE(imageRmse(after.image, marched), 1e-6);
        // Shading is beyond the tiers: a moving view goes back to the coarse ray marcher.
        s.apply(ViewerAction::ToggleShading);
        EXPECT_EQ(s.previewTier(), GridMethod::Raymarch);
        s.camera().orbit(0.1, 0.0);
        EXPECT_EQ(s.renderFrame(64, 64, true).level.tier, GridMethod::Raymarch);
        EXPECT_FALSE(s.refining());
    }
}

TEST(AdaptiveQuality, FaceLevelsSpendTheWorkOnFacesFirst) {
    AdaptiveQuality aq({.faceLevels = true, .minFaceFraction = 0.05});
    for (double w : {1.0, 0.5, 0.1, 0.05}) {
        const QualityLevel q = aq.split(w);
        EXPECT_NEAR(q.faceFraction, w, 1e-12);
        EXPECT_EQ(q.resolutionScale, 1.0);
        EXPECT_EQ(q.stepScale, 1.0);
    }
    const QualityLevel low = aq.split(0.0125); // below the face limit: the resolution takes the rest
    EXPECT_NEAR(low.faceFraction, 0.05, 1e-12);
    EXPECT_NEAR(low.resolutionScale, 0.5, 1e-9);
    EXPECT_NEAR(low.work(), 0.0125, 1e-9);
    EXPECT_FALSE(low.full());
    EXPECT_THROW(AdaptiveQuality({.minFaceFraction = 0.0}), UsageError);
}

TEST(ViewerSession, KBufferMeshDropsFacesWhileMovingAndRefinesWhenStill) {
    // A k-buffer mesh in the viewer: interactive frames over the target draw fewer internal faces at the full
    // viewport size (the boundary always stays), a still frame draws every face and equals a fresh render.
    const mesh::TetMesh m = mesh::marschnerLobbMesh(12);
    TransferFunction tf;
    tf.domain = {m.valueMin, m.valueMax};
    tf.color = {{m.valueMin, {0.2, 0.4, 1.0}}, {m.valueMax, {1.0, 0.8, 0.3}}};
    tf.extinction = {{m.valueMin, 0.5}, {m.valueMax, 4.0}};
    Scene scene;
    scene.meshMethod = MeshMethod::KBuffer;
    scene.kBufferDepth = 6;
    scene.earlyTermination = 1.0;
    AdaptiveQualityOptions ao;
    ao.targetMs = 100.0;
    ViewerSession s(test::computeContext(), RenderInput::borrowMesh(m), scene, tf, {}, ao);
    EXPECT_TRUE(s.adaptive().options().faceLevels);
    const ViewerFrame first = s.renderFrame(64, 64, false);
    EXPECT_TRUE(first.level.full());
    const auto* kb = dynamic_cast<const KBufferRenderer*>(&s.renderer());
    ASSERT_NE(kb, nullptr);
    const std::size_t allFaces = kb->facesDrawn();
    ViewerFrame f;
    for (int i = 0; i < 3; ++i) { // each frame "took" 400 ms (four times the target) plus its table build
        s.camera().orbit(0.05, 0.0);
        f = s.renderFrame(64, 64, true);
        s.frameDone(f, 400.0 + f.tableMs);
    }
    EXPECT_LT(f.level.faceFraction, 0.3);
    EXPECT_EQ(f.image.width, 64); // faces go first: the resolution is kept
    EXPECT_LT(kb->facesDrawn(), allFaces);
    EXPECT_GE(kb->facesDrawn(), kb->faces().boundaryCount);
    EXPECT_NE(s.title(f, 400.0).find("faces"), std::string::npos);
    const ViewerFrame still = s.renderFrame(64, 64, false);
    EXPECT_TRUE(still.level.full());
    EXPECT_EQ(kb->facesDrawn(), allFaces);
    Scene now = s.currentScene();
    now.width = 64;
    now.height = 64;
    KBufferRenderer fresh(test::computeContext(), m, tf, now, 6);
    EXPECT_EQ(still.image.pixels, fresh.render().pixels);
}
