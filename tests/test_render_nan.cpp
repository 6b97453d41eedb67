// NaN/Inf voxels in the grid ray marcher: the NaN colour against closed-form scenes integrated on the host.
#include "TestUtil.hpp"

#include "core/Error.hpp"
#include "core/Volume.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/Scene.hpp"
#include "render/grid/GridRenderer.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <functional>
#include <limits>

namespace {

using namespace volcl;
using volcl::test::computeContext;
using volcl::test::makeFloatVolume;
using volcl::test::orthoScene;

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();

/// 9 x 9 x 33 voxels holding s = z, except the z planes in [nanLo, nanHi] (NaN) and `infPlane` (+Inf when
/// given): the field along every ray of orthoScene is the ramp with holes.
Volume rampWithHoles(int nanLo, int nanHi, int infPlane = -1) {
    return makeFloatVolume({9, 9, 33}, [=](double, double, double z) {
        const int k = int(z);
        if (k >= nanLo && k <= nanHi) return double(kNaN);
        if (k == infPlane) return double(kInf);
        return z;
    });
}

/// tau(s) = 0.02 s, colour (s / 32, 1, 0) over [0, 32].
TransferFunction rampTf() {
    TransferFunction tf;
    tf.domain = {0, 32};
    tf.color = {{0, {0.0, 1.0, 0.0}}, {32, {1.0, 1.0, 0.0}}};
    tf.extinction = {{0, 0.0}, {32, 0.64}};
    return tf;
}

struct Pixel {
    double r, g, b, a;
};

/// Front-to-back emission-absorption over z in [0, 32] by 320000 midpoint steps in double: `nanAt(z)` says
/// where the documented rule makes the field NaN, which then takes `nanRgb` with extinction `nanTau`;
/// elsewhere the ramp TF's closed form. Independent of the kernels and of the reference renderer.
Pixel integrate(const std::function<bool(double)>& nanAt, std::array<double, 3> nanRgb, double nanTau) {
    Pixel p{0, 0, 0, 0};
    double T = 1.0;
    const int m = 320000;
    const double dz = 32.0 / m;
    for (int i = 0; i < m; ++i) {
        const double z = (i + 0.5) * dz;
        const bool nan = nanAt(z);
        const double tau = nan ? nanTau : 0.02 * z;
        const std::array<double, 3> c = nan ? nanRgb : std::array<double, 3>{z / 32.0, 1.0, 0.0};
        const double a = 1.0 - std::exp(-tau * dz);
        p.r += T * a * c[0];
        p.g += T * a * c[1];
        p.b += T * a * c[2];
        T *= 1.0 - a;
    }
    p.a = 1.0 - T;
    return p;
}

void expectPixel(const ImageBuffer& img, const Pixel& want, double tol, const std::string& what) {
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
            EXPECT_NEAR(img.at(x, y, 0), want.r, tol) << what << " at " << x << "," << y;
            EXPECT_NEAR(img.at(x, y, 1), want.g, tol) << what;
            EXPECT_NEAR(img.at(x, y, 2), want.b, tol) << what;
            EXPECT_NEAR(img.at(x, y, 3), want.a, tol) << what;
        }
}

// The documented rule: a point sample is NaN when a corner of its cell [floor(z), floor(z) + 1] is, so NaN
// planes 12..14 make z in [11, 15) NaN; a pre-integrated segment is NaN when one of its ends is, so with
// step 0.5 the segments from 10.5 to 15 are.
TEST(RenderNan, DvrDrawsTheNanColourWhereTheRuleSays) {
    const Volume v = rampWithHoles(12, 14);
    const TransferFunction tf = rampTf();
    Scene s = orthoScene({9, 9, 33}, 6.0, 4, 4);
    s.step = 0.5;
    const double nanTau = -std::log(1.0 - 0.3);
    auto pointNan = [](double z) { return z >= 11.0 && z < 15.0; };
    auto segmentNan = [](double z) { return z >= 10.5 && z < 15.0; };
    // Transparent by default: the hole adds nothing and hides nothing.
    expectPixel(GridRenderer(computeContext(), v, tf, s).render(), integrate(pointNan, {0, 0, 0}, 0.0), 2e-3,
                "dvr, default nan colour");
    s.nanColor = {0.0, 0.0, 1.0, 0.3};
    expectPixel(GridRenderer(computeContext(), v, tf, s).render(), integrate(pointNan, {0, 0, 1}, nanTau),
                2e-3, "dvr, blue nan colour");
    s.tableSize = 64; // the ramp TF is smooth: small tables stay well inside the tolerance, and build fast
    s.tableLengths = 4;
    for (Preintegration pre : {Preintegration::Table2d, Preintegration::Table3d}) {
        s.preintegration = pre;
        expectPixel(GridRenderer(computeContext(), v, tf, s).render(),
                    integrate(segmentNan, {0, 0, 1}, nanTau), 2e-3, std::string(preintegrationName(pre)));
    }
}

TEST(RenderNan, SkippingKeepsCellsWhereOnlyTheNanColourShows) {
    // The TF is transparent everywhere: every macrocell would be empty but those holding the NaN planes.
    const Volume v = rampWithHoles(12, 14);
    TransferFunction tf = rampTf();
    tf.extinction = {{0, 0.0}};
    Scene s = orthoScene({9, 9, 33}, 6.0, 4, 4);
    s.step = 0.5;
    s.nanColor = {1.0, 0.0, 0.0, 0.5};
    for (bool skipping : {true, false}) {
        s.skipping = skipping ? SkipMode::On : SkipMode::Off;
        const ImageBuffer img = GridRenderer(computeContext(), v, tf, s).render();
        const double a = 1.0 - std::pow(0.5, 4.0); // z in [11, 15): four units at opacity 0.5 per unit
        expectPixel(img, {a, 0.0, 0.0, a}, 1e-5, skipping ? "skipping" : "no skipping");
    }
}

TEST(RenderNan, MipAndXraySkipSamplesThatAreNotFinite) {
    // +Inf on plane 32 (the ramp's top) and NaN on 20..22: MIP sees the largest finite sample, below 31.
    const Volume v = rampWithHoles(20, 22, 32);
    Scene s = orthoScene({9, 9, 33}, 6.0, 4, 4);
    s.mode = RenderMode::Mip;
    s.window = std::array<double, 2>{16.0, 32.0}; // grey = s / 32
    s.step = 0.3;
    s.nanColor = {1, 1, 1, 1}; // MIP has no NaN colour
    const ImageBuffer mip = GridRenderer(computeContext(), v, rampTf(), s).render();
    // Samples at 0.3 k: the last one in a cell with finite corners is at 30.9.
    for (int c = 0; c < 4; ++c)
        EXPECT_NEAR(mip.at(1, 2, c), 30.9 / 32.0, 1e-4) << c;
    // X-ray with constant tau 0.05: the finite length is 32 minus [19, 23) and [31, 32].
    TransferFunction flat;
    flat.domain = {0, 32};
    flat.color = {{0, {1, 1, 1}}};
    flat.extinction = {{0, 0.05}};
    s.mode = RenderMode::Xray;
    s.step = 0.5;
    const ImageBuffer xray = GridRenderer(computeContext(), v, flat, s).render();
    const double a = 1.0 - std::exp(-0.05 * (32.0 - 4.0 - 1.0));
    expectPixel(xray, {a, a, a, a}, 1e-5, "xray");
}

TEST(RenderNan, IsoSurfacesNeedCellsWithFiniteCorners) {
    // s = z with NaN planes 12..14: the surface s = 13 lies inside the hole and must not appear, not even
    // on the hole's faces where the side changes from 11 to 15; s = 20 is hit at depth 50 + 20.
    const Volume v = rampWithHoles(12, 14);
    Scene s = orthoScene({9, 9, 33}, 6.0, 4, 4);
    s.mode = RenderMode::Iso;
    s.effects.shadingGiven = true;
    s.effects.shading = false;
    s.effects.isosurfaces = {{13.0, {1, 0, 0, 1}}, {20.0, {0, 1, 0, 1}}};
    TransferFunction tf = rampTf();
    for (bool table : {false, true}) {
        s.effects.isoTable = table;
        const ImageBuffer img = GridRenderer(computeContext(), v, tf, s).render();
        for (int y = 0; y < 4; ++y)
            for (int x = 0; x < 4; ++x) {
                EXPECT_NEAR(img.at(x, y, 0), 0.0, 1e-6) << (table ? "table" : "roots");
                EXPECT_NEAR(img.at(x, y, 1), 1.0, 1e-6) << (table ? "table" : "roots");
                if (!table) EXPECT_NEAR(img.at(x, y, 4), 70.0, 1e-3);
            }
    }
}

TEST(RenderNan, EveryEffectRendersFiniteImages) {
    // A blob of NaN and Inf voxels inside a smooth field: lit, shadowed, scattering, path traced, MIP
    // coloured and pre-integrated lighting all give finite, non-negative pixels and opacity in [0, 1].
    const Dims n{16, 16, 16};
    Volume v = makeFloatVolume(n, [](double x, double y, double z) {
        return 10.0 + 5.0 * std::sin(0.4 * x) * std::cos(0.3 * y) + 0.2 * z;
    });
    for (std::size_t k = 6; k < 9; ++k)
        for (std::size_t j = 5; j < 10; ++j)
            for (std::size_t i = 4; i < 11; ++i)
                v.values<float>()[v.index(i, j, k)] = (i + j) % 3 == 0 ? kInf : kNaN;
    TransferFunction tf;
    tf.domain = {5, 19};
    tf.color = {{5, {0.2, 0.4, 1.0}}, {19, {1.0, 0.8, 0.2}}};
    tf.extinction = {{5, 0.0}, {19, 0.4}};
    Scene base = orthoScene(n, 20.0, 12, 12);
    base.nanColor = {1.0, 0.0, 1.0, 0.4};
    base.lights = {Light{LightKind::Directional, {0.3, 0.5, -0.8}, {1, 1, 1}, 1.0}};
    std::vector<std::pair<std::string, Scene>> scenes;
    auto add = [&](std::string name, const std::function<void(Scene&)>& f) {
        Scene s = base;
        f(s);
        scenes.emplace_back(std::move(name), s);
    };
    add("shaded", [](Scene& s) { s.effects.shading = s.effects.shadingGiven = true; });
    add("sobel shadows", [](Scene& s) {
        s.effects.shading = s.effects.shadingGiven = s.effects.shadows = true;
        s.effects.gradient = GradientKind::Sobel;
    });
    add("scattering", [](Scene& s) {
        s.effects.scattering = true;
        s.effects.albedo = 0.6;
    });
    add("path traced", [](Scene& s) {
        s.effects.scattering = true;
        s.effects.albedo = 0.6;
        s.effects.scatteringOrder = ScatteringOrder::Multiple;
        s.effects.samples = 4;
    });
    add("preintegrated lighting", [](Scene& s) {
        s.preintegration = Preintegration::Table2d;
        s.effects.shading = s.effects.shadingGiven = s.effects.shadingPreintegrated = true;
    });
    add("dvr with iso layer", [](Scene& s) { s.effects.isosurfaces = {{12.0, {1, 1, 1, 0.5}}}; });
    add("mip tf colour", [](Scene& s) {
        s.mode = RenderMode::Mip;
        s.mipColor = MipColor::Tf;
    });
    add("smoothed", [](Scene& s) { s.smoothing = 1.0; });
    for (auto& [name, s] : scenes) {
        const ImageBuffer img = GridRenderer(computeContext(), v, tf, s).render();
        double sum = 0.0;
        for (int y = 0; y < img.height; ++y)
            for (int x = 0; x < img.width; ++x)
                for (int c = 0; c < 4; ++c) {
                    const float p = img.at(x, y, c);
                    ASSERT_TRUE(std::isfinite(p)) << name << " at " << x << "," << y << "," << c;
                    ASSERT_GE(p, -1e-6f) << name;
                    if (c == 3) ASSERT_LE(p, 1.0f + 1e-5f) << name; // lit radiance may exceed 1
                    sum += p;
                }
        EXPECT_GT(sum, 0.0) << name;
    }
    // The cubic filters prefilter globally: refused, naming the way out.
    Scene cubic = base;
    cubic.filter = ReconstructionFilter::Cubic;
    try {
        GridRenderer(computeContext(), v, tf, cubic).render();
        ADD_FAILURE() << "cubic filter accepted NaN voxels";
    } catch (const DataError& e) {
        EXPECT_NE(std::string(e.what()).find("--filter linear"), std::string::npos) << e.what();
    }
}

TEST(RenderNan, FiniteVolumesCompileNoNanTest) {
    const Volume finite = makeFloatVolume({4, 4, 4}, [](double x, double, double) { return x; });
    const Volume holed = rampWithHoles(3, 3);
    const Scene s = orthoScene({4, 4, 4}, 4.0);
    EXPECT_EQ(planEffects(s, finite, rampTf()).defines.toOptions().find("NAN_COLOR"), std::string::npos);
    EXPECT_NE(planEffects(s, holed, rampTf()).defines.toOptions().find("NAN_COLOR"), std::string::npos);
}

TEST(RenderNan, SceneKeyRoundTripsAndIsChecked) {
    Scene s = Scene::fromJson(R"({"render": {"nan_color": [1, 0, 0.5, 0.25]}})");
    EXPECT_EQ(s.nanColor, (std::array<double, 4>{1, 0, 0.5, 0.25}));
    EXPECT_EQ(Scene::fromJson(s.toJson()).nanColor, s.nanColor);
    s.nanColor[3] = 1.5;
    EXPECT_THROW(s.validate(), UsageError);
}

} // namespace
