// Reconstruction filters (linear, cubic, bspline) and the MIP window: the spline against its definition,
// the kernels against the double reference, normals on a quantised sphere, the 8-bit MRI.
#include "TestUtil.hpp"

#include "core/Error.hpp"
#include "core/Volume.hpp"
#include "host/io/VolumeIo.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/Scene.hpp"
#include "render/grid/BsplineField.hpp"
#include "render/grid/FilterAccuracy.hpp"
#include "render/grid/GridRenderer.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

namespace {

using namespace volcl;
using volcl::test::computeContext;
using volcl::test::makeFloatVolume;

constexpr double kPi = 3.14159265358979323846;

/// test::orthoScene seen slightly from the side, so rays cross cells obliquely.
Scene obliqueScene(Dims n, double h, int w, int ht) {
    Scene s = test::orthoScene(n, h, w, ht);
    s.camera->eye = {s.camera->target[0] + 7.0, s.camera->target[1] - 5.0, -60.0};
    return s;
}

/// A smooth band-limited field (Marschner-Lobb's shape on a coarse grid), values in about [0, 1].
Volume smoothField(Dims n) {
    return makeFloatVolume(n, [&](double x, double y, double z) {
        const double u = 2.0 * x / double(n.x - 1) - 1.0, v = 2.0 * y / double(n.y - 1) - 1.0,
                     w = 2.0 * z / double(n.z - 1) - 1.0;
        const double r = std::sqrt(u * u + v * v);
        return (1.0 - std::sin(kPi * w / 2.0) +
                0.25 * (1.0 + std::cos(2.0 * kPi * 1.5 * std::cos(kPi * r / 2.0)))) /
               2.5;
    });
}

TransferFunction rampTf(double lo, double hi, double tau) {
    TransferFunction tf;
    tf.domain = {lo, hi};
    tf.color = {{lo, {0.1, 0.3, 0.9}}, {0.5 * (lo + hi), {0.9, 0.6, 0.2}}, {hi, {1.0, 1.0, 0.9}}};
    tf.extinction = {{lo, 0.0}, {lo + 0.3 * (hi - lo), 0.0}, {hi, tau}};
    return tf;
}

TEST(Filter, CubicSplineInterpolatesTheVoxels) {
    for (Dims n : {Dims{1, 1, 1}, Dims{2, 3, 1}, Dims{7, 5, 4}, Dims{40, 3, 2}}) {
        const Volume v = makeFloatVolume(n, [](double x, double y, double z) {
            return float(std::sin(1.3 * x) + 0.5 * std::cos(0.7 * y) - 0.2 * z * z);
        });
        const auto c = bsplineCoefficients<double>(v, ReconstructionFilter::Cubic);
        for (std::size_t k = 0; k < n.z; ++k)
            for (std::size_t j = 0; j < n.y; ++j)
                for (std::size_t i = 0; i < n.x; ++i)
                    EXPECT_NEAR(bsplineValue(c, {double(i), double(j), double(k)}),
                                v.valueAt(v.index(i, j, k)), 1e-9)
                        << n.x << "x" << n.y << "x" << n.z << " at " << i << "," << j << "," << k;
    }
}

TEST(Filter, SplinesReproduceALinearFieldAndItsGradient) {
    // Both splines reproduce linear functions away from the mirrored border (the interpolating one's
    // prefilter spreads the border's kink by 0.268^k over k voxels); the gradient is analytic.
    const Dims n{32, 30, 28};
    const Volume v =
        makeFloatVolume(n, [](double x, double y, double z) { return float(1.5 * x - 0.75 * y + 0.25 * z); });
    for (ReconstructionFilter f : {ReconstructionFilter::Cubic, ReconstructionFilter::Bspline}) {
        const auto c = bsplineCoefficients<double>(v, f);
        for (const Vec3 p : {Vec3{13.3, 14.7, 12.1}, Vec3{15.5, 12.25, 16.9}, Vec3{17.0, 16.0, 15.0}}) {
            Vec3 g;
            EXPECT_NEAR(bsplineValue(c, p, &g), 1.5 * p[0] - 0.75 * p[1] + 0.25 * p[2], 1e-6)
                << filterName(f);
            EXPECT_NEAR(g[0], 1.5, 1e-6);
            EXPECT_NEAR(g[1], -0.75, 1e-6);
            EXPECT_NEAR(g[2], 0.25, 1e-6);
        }
        // Outside the box the point is clamped, as the trilinear sample is.
        EXPECT_DOUBLE_EQ(bsplineValue(c, {-5.0, 4.0, 3.0}), bsplineValue(c, {0.0, 4.0, 3.0}));
    }
    EXPECT_THROW(bsplineCoefficients<float>(v, ReconstructionFilter::Linear), UsageError);
}

TEST(Filter, SplineGradientIsTheDerivativeOfItsValue) {
    const Volume v = smoothField({9, 8, 7});
    for (ReconstructionFilter f : {ReconstructionFilter::Cubic, ReconstructionFilter::Bspline}) {
        const auto c = bsplineCoefficients<double>(v, f);
        const Vec3 p{3.37, 4.61, 2.83};
        Vec3 g;
        bsplineValue(c, p, &g);
        const double h = 1e-5;
        for (int a = 0; a < 3; ++a) {
            Vec3 lo = p, hi = p;
            lo[std::size_t(a)] -= h;
            hi[std::size_t(a)] += h;
            EXPECT_NEAR(g[std::size_t(a)], (bsplineValue(c, hi) - bsplineValue(c, lo)) / (2 * h), 1e-6) << a;
        }
    }
}

TEST(Filter, MacrocellsBoundTheSpline) {
    const Volume v = makeFloatVolume({21, 19, 18}, [](double x, double y, double z) {
        return float((int(x) * 7 + int(y) * 3 + int(z) * 5) % 11 == 0 ? 10.0 : 0.0); // spiky: overshoots
    });
    const auto cf = bsplineCoefficients<float>(v, ReconstructionFilter::Cubic);
    const auto cd = bsplineCoefficients<double>(v, ReconstructionFilter::Cubic);
    const auto m = bsplineMacrocells(cf, 8);
    for (double z = 0; z <= 17; z += 0.37)
        for (double y = 0; y <= 18; y += 0.41)
            for (double x = 0; x <= 20; x += 0.43) {
                const double s = bsplineValue(cd, {x, y, z});
                const unsigned cx = std::min(unsigned(x / 8), m.nx - 1),
                               cy = std::min(unsigned(y / 8), m.ny - 1),
                               cz = std::min(unsigned(z / 8), m.nz - 1);
                const std::size_t c = (std::size_t(cz) * m.ny + cy) * m.nx + cx;
                ASSERT_GE(s, m.min[c] - 1e-5);
                ASSERT_LE(s, m.max[c] + 1e-5);
            }
}

TEST(Filter, KernelsMatchTheReferenceOnASmoothField) {
    const Dims n{24, 22, 20};
    const Volume v = smoothField(n);
    const TransferFunction tf = rampTf(0.0, 1.0, 0.6);
    const Light light{LightKind::Directional, {0.4, 0.6, -0.7}, {1, 1, 1}, 1.0};
    for (ReconstructionFilter f : {ReconstructionFilter::Cubic, ReconstructionFilter::Bspline}) {
        struct Case {
            const char* name;
            std::function<void(Scene&)> apply;
            double tol;
        };
        const Case cases[] = {
            {"dvr", [](Scene&) {}, 2e-3},
            {"dvr 2d", [](Scene& s) { s.preintegration = Preintegration::Table2d; }, 3e-3},
            {"dvr shaded shadows",
             [&](Scene& s) {
                 s.lights = {light};
                 s.effects.shading = true;
                 s.effects.shadows = true;
                 s.effects.shadowStep = 0.1;
             },
             5e-3}, // the step's midpoint error on lit shadowed samples: 2e-3 at step 0.1
            {"iso shaded",
             [&](Scene& s) {
                 s.mode = RenderMode::Iso;
                 s.lights = {light};
                 s.effects.shading = true;
                 s.effects.isosurfaces = {{0.45, {0.9, 0.8, 0.7, 1.0}}, {0.6, {0.2, 0.5, 1.0, 0.5}}};
             },
             4e-3},
            {"mip", [](Scene& s) { s.mode = RenderMode::Mip; }, 2e-3},
            {"xray", [](Scene& s) { s.mode = RenderMode::Xray; }, 2e-3},
        };
        for (const auto& cs : cases) {
            Scene s = obliqueScene(n, 30.0, 28, 24);
            s.step = 0.25;
            s.filter = f;
            cs.apply(s);
            GridRenderer r(computeContext(), v, tf, s);
            const ImageBuffer img = r.render();
            const ImageBuffer ref = referenceRender(v, tf, s, {.step = 0.04});
            const double rmse = imageRmse(img, ref);
            // The stated tolerance, or as close as the linear path is to its own reference on the same
            // scene (the step's discretisation error, which the filter does not change).
            Scene lin = s;
            lin.filter = ReconstructionFilter::Linear;
            const double linear = imageRmse(GridRenderer(computeContext(), v, tf, lin).render(),
                                            referenceRender(v, tf, lin, {.step = 0.04}));
            EXPECT_LT(rmse, std::max(cs.tol, 1.5 * linear))
                << filterName(f) << " " << cs.name << " (linear " << linear << ")";
            EXPECT_NE(r.plan().defines.toOptions().find("-DFILTER_BSPLINE"), std::string::npos);
            // Skipping and the packet kernel change nothing beyond float noise.
            Scene noSkip = s;
            noSkip.skipping = SkipMode::Off;
            EXPECT_LT(imageRmse(GridRenderer(computeContext(), v, tf, noSkip).render(), img), 1e-4)
                << filterName(f) << " " << cs.name;
        }
    }
}

TEST(Filter, LinearFilterOnSmoothedDataMatchesReference) {
    const Dims n{22, 20, 19};
    Volume v(n, ScalarType::UInt8);
    auto vals = v.values<std::uint8_t>();
    for (std::size_t i = 0; i < vals.size(); ++i)
        vals[i] = std::uint8_t((i * 37) % 200); // rough: smoothing changes it everywhere
    const TransferFunction tf = rampTf(0.0, 200.0, 0.05);
    const Light light{LightKind::Directional, {0.4, 0.6, -0.7}, {1, 1, 1}, 1.0};
    for (RenderMode mode : {RenderMode::Dvr, RenderMode::Iso, RenderMode::Mip}) {
        Scene s = obliqueScene(n, 28.0, 24, 20);
        s.step = 0.25;
        s.smoothing = 1.0;
        s.mode = mode;
        s.lights = {light};
        s.effects.shading = mode != RenderMode::Mip;
        if (mode == RenderMode::Iso) s.effects.isosurfaces = {{95.5, {1, 1, 1, 1}}};
        GridRenderer r(computeContext(), v, tf, s);
        EXPECT_EQ(r.plan().defines.toOptions().find("FILTER_BSPLINE"), std::string::npos);
        EXPECT_NE(r.plan().defines.toOptions().find("-DVOXEL_TYPE=0"), std::string::npos);
        const ImageBuffer img = r.render();
        const double rmse = imageRmse(img, referenceRender(v, tf, s, {.step = 0.04}));
        EXPECT_LT(rmse, 3e-3) << renderModeName(mode);
        Scene raw = s;
        raw.smoothing = 0.0;
        EXPECT_GT(imageRmse(GridRenderer(computeContext(), v, tf, raw).render(), img), 10.0 * rmse)
            << "smoothing changes the image";
    }
}

TEST(Filter, SmoothingSplineRemovesQuantisationTerracesOnASphere) {
    // 8-bit data of a sphere with a shallow radial ramp (one level per voxel): the trilinear field is a
    // staircase, and normals from it (central differences or Sobel) follow the stairs.
    const Vec3 c{23.4, 24.1, 23.7};
    const double R = 15.0, slope = 1.0;
    const Volume v = quantisedSphere({48, 48, 48}, c, R, slope);
    const TransferFunction tf = rampTf(0.0, 255.0, 0.0);
    const Scene s = sphereNormalScene(c, R, 96);
    auto errorFor = [&](ReconstructionFilter f, GradientKind g, double smoothing, double depthBound) {
        Scene t = s;
        t.filter = f;
        t.effects.gradient = g;
        t.smoothing = smoothing;
        const ImageBuffer img = GridRenderer(computeContext(), v, tf, t).render();
        // The level 128.5 lies at radius R - 0.5 / slope; every filter keeps the surface near it.
        EXPECT_LT(meanDepthError(img, t, c, R - 0.5 / slope), depthBound) << filterName(f);
        return std::pair{meanNormalErrorDeg(img, t, c), shadingRoughness(img)};
    };
    const auto linear = errorFor(ReconstructionFilter::Linear, GradientKind::Central, 0.0, 0.25);
    const auto sobel = errorFor(ReconstructionFilter::Linear, GradientKind::Sobel, 0.0, 0.25);
    const auto cubic = errorFor(ReconstructionFilter::Cubic, GradientKind::Central, 0.0, 0.4);
    const auto smooth = errorFor(ReconstructionFilter::Bspline, GradientKind::Central, 1.0, 0.2);
    const auto smoothLinear = errorFor(ReconstructionFilter::Linear, GradientKind::Central, 1.0, 0.2);
    std::cerr << "[ normals ] mean angular error (deg) / roughness: linear " << linear.first << " / "
              << linear.second << ", sobel " << sobel.first << " / " << sobel.second << ", cubic "
              << cubic.first << " / " << cubic.second << ", bspline smoothing 1 " << smooth.first << " / "
              << smooth.second << ", linear smoothing 1 " << smoothLinear.first << " / "
              << smoothLinear.second << '\n';
    RecordProperty("normal_error_deg_linear", std::to_string(linear.first));
    RecordProperty("normal_error_deg_bspline_smoothing_1", std::to_string(smooth.first));
    EXPECT_GT(linear.first, 3.0);         // the terraces the trilinear field shows
    EXPECT_GT(sobel.first, 1.5);          // Sobel alone does not remove them
    EXPECT_GT(cubic.first, linear.first); // an interpolating spline follows the stairs even more closely
    EXPECT_LT(smooth.first, 1.2);         // the smoothing spline removes them
    EXPECT_LT(smooth.first, 0.3 * linear.first);
    EXPECT_LT(smooth.second, 0.3 * linear.second);
    EXPECT_LT(smoothLinear.first, 0.5 * linear.first); // smoothing helps the trilinear field too
}

TEST(Filter, MipWindowGreyTfAndTfOpacity) {
    const Dims n{20, 18, 16};
    const Volume v = makeFloatVolume(n, [](double x, double y, double) { return float(10.0 + 3.0 * x + y); });
    TransferFunction tf = rampTf(0.0, 100.0, 2.0);
    Scene s = obliqueScene(n, 24.0, 20, 18);
    s.camera->eye = {s.camera->target[0], s.camera->target[1],
                     -60.0}; // along +z: the maximum is the column's value
    s.mode = RenderMode::Mip;
    s.step = 0.25;
    s.window = std::array<double, 2>{50.0, 40.0}; // 30..70
    for (MipColor mc : {MipColor::Grey, MipColor::Tf, MipColor::TfOpacity}) {
        s.mipColor = mc;
        GridRenderer r(computeContext(), v, tf, s);
        const ImageBuffer img = r.render();
        const ImageBuffer ref = referenceRender(v, tf, s);
        EXPECT_LT(imageRmse(img, ref), 1e-4) << mipColorName(mc);
        for (int y = 0; y < img.height; ++y)
            for (int x = 0; x < img.width; ++x) {
                const CameraRay ray = cameraRay(*s.camera, s.width, s.height, x, y);
                const double px = ray.origin[0], py = ray.origin[1];
                if (px < 0.0 || py < 0.0 || px > n.x - 1 || py > n.y - 1) continue;
                const double m = 10.0 + 3.0 * px + py;
                const double g = std::clamp((m - 30.0) / 40.0, 0.0, 1.0);
                const auto col = tf.colorAt(m);
                if (mc == MipColor::Grey) {
                    EXPECT_NEAR(img.at(x, y, 0), g, 1e-4);
                    EXPECT_NEAR(img.at(x, y, 3), g, 1e-4);
                } else if (mc == MipColor::Tf) {
                    EXPECT_NEAR(img.at(x, y, 2), col[2] * g, 1e-4);
                    EXPECT_NEAR(img.at(x, y, 3), g, 1e-4);
                } else {
                    EXPECT_NEAR(img.at(x, y, 3), 1.0 - std::exp(-tf.extinctionAt(m)), 1e-4);
                }
            }
    }
    // No window: the data range. A pixel over the column holding the maximum value is white.
    s.window.reset();
    s.mipColor = MipColor::Grey;
    const ImageBuffer full = GridRenderer(computeContext(), v, tf, s).render();
    EXPECT_LT(imageRmse(full, referenceRender(v, tf, s)), 1e-4);
    Scene bad = s;
    bad.window = std::array<double, 2>{50.0, 0.0};
    EXPECT_THROW(bad.validate(), UsageError);
    bad.window = std::array<double, 2>{NAN, 10.0};
    EXPECT_THROW(bad.validate(), UsageError);
}

TEST(Filter, DegenerateGridsAndExtremeValues) {
    const TransferFunction tf = rampTf(0.0, 1.0, 2.0);
    for (Dims n : {Dims{2, 2, 2}, Dims{1, 6, 5}, Dims{7, 1, 1}, Dims{3, 4, 2}}) {
        const Volume v =
            makeFloatVolume(n, [](double x, double y, double z) { return float(0.2 + 0.1 * (x + y + z)); });
        for (ReconstructionFilter f : {ReconstructionFilter::Cubic, ReconstructionFilter::Bspline})
            for (RenderMode mode : {RenderMode::Dvr, RenderMode::Mip, RenderMode::Iso}) {
                Scene s = obliqueScene(n, 8.0, 9, 7);
                s.camera->eye = {s.camera->target[0] + 0.3, s.camera->target[1] + 0.2, -20.0};
                s.filter = f;
                s.smoothing = 0.5;
                s.mode = mode;
                if (mode == RenderMode::Iso) s.effects.isosurfaces = {{0.45, {1, 1, 1, 1}}};
                const ImageBuffer img = GridRenderer(computeContext(), v, tf, s).render();
                const ImageBuffer ref = referenceRender(v, tf, s);
                for (float p : img.pixels)
                    if (!std::isinf(p)) ASSERT_TRUE(std::isfinite(p));
                EXPECT_LT(imageRmse(img, ref), 2e-3)
                    << n.x << "x" << n.y << "x" << n.z << " " << filterName(f);
            }
    }
    // Values near float's limit: the approximating spline stays finite (weights sum to 1); the
    // interpolating prefilter would overflow and is refused with a one-line error.
    const Dims n{6, 6, 6};
    const Volume huge =
        makeFloatVolume(n, [](double x, double, double) { return int(x) % 2 ? 3e38f : -3e38f; });
    TransferFunction wide = rampTf(-3e38, 3e38, 1.0);
    Scene s = obliqueScene(n, 8.0, 8, 8);
    s.filter = ReconstructionFilter::Bspline;
    const ImageBuffer img = GridRenderer(computeContext(), huge, wide, s).render();
    for (float p : img.pixels)
        ASSERT_TRUE(std::isfinite(p));
    s.filter = ReconstructionFilter::Cubic;
    EXPECT_THROW(GridRenderer(computeContext(), huge, wide, s), DataError);
    s.smoothing = 9.0;
    EXPECT_THROW(s.validate(), UsageError);
}

TEST(Filter, SceneJsonFieldsRoundTripAndRefuseUnknowns) {
    const Scene s = Scene::fromJson(R"({"render": {"mode": "mip", "filter": "bspline", "window": [40, 80],
                                        "mip_color": "tf"}})");
    EXPECT_EQ(s.filter, ReconstructionFilter::Bspline);
    ASSERT_TRUE(s.window.has_value());
    EXPECT_EQ((*s.window)[1], 80.0);
    EXPECT_EQ(s.mipColor, MipColor::Tf);
    const Scene back = Scene::fromJson(s.toJson());
    EXPECT_EQ(back.filter, s.filter);
    EXPECT_EQ(back.window, s.window);
    EXPECT_EQ(back.mipColor, s.mipColor);
    EXPECT_EQ(Scene::fromJson("{}").filter, ReconstructionFilter::Linear);
    EXPECT_THROW(Scene::fromJson(R"({"render": {"filter": "quintic"}})"), UsageError);
    EXPECT_THROW(Scene::fromJson(R"({"render": {"mip_color": "pink"}})"), UsageError);
    EXPECT_THROW(Scene::fromJson(R"({"render": {"window": [1]}})"), UsageError);
}

TEST(Filter, RealEightBitMriMatchesReference) {
    const std::filesystem::path mri = "/usr/share/mricron/templates/ch2better.nii.gz";
    if (!std::filesystem::exists(mri)) GTEST_SKIP() << mri << " is absent (apt-get install mricron-data)";
    const Volume full = readVolume(mri);
    ASSERT_EQ(full.type(), ScalarType::UInt8);
    // A 48^3 block through the cortex keeps the double reference quick.
    const Volume v = full.cropped({120, 150, 200}, {168, 198, 248});
    TransferFunction tf = rampTf(0.0, 255.0, 0.3);
    const VolumeStats st = v.stats(1);
    const double iso = std::floor(0.5 * (st.min + st.max)) + 0.5;
    for (ReconstructionFilter f : {ReconstructionFilter::Cubic, ReconstructionFilter::Bspline}) {
        for (RenderMode mode : {RenderMode::Iso, RenderMode::Dvr}) {
            Scene s;
            Camera cam = defaultCamera(v);
            cam.eye = {cam.eye[0] + 0.5 * (cam.target[2] - cam.eye[2]), cam.eye[1], cam.eye[2]};
            s.camera = cam;
            s.width = 40;
            s.height = 40;
            s.step = 0.25 * v.spacing[0];
            s.earlyTermination = 1.0;
            s.filter = f;
            s.mode = mode;
            s.lights = {Light{LightKind::Head, {0, 0, 0}, {1, 1, 1}, 1.0}};
            s.effects.shading = true;
            if (mode == RenderMode::Iso) s.effects.isosurfaces = {{iso, {1, 0.9, 0.8, 1}}};
            const ImageBuffer img = GridRenderer(computeContext(), v, tf, s).render();
            const ImageBuffer ref = referenceRender(v, tf, s, {.step = 0.05 * v.spacing[0]});
            const double rmse = imageRmse(img, ref);
            std::cerr << "[ mri ] " << filterName(f) << " " << renderModeName(mode) << " RMSE " << rmse
                      << '\n';
            EXPECT_LT(rmse, 5e-3) << filterName(f) << " " << renderModeName(mode);
        }
    }
}

} // namespace
