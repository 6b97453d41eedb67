// Ray marcher tests: analytic scenes, kernel vs double reference, skipping, effect planning, hard cases, real
// data.
#include "TestUtil.hpp"

#include "core/Error.hpp"
#include "core/Volume.hpp"
#include "host/io/VolumeIo.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/Scene.hpp"
#include "render/grid/GridRenderer.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>

namespace {

using namespace volcl;
using volcl::test::computeContext;
using volcl::test::makeFloatVolume;
using volcl::test::orthoScene;

TransferFunction constantTf(double tau, std::array<double, 3> rgb = {1.0, 0.5, 0.25}) {
    TransferFunction tf;
    tf.domain = {0.0, 2.0};
    tf.color = {{0.0, rgb}};
    tf.extinction = {{0.0, tau}};
    return tf;
}

double maxAbsDiff(const ImageBuffer& a, const ImageBuffer& b, int channels = 4) {
    double m = 0.0;
    for (int y = 0; y < a.height; ++y)
        for (int x = 0; x < a.width; ++x)
            for (int c = 0; c < channels; ++c)
                m = std::max(m, std::abs(double(a.at(x, y, c)) - double(b.at(x, y, c))));
    return m;
}

void expectFiniteBounded(const ImageBuffer& img) {
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x)
            for (int c = 0; c < 4; ++c) {
                const float v = img.at(x, y, c);
                ASSERT_TRUE(std::isfinite(v)) << x << "," << y << "," << c;
                ASSERT_GE(v, -1e-6f);
                ASSERT_LE(v, 1.0f + 1e-5f);
            }
}

TEST(Render, ConstantBoxMatchesBeerLambert) {
    const Dims n{17, 17, 17};
    const Volume v = makeFloatVolume(n, [](double, double, double) { return 1.0f; });
    const TransferFunction tf = constantTf(0.1);
    const double alpha = 1.0 - std::exp(-0.1 * 16.0);
    for (Preintegration pre : {Preintegration::None, Preintegration::Table2d, Preintegration::Table3d}) {
        for (double step : {0.3, 1.0, 5.0}) {
            Scene s = orthoScene(n, 8.0);
            s.preintegration = pre;
            s.step = step;
            GridRenderer r(computeContext(), v, tf, s);
            const ImageBuffer img = r.render();
            for (int y = 0; y < 8; ++y)
                for (int x = 0; x < 8; ++x) {
                    EXPECT_NEAR(img.at(x, y, 3), alpha, 2e-5) << preintegrationName(pre) << " step " << step;
                    EXPECT_NEAR(img.at(x, y, 0), alpha, 2e-5);
                    EXPECT_NEAR(img.at(x, y, 2), 0.25 * alpha, 2e-5);
                }
        }
    }
    const ImageBuffer ref = referenceRender(v, tf, orthoScene(n, 8.0));
    EXPECT_NEAR(ref.at(3, 3, 3), alpha, 1e-7); // the image stores float
    EXPECT_NEAR(ref.at(3, 3, 1), 0.5 * alpha, 1e-7);
}

TEST(Render, LinearRampOpticalDepth) {
    // s = z along the ray, tau(s) = 0.02 s: optical depth over z in [0, 31] is 0.01 * 31^2.
    const Dims n{9, 9, 32};
    const Volume v = makeFloatVolume(n, [](double, double, double z) { return float(z); });
    TransferFunction tf;
    tf.domain = {0, 31};
    tf.color = {{0, {0.0, 1.0, 0.0}}, {31, {1.0, 1.0, 0.0}}};
    tf.extinction = {{0, 0.0}, {31, 0.62}};
    const double alpha = 1.0 - std::exp(-0.01 * 31 * 31);
    // Colour: integral of c(s) tau(s) T(s) ds with c_r = s / 31, in closed form by fine quadrature.
    double red = 0.0, T = 1.0;
    const int m = 200000;
    for (int i = 0; i < m; ++i) {
        const double s = (i + 0.5) * 31.0 / m, ds = 31.0 / m;
        red += (s / 31.0) * 0.02 * s * T * ds;
        T *= std::exp(-0.02 * s * ds);
    }
    Scene s = orthoScene(n, 4.0, 4, 4);
    const ImageBuffer ref = referenceRender(v, tf, s);
    EXPECT_NEAR(ref.at(1, 1, 3), alpha, 1e-9);
    EXPECT_NEAR(ref.at(1, 1, 0), red, 1e-5);
    EXPECT_NEAR(ref.at(1, 1, 1), alpha, 1e-9);
    for (Preintegration pre : {Preintegration::None, Preintegration::Table2d, Preintegration::Table3d}) {
        s.preintegration = pre;
        s.step = 0.5;
        const ImageBuffer img = GridRenderer(computeContext(), v, tf, s).render();
        EXPECT_NEAR(img.at(1, 1, 3), alpha, 1e-4) << preintegrationName(pre);
        EXPECT_NEAR(img.at(1, 1, 0), red, 2e-3) << preintegrationName(pre);
    }
}

TEST(Render, ReferenceConvergesWithStep) {
    const Dims n{24, 20, 18};
    const Volume v = makeFloatVolume(n, [](double x, double y, double z) {
        return float(1.0 + std::sin(0.5 * x) * std::cos(0.4 * y) * std::sin(0.3 * z + 1.0));
    });
    TransferFunction tf;
    tf.domain = {0, 2};
    tf.color = {{0, {0.1, 0.2, 1.0}}, {1.2, {1.0, 0.5, 0.1}}, {2, {1.0, 1.0, 1.0}}};
    tf.extinction = {{0, 0.0}, {0.8, 0.0}, {1.5, 0.6}, {2, 0.1}};
    Scene s = orthoScene(n, 24.0, 24, 24);
    const ImageBuffer a = referenceRender(v, tf, s, {.step = 0.05});
    const ImageBuffer b = referenceRender(v, tf, s, {.step = 0.025});
    EXPECT_LT(imageRmse(a, b), 5e-5);
    s.step = 0.25;
    s.preintegration = Preintegration::Table2d;
    const ImageBuffer k = GridRenderer(computeContext(), v, tf, s).render();
    EXPECT_LT(imageRmse(k, b), 2e-3);
}

TEST(Render, SphereIsoHitsAnalyticSurface) {
    const Dims n{48, 48, 48};
    const double c = 23.5, R = 17.0;
    const Volume v = makeFloatVolume(n, [&](double x, double y, double z) {
        return float((x - c) * (x - c) + (y - c) * (y - c) + (z - c) * (z - c));
    });
    TransferFunction tf = constantTf(0.0);
    tf.domain = {0, 2000};
    Scene s;
    Camera cam;
    cam.target = {c, c, c};
    cam.eye = {c, c, -40.0};
    cam.height = 40.0;
    s.camera = cam;
    s.width = s.height = 32;
    s.mode = RenderMode::Iso;
    s.step = 0.5;
    s.effects.isosurfaces = {{R * R, {1, 1, 1, 1}}};
    GridRenderer r(computeContext(), v, tf, s);
    const ImageBuffer img = r.render();
    ASSERT_EQ(img.channelCount(), 5);
    const ImageBuffer ref = referenceRender(v, tf, s, {.step = 0.05});
    double worstRoot = 0.0, worstSphere = 0.0;
    int hits = 0;
    for (int y = 0; y < 32; ++y)
        for (int x = 0; x < 32; ++x) {
            const CameraRay ray = cameraRay(cam, 32, 32, x, y);
            const double dx = ray.origin[0] - c, dy = ray.origin[1] - c;
            const double r2 = R * R - dx * dx - dy * dy;
            const float depth = img.at(x, y, 4);
            if (r2 < 4.0 * R) continue; // near the silhouette a grazing ray may legitimately differ
            ++hits;
            ASSERT_TRUE(std::isfinite(depth)) << x << "," << y;
            worstRoot = std::max(worstRoot, std::abs(double(depth) - double(ref.at(x, y, 4))));
            const double exact = (c - std::sqrt(r2)) - ray.origin[2];
            // |x - c|^2 is not trilinear: interpolation changes the value by at most 3 * 0.25 voxel^2, which
            // moves the hit along the ray by at most that over |d(value)/dz| = 2 sqrt(r2).
            worstSphere =
                std::max(worstSphere, std::abs(double(depth) - exact) / (0.75 / (2.0 * std::sqrt(r2))));
            EXPECT_EQ(img.at(x, y, 3), 1.0f);
        }
    EXPECT_GT(hits, 300);
    // Root of the trilinear field (reference bisection in double): float bisection gets within 1e-4 voxel.
    EXPECT_LT(worstRoot, 1e-4);
    // Every hit lies within the interpolation bound of the analytic sphere (ratio to the bound < 1).
    EXPECT_LT(worstSphere, 1.0);
    RecordProperty("worst_root_error_voxels", std::to_string(worstRoot));
    RecordProperty("worst_sphere_error_over_bound", std::to_string(worstSphere));
    // No hit outside the sphere.
    EXPECT_TRUE(std::isinf(img.at(0, 0, 4)));
    EXPECT_EQ(img.at(0, 0, 3), 0.0f);
}

TEST(Render, TransparentIsoSurfacesCompositeInOrder) {
    const Dims n{32, 32, 32};
    const double c = 15.5;
    const Volume v = makeFloatVolume(n, [&](double x, double y, double z) {
        return float(std::sqrt((x - c) * (x - c) + (y - c) * (y - c) + (z - c) * (z - c)));
    });
    TransferFunction tf = constantTf(0.0);
    tf.domain = {0, 30};
    Scene s = orthoScene(n, 6.0, 6, 6);
    s.mode = RenderMode::Iso;
    s.effects.isosurfaces = {{12.0, {1, 0, 0, 0.5}}, {6.0, {0, 0, 1, 1.0}}};
    const ImageBuffer img = GridRenderer(computeContext(), v, tf, s).render();
    // Central ray: outer red shell first (half), then the inner opaque blue shell, then red again behind it.
    EXPECT_NEAR(img.at(3, 3, 0), 0.5, 1e-6);
    EXPECT_NEAR(img.at(3, 3, 2), 0.5, 1e-6);
    EXPECT_NEAR(img.at(3, 3, 3), 1.0, 1e-6);
    const ImageBuffer ref = referenceRender(v, tf, s);
    EXPECT_LT(maxAbsDiff(img, ref), 1e-5);
}

TEST(Render, SkippingChangesNothingBeyondFloatNoise) {
    const Dims n{40, 36, 30};
    const Volume v = makeFloatVolume(n, [](double x, double y, double z) {
        const double r = std::sqrt((x - 20) * (x - 20) + (y - 18) * (y - 18) + (z - 15) * (z - 15));
        return float(std::max(0.0, 100.0 - 9.0 * r) + (x > 30 ? 40.0 : 0.0));
    });
    TransferFunction tf;
    tf.domain = {0, 100};
    tf.color = {{0, {1, 1, 1}}, {100, {1, 0.3, 0.1}}};
    tf.extinction = {{0, 0.0}, {45, 0.0}, {60, 0.3}, {100, 1.0}};
    for (Preintegration pre : {Preintegration::None, Preintegration::Table2d, Preintegration::Table3d})
        for (RenderMode mode : {RenderMode::Dvr, RenderMode::Iso}) {
            Scene s = orthoScene(n, 42.0, 48, 40);
            Camera cam = *s.camera;
            cam.eye = {-30, 70, -40};
            s.camera = cam;
            s.mode = mode;
            s.preintegration = pre;
            s.step = 0.7;
            s.effects.isosurfaces = {{70.0, {0.2, 0.9, 0.2, 0.6}}};
            GridRenderer r(computeContext(), v, tf, s);
            const ImageBuffer on = r.render();
            EXPECT_GT(r.emptyMacrocellFraction(), 0.2);
            s.skipping = SkipMode::Off;
            r.setScene(s);
            const ImageBuffer off = r.render();
            EXPECT_LT(maxAbsDiff(on, off), 2e-6) << renderModeName(mode) << " " << preintegrationName(pre);
        }
}

TEST(Render, PlainKernelMatchesBaseline) {
    const Dims n{20, 20, 20};
    const Volume v =
        makeFloatVolume(n, [](double x, double y, double z) { return float(x + 0.5 * y + 0.25 * z); });
    TransferFunction tf;
    tf.domain = {0, 35};
    tf.color = {{0, {0, 0, 1}}, {35, {1, 0, 0}}};
    tf.extinction = {{0, 0.0}, {35, 0.3}};
    Scene s = orthoScene(n, 22.0, 16, 16);
    s.skipping = SkipMode::Off;
    s.earlyTermination = 0.99;
    GridRenderer r(computeContext(), v, tf, s);
    EXPECT_EQ(r.plan().defines.toOptions(), "-DEARLY_TERMINATION -DMODE=0 -DVOXEL_TYPE=0");
    EXPECT_LT(maxAbsDiff(r.render(), r.renderPlainBaseline()), 1e-7);
}

TEST(Render, EffectsCompiledOnlyWhenTheyMatter) {
    const Dims n{16, 16, 16};
    const Volume v = makeFloatVolume(n, [](double x, double, double) { return float(x); });
    TransferFunction tf;
    tf.domain = {0, 15};
    tf.color = {{0, {1, 1, 1}}};
    tf.extinction = {{0, 0.1}};
    Scene s = orthoScene(n, 16.0);
    s.effects.shading = true;
    s.effects.shadows = true;
    s.effects.scattering = true;
    s.effects.albedo = 0.0;
    s.effects.gradient = GradientKind::Sobel;
    s.effects.isosurfaces = {{100.0, {1, 1, 1, 1}}, {5.0, {1, 1, 1, 0.0}}};
    s.effects.clipPlanes = {{{1, 0, 0}, 10.0}}; // x >= -10: keeps everything
    EffectPlan p = planEffects(s, v, tf);
    EXPECT_FALSE(p.shading);
    EXPECT_FALSE(p.shadows);
    EXPECT_FALSE(p.scattering);
    EXPECT_FALSE(p.clipping);
    EXPECT_FALSE(p.sobel);
    EXPECT_TRUE(p.isosurfaces.empty());
    EXPECT_EQ(p.dropped.size(), 7u) << p.explain();
    const std::string text = p.explain();
    for (const char* word : {"no light", "albedo 0", "nothing is lit", "outside the data range", "opacity 0",
                             "keeps the whole volume", "nothing uses gradients"})
        EXPECT_NE(text.find(word), std::string::npos) << word << "\n" << text;

    // Zero diffuse and specular: no gradients; the image equals the reference with shading on.
    s.lights = {Light{LightKind::Directional, {0, 0, -1}, {1, 1, 1}, 1.0}};
    s.effects.diffuse = 0.0;
    s.effects.specular = 0.0;
    s.effects.ambient = 0.4;
    p = planEffects(s, v, tf);
    EXPECT_FALSE(p.shading);
    EXPECT_EQ(p.colorScale, 0.4);
    GridRenderer r(computeContext(), v, tf, s);
    EXPECT_LT(maxAbsDiff(r.render(), referenceRender(v, tf, s)), 1e-4);

    // A light and diffuse shading: shading, Sobel and shadows compiled.
    s.effects.diffuse = 0.7;
    s.effects.clipPlanes = {{{1, 0, 0}, -7.5}};
    p = planEffects(s, v, tf);
    EXPECT_TRUE(p.shading && p.sobel && p.shadows && p.clipping);
}

TEST(Render, ShadingShadowsScatteringAndClippingMatchReference) {
    const Dims n{24, 24, 24};
    const Volume v = makeFloatVolume(n, [](double x, double y, double z) {
        const double r =
            std::sqrt((x - 11.5) * (x - 11.5) + (y - 11.5) * (y - 11.5) + (z - 11.5) * (z - 11.5));
        return float(std::max(0.0, 10.0 - r));
    });
    TransferFunction tf;
    tf.domain = {0, 10};
    tf.color = {{0, {1, 0.8, 0.6}}, {10, {0.6, 0.8, 1}}};
    tf.extinction = {{0, 0.0}, {2, 0.0}, {6, 0.4}, {10, 0.8}};
    Scene s = orthoScene(n, 26.0, 20, 20);
    s.step = 0.1;
    s.lights = {Light{LightKind::Directional, {0.3, 0.5, -0.8}, {1, 1, 1}, 1.0},
                Light{LightKind::Point, {40, 12, 0}, {0.5, 0.4, 0.3}, 1.0}};
    s.effects.shading = true;
    s.effects.shadows = true;
    s.effects.shadowStep = 0.1;
    s.effects.scattering = true;
    s.effects.albedo = 0.6;
    s.effects.phaseG = 0.4;
    s.effects.clipPlanes = {{{0, -1, 0}, 17.0}};
    GridRenderer r(computeContext(), v, tf, s);
    EXPECT_TRUE(r.plan().shading && r.plan().shadows && r.plan().scattering && r.plan().clipping);
    const ImageBuffer img = r.render();
    expectFiniteBounded(img);
    const ImageBuffer ref = referenceRender(v, tf, s, {.step = 0.025});
    EXPECT_LT(imageRmse(img, ref), 3e-3);
    // The clip plane removes y > 17: top rows see less.
    EXPECT_GT(img.at(10, 0, 3) + 0.05f, 0.0f);
}

TEST(Render, MipAndXrayMatchReference) {
    const Dims n{30, 26, 22};
    const Volume v = makeFloatVolume(n, [](double x, double y, double z) {
        return float(50.0 + 40.0 * std::sin(0.3 * x) * std::cos(0.25 * y + 0.1 * z));
    });
    TransferFunction tf;
    tf.domain = {0, 100};
    tf.color = {{0, {0, 0, 0}}, {100, {1, 1, 1}}};
    tf.extinction = {{0, 0.0}, {100, 0.5}};
    for (RenderMode mode : {RenderMode::Mip, RenderMode::Xray}) {
        Scene s = orthoScene(n, 32.0, 24, 20);
        s.mode = mode;
        s.step = 0.25;
        const ImageBuffer img = GridRenderer(computeContext(), v, tf, s).render();
        const ImageBuffer ref = referenceRender(v, tf, s);
        EXPECT_LT(imageRmse(img, ref), 2e-3) << renderModeName(mode);
        expectFiniteBounded(img);
    }
}

TEST(Render, HardGeometry) {
    const Dims n{16, 16, 16};
    const Volume v =
        makeFloatVolume(n, [](double x, double y, double z) { return float((x + y + z) / 45.0); });
    TransferFunction tf;
    tf.domain = {0, 1};
    tf.color = {{0, {1, 0, 0}}, {1, {0, 0, 1}}};
    tf.extinction = {{0, 0.05}, {1, 0.3}};
    struct Case {
        const char* name;
        Camera cam;
        int w, h;
    };
    std::vector<Case> cases;
    Camera edge; // rays exactly along the box face x = 0 and the edge x = y = 0
    edge.target = {0, 0, 7.5};
    edge.eye = {0, 0, -20};
    edge.height = 2.0;
    cases.push_back({"edges", edge, 2, 2});
    Camera diag; // the main diagonal through two corners
    diag.eye = {-10, -10, -10};
    diag.target = {15, 15, 15};
    diag.height = 3.0;
    cases.push_back({"diagonal", diag, 3, 3});
    Camera graze; // grazing the top face
    graze.eye = {7.5, 15.0, -30};
    graze.target = {7.5, 15.0, 7.5};
    graze.height = 1e-4;
    cases.push_back({"grazing", graze, 1, 1});
    Camera inside; // perspective camera inside the volume
    inside.projection = Projection::Perspective;
    inside.eye = {7.5, 7.5, 7.5};
    inside.target = {15, 9, 7.5};
    inside.fovYDeg = 120.0;
    cases.push_back({"inside", inside, 7, 5});
    Camera oneByOne = diag;
    cases.push_back({"1x1", oneByOne, 1, 1});
    Camera wide = edge;
    wide.target = {7.5, 7.5, 7.5};
    wide.eye = {7.5, 7.5, -20};
    wide.height = 20;
    cases.push_back({"non-square", wide, 13, 3});
    for (const auto& c : cases) {
        Scene s;
        s.camera = c.cam;
        s.width = c.w;
        s.height = c.h;
        s.step = 0.1;
        s.earlyTermination = 1.0;
        const ImageBuffer img = GridRenderer(computeContext(), v, tf, s).render();
        expectFiniteBounded(img);
        const ImageBuffer ref = referenceRender(v, tf, s, {.step = 0.02});
        EXPECT_LT(maxAbsDiff(img, ref), 2e-3) << c.name;
    }
}

TEST(Render, Uint8CornerLayoutMatchesLinearLayout) {
    // uint8 volumes reach the packet kernels as 8 corner bytes per cell (CORNER_VOXELS); the same voxels as
    // float take the linear path. Same arithmetic, so the images agree exactly, also on grids two voxels
    // thin (clamped neighbours) and images whose size is not a multiple of the 4x2 packet.
    for (const Dims n : {Dims{9, 6, 5}, Dims{2, 7, 3}, Dims{3, 2, 6}, Dims{5, 4, 2}}) {
        Volume u8(n, ScalarType::UInt8), f32(n, ScalarType::Float32);
        auto bytes = u8.values<std::uint8_t>();
        auto floats = f32.values<float>();
        for (std::size_t i = 0; i < bytes.size(); ++i) {
            bytes[i] = std::uint8_t((i * 97 + 31) % 251);
            floats[i] = float(bytes[i]);
        }
        TransferFunction tf;
        tf.domain = {0, 255};
        tf.color = {{0, {0.2, 0.4, 1.0}}, {255, {1.0, 0.8, 0.1}}};
        tf.extinction = {{0, 0.0}, {60, 0.0}, {120, 0.2}, {255, 0.6}};
        for (Preintegration pre : {Preintegration::None, Preintegration::Table2d, Preintegration::Table3d}) {
            Scene s = orthoScene(n, 12.0, 11, 7);
            Camera cam = *s.camera;
            cam.eye = {-20, 30, -25};
            s.camera = cam;
            s.step = 0.3;
            s.preintegration = pre;
            const ImageBuffer a = GridRenderer(computeContext(), u8, tf, s).render();
            const ImageBuffer b = GridRenderer(computeContext(), f32, tf, s).render();
            EXPECT_GT(maxAbsDiff(b, ImageBuffer(b.width, b.height, {"R", "G", "B", "A"})), 0.01)
                << "the scene must show something";
            EXPECT_LT(maxAbsDiff(a, b), 1e-6)
                << n.x << "x" << n.y << "x" << n.z << " " << preintegrationName(pre);
        }
    }
}

TEST(Render, DegenerateVolumesAndSteps) {
    // One voxel thick: the box has no depth, so nothing is integrated (the box is [o, o+(n-1)s]).
    const Volume slab = makeFloatVolume({8, 8, 1}, [](double, double, double) { return 1.0f; });
    Scene s = orthoScene({8, 8, 1}, 8.0);
    ImageBuffer img = GridRenderer(computeContext(), slab, constantTf(5.0), s).render();
    for (float p : img.pixels)
        EXPECT_EQ(p, 0.0f);
    // Two voxels thick: one voxel of depth.
    const Volume thin = makeFloatVolume({8, 8, 2}, [](double, double, double) { return 1.0f; });
    s = orthoScene({8, 8, 2}, 6.0);
    img = GridRenderer(computeContext(), thin, constantTf(0.5), s).render();
    EXPECT_NEAR(img.at(4, 4, 3), 1.0 - std::exp(-0.5), 1e-6);
    // A single voxel.
    const Volume one = makeFloatVolume({1, 1, 1}, [](double, double, double) { return 1.0f; });
    img = GridRenderer(computeContext(), one, constantTf(5.0), orthoScene({1, 1, 1}, 1.0, 1, 1)).render();
    EXPECT_EQ(img.at(0, 0, 3), 0.0f);

    const Dims n{12, 12, 12};
    const Volume box = makeFloatVolume(n, [](double, double, double) { return 1.0f; });
    // Tiny and huge steps stay finite and correct on a constant box.
    for (double step : {1e-3, 1e6}) {
        Scene t = orthoScene(n, 6.0, 2, 2);
        t.step = step;
        img = GridRenderer(computeContext(), box, constantTf(0.1), t).render();
        EXPECT_NEAR(img.at(1, 1, 3), 1.0 - std::exp(-1.1), 5e-4) << step;
    }
    Scene tooSmall = orthoScene(n, 6.0, 2, 2);
    tooSmall.step = 1e-7;
    EXPECT_THROW(GridRenderer(computeContext(), box, constantTf(0.1), tooSmall), UsageError);
    // Extinction so high that one sample is opaque; zero extinction gives an empty image.
    img = GridRenderer(computeContext(), box, constantTf(1e30), orthoScene(n, 6.0)).render();
    expectFiniteBounded(img);
    EXPECT_EQ(img.at(3, 3, 3), 1.0f);
    EXPECT_NEAR(img.at(3, 3, 0), 1.0f, 1e-6);
    img = GridRenderer(computeContext(), box, constantTf(0.0), orthoScene(n, 6.0)).render();
    for (float p : img.pixels)
        EXPECT_EQ(p, 0.0f);
}

TEST(Render, IsoValuesOnVoxelsAndOutsideTheRange) {
    const Dims n{10, 10, 10};
    const Volume v = makeFloatVolume(n, [](double, double, double z) { return float(z); });
    Scene s = orthoScene(n, 6.0, 3, 3);
    s.mode = RenderMode::Iso;
    s.effects.isosurfaces = {{4.0, {1, 1, 1, 1}}}; // exactly the values of the slice z = 4
    TransferFunction tf = constantTf(0.0);
    tf.domain = {0, 9};
    ImageBuffer img = GridRenderer(computeContext(), v, tf, s).render();
    // Eye at z = -50: depth = 54 at the slice.
    EXPECT_NEAR(img.at(1, 1, 4), 54.0, 1e-4);
    EXPECT_EQ(img.at(1, 1, 3), 1.0f);
    s.effects.isosurfaces = {{9.5, {1, 1, 1, 1}}};
    GridRenderer r(computeContext(), v, tf, s);
    EXPECT_TRUE(r.plan().isosurfaces.empty());
    img = r.render();
    for (int i = 0; i < 9; ++i)
        EXPECT_EQ(img.pixels[std::size_t(i) * 4 + 3], 0.0f);
}

TEST(Render, BadInputIsRefused) {
    // NaN/Inf voxels are no longer refused: they take the NaN colour (test_render_nan.cpp).
    EXPECT_THROW(Scene::fromJson(R"({"render": {"mode": "volume"}})"), UsageError);
    EXPECT_THROW(Scene::fromJson(R"({"render": {"stepp": 1}})"), UsageError);
    EXPECT_THROW(Scene::fromJson(R"({"camera": {"eye": [0, 0]}})"), UsageError);
    EXPECT_THROW(Scene::fromJson("{oops"), UsageError);
    // Integer fields past int's range are refused when read, not converted (undefined behaviour; found by
    // fuzz_scene_json).
    for (const char* huge : {R"({"render": {"table_lengths": 2.2e56}})",
                             R"({"render": {"table_size": -1e300}})", R"({"render": {"k": 2147483648}})",
                             R"({"image": {"width": 1e10}})", R"({"image": {"height": -3e9}})"})
        EXPECT_THROW(Scene::fromJson(huge), UsageError) << huge;
    EXPECT_EQ(Scene::fromJson(R"({"render": {"k": 2147483647}})").kBufferDepth, 2147483647);
    Scene s = Scene::fromJson(R"({"render": {"step": -1}})");
    EXPECT_THROW(s.validate(), UsageError);
    s = Scene::fromJson(R"({"image": {"width": 0}})");
    EXPECT_THROW(s.validate(), UsageError);
    s = Scene::fromJson(R"({"camera": {"eye": [0, 0, 0], "target": [0, 5, 0], "up": [0, 1, 0]}})");
    EXPECT_THROW(s.validate(), UsageError);
    s = Scene::fromJson(R"({"render": {"mode": "iso"}})");
    EXPECT_THROW(s.validate(), UsageError);
}

TEST(Render, SceneJsonRoundTrip) {
    const char* text = R"({
      "volume": "head.nrrd", "tf": "tf.json",
      "camera": {"projection": "perspective", "eye": [64, 64, -200], "target": [64, 64, 64], "up": [0, 1, 0],
                 "fov_y_deg": 40},
      "image": {"width": 320, "height": 200, "background": [0, 0, 0.2, 1]},
      "render": {"mode": "dvr", "step": 0.5, "preintegration": "2d", "early_termination": 0.99},
      "lights": [{"type": "head"}, {"type": "point", "position": [1, 2, 3], "intensity": 0.5}],
      "effects": {"shading": {"ambient": 0.1, "diffuse": 0.8, "specular": 0.2, "shininess": 16},
                  "shadows": true, "scattering": {"albedo": 0.5, "g": 0.2},
                  "clip_planes": [{"normal": [1, 0, 0], "point": [10, 0, 0]}],
                  "isosurfaces": [{"value": 90, "color": [1, 1, 1, 0.5]}]}
    })";
    const Scene s = Scene::fromJson(text, "/data");
    EXPECT_EQ(s.volume, std::filesystem::path("/data/head.nrrd"));
    EXPECT_EQ(s.camera->projection, Projection::Perspective);
    EXPECT_EQ(s.preintegration, Preintegration::Table2d);
    EXPECT_EQ(s.lights.size(), 2u);
    EXPECT_EQ(s.effects.clipPlanes[0].offset, -10.0);
    const Scene back = Scene::fromJson(s.toJson());
    EXPECT_EQ(back.toJson(), s.toJson());
}

// Real volumes: unshaded DVR with 2D pre-integration at step 0.25 against the double reference.
struct RealCase {
    const char* path;
    std::array<double, 2> domain;
};

TEST(Render, RealVolumesPreintegratedMatchReference) {
    std::filesystem::path data;
    VOLCL_REQUIRE_SHARED_DATA(data);
    const RealCase cases[] = {
        {"regular/nucleon.nrrd", {0, 255}},
        {"regular/Bucky.raw", {0, 255}},
        {"regular/hydrogenatom.dat", {0, 255}},
        {"regular/t1_icbm_normal_1mm_pn0_rf0_180x216x180_uint8_1x1.bin-gz", {0, 255}},
        {"regular/headsq/quarter.nhdr", {0, 3000}},
    };
    for (const auto& rc : cases) {
        ReadOptions ro;
        if (std::string(rc.path).find("Bucky") != std::string::npos) {
            ro.dims = Dims{32, 32, 32};
            ro.type = ScalarType::UInt8;
        }
        if (std::string(rc.path).find("t1_icbm") != std::string::npos) {
            ro.dims = Dims{180, 216, 180};
            ro.type = ScalarType::UInt8;
        }
        const Volume v = readVolume(data / rc.path, ro);
        const double lo = rc.domain[0], hi = rc.domain[1], w = hi - lo;
        TransferFunction tf;
        tf.domain = rc.domain;
        tf.color = {{lo, {0.1, 0.2, 0.9}}, {lo + 0.4 * w, {0.9, 0.5, 0.2}}, {hi, {1.0, 1.0, 0.9}}};
        tf.extinction = {
            {lo, 0.0}, {lo + 0.15 * w, 0.0}, {lo + 0.35 * w, 0.08}, {lo + 0.6 * w, 0.4}, {hi, 0.8}};
        // Scale extinction to the grid so every volume is semi-transparent (tau is per world unit).
        const double minSpacing = std::min({v.spacing[0], v.spacing[1], v.spacing[2]});
        for (auto& p : tf.extinction)
            p.tau /= minSpacing;
        Scene s;
        Camera cam = defaultCamera(v);
        cam.eye = {cam.eye[0] + 0.6 * (cam.target[2] - cam.eye[2]),
                   cam.eye[1] - 0.3 * (cam.target[2] - cam.eye[2]), cam.eye[2]};
        s.camera = cam;
        s.width = 64;
        s.height = 64;
        s.preintegration = Preintegration::Table2d;
        s.step = 0.25 * minSpacing;
        const ImageBuffer img = GridRenderer(computeContext(), v, tf, s).render();
        const ImageBuffer ref = referenceRender(v, tf, s, {.step = 0.05 * minSpacing});
        const double rmse = imageRmse(img, ref);
        EXPECT_LE(rmse, 0.005) << rc.path;
        RecordProperty(std::string("rmse_") + std::filesystem::path(rc.path).filename().string(),
                       std::to_string(rmse));
        std::cerr << "[ real ] " << rc.path << " RMSE " << rmse << '\n';
    }
}

} // namespace
