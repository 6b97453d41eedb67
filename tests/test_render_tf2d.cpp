// Gradient transfer functions (2D widgets over value x gradient magnitude, gradient opacity): the JSON form and its
// refusals, the kernel and the double reference against closed-form oracles on analytic fields, hard cases.
#include "TestUtil.hpp"

#include "core/Error.hpp"
#include "core/Volume.hpp"
#include "host/tf/TransferFunction.hpp"
#include "preintegration/PreintegrationTable.hpp"
#include "render/Reference.hpp"
#include "render/Scene.hpp"
#include "render/grid/GridRenderer.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <string>

namespace {

using namespace volcl;
using volcl::test::computeContext;
using volcl::test::makeFloatVolume;
using volcl::test::orthoScene;

constexpr const char* kRampTf = R"({
  "domain": [0, 64],
  "color": [[0, 0.2, 0.2, 1.0], [64, 0.2, 0.2, 1.0]],
  "extinction": [[0, 0], [8, 0], [8.5, 0.01], [56, 0.01], [56.5, 0]],
  "gradient_opacity": [[0, 1], [1, 1], [3, 0.5]],
  "widgets": [
    {"type": "box", "value": [20, 40], "gradient": [1, 3], "color": [1, 0.5, 0], "extinction": 0.1},
    {"type": "gaussian", "center": [46, 2], "sigma": [3, 1], "color": [0, 1, 0], "extinction": 0.2}
  ]
})";

/// Emission-absorption along one ray by fine midpoint steps of the closed-form classification `f(z)` ->
/// (r, g, b, tau) over z in [z0, z1] (the oracle: no volume, no trilinear field, no kernel code).
std::array<double, 4> integrate(const std::function<std::array<double, 4>(double)>& f, double z0, double z1) {
    const int m = 200000;
    const double dz = (z1 - z0) / m;
    std::array<double, 4> out{0, 0, 0, 0};
    double T = 1.0;
    for (int i = 0; i < m; ++i) {
        const auto c = f(z0 + (i + 0.5) * dz);
        const double a = 1.0 - std::exp(-c[3] * dz);
        for (int k = 0; k < 3; ++k)
            out[std::size_t(k)] += T * a * c[std::size_t(k)];
        T *= 1.0 - a;
    }
    out[3] = 1.0 - T;
    return out;
}

/// The ramp scene (looking down z at a 9 x 9 x 33 grid, step 0.02) rendered by the kernel and the double reference:
/// pixel (1, 2) of each within 3e-3 per channel of the oracle's `want`. Returns the scene.
Scene expectRampPixel(const Volume& v, const TransferFunction& tf, const std::array<double, 4>& want) {
    Scene s = orthoScene(v.dims(), 4.0, 4, 4);
    s.step = 0.02;
    const ImageBuffer img = GridRenderer(computeContext(), v, tf, s).render();
    const ImageBuffer ref = referenceRender(v, tf, s, {.step = 0.02});
    for (int c = 0; c < 4; ++c) {
        EXPECT_NEAR(img.at(1, 2, c), want[std::size_t(c)], 3e-3) << "kernel, channel " << c;
        EXPECT_NEAR(ref.at(1, 2, c), want[std::size_t(c)], 3e-3) << "reference, channel " << c;
    }
    return s;
}

TEST(GradientTf, JsonRoundTripAndClassification) {
    const TransferFunction tf = TransferFunction::fromJson(kRampTf);
    ASSERT_TRUE(tf.usesGradient());
    EXPECT_FALSE(tf.normalized);
    ASSERT_EQ(tf.widgets.size(), 2u);
    EXPECT_EQ(tf.widgets[1].shape, TfWidgetShape::Gaussian);
    EXPECT_DOUBLE_EQ(tf.gradientOpacityAt(2.0), 0.75);
    EXPECT_DOUBLE_EQ(tf.gradientOpacityAt(100.0), 0.5); // beyond the points
    EXPECT_DOUBLE_EQ(tf.gradientOpacityAt(std::numeric_limits<double>::quiet_NaN()), 0.5); // no gradient
    // In the box at g = 2: tau 0.01 * 0.75 + 0.1 (the Gaussian adds its tail).
    const auto c = tf.classify(30.0, 2.0);
    const double gauss = 0.2 * std::exp(-0.5 * (16.0 / 3.0) * (16.0 / 3.0));
    EXPECT_NEAR(c[3], 0.0075 + 0.1 + gauss, 1e-12);
    EXPECT_NEAR(c[0], (0.2 * 0.0075 + 1.0 * 0.1) / c[3], 1e-12);
    // Beyond the box's gradient range only the value axis and the Gaussian's tail remain.
    EXPECT_NEAR(tf.classify(30.0, 5.0)[3], 0.005 + 0.2 * std::exp(-0.5 * ((16.0 / 3) * (16.0 / 3) + 9.0)),
                1e-12);
    const TransferFunction back = TransferFunction::fromJson(tf.toJson());
    EXPECT_EQ(back.toJson(), tf.toJson());
    // The value axis rescales with an explicit range; the gradient axis is absolute.
    const TransferFunction r = tf.rescaled({0.0, 128.0});
    EXPECT_DOUBLE_EQ(r.widgets[0].valueRange[1], 80.0);
    EXPECT_DOUBLE_EQ(r.widgets[0].gradientRange[1], 3.0);
    EXPECT_DOUBLE_EQ(r.widgets[1].sigma[0], 6.0);
    // Widgets alone over a domain: the value axis adds nothing.
    const TransferFunction w = TransferFunction::fromJson(
        R"({"domain": [0, 10], "widgets": [{"type": "box", "value": [1, 2], "gradient": [0, 1],
            "color": [1, 1, 1], "extinction": 2}]})");
    EXPECT_EQ(w.maxExtinction(), 0.0);
    EXPECT_EQ(w.classify(1.5, 0.5)[3], 2.0);
}

TEST(GradientTf, BadJsonIsRefusedAtLoad) {
    const std::string box = R"("type": "box", "value": [1, 2], "gradient": [0, 1], "color": [1, 1, 1])";
    auto tfWith = [](const std::string& extra) {
        return R"({"domain": [0, 10], "color": [[0, 1, 1, 1]], "extinction": [[0, 0.1]], )" + extra + "}";
    };
    for (const std::string& bad : {
             tfWith(R"("widgets": [{"type": "box", "value": [2, 2], "gradient": [0, 1], "color": [1, 1, 1],
                     "extinction": 1}])"), // zero width
             tfWith(R"("widgets": [{"type": "gaussian", "center": [2, 2], "sigma": [0, 1], "color": [1, 1, 1],
                     "extinction": 1}])"), // zero sigma
             tfWith(R"("widgets": [{)" + box + R"(, "extinction": -1}])"),
             tfWith(R"("widgets": [{)" + box + R"(, "extinction": 1, "sharpness": 2}])"),
             tfWith(R"("widgets": [{"type": "ellipse"}])"),
             tfWith(R"("widgets": [{"type": "box", "value": [1, 2], "gradient": [-2, -1], "color": [1, 1, 1],
                     "extinction": 1}])"), // below every gradient magnitude
             tfWith(R"("gradient_opacity": [[0, 1.5]])"), tfWith(R"("gradient_opacity": [[2, 1], [1, 0.5]])"),
             tfWith(R"("gradient_opacity": [[-1, 1]])"), tfWith(R"("gradient_opacity": [])"),
             std::string(R"({"widgets": [{)" + box + R"(, "extinction": 1}]})"), // no domain
         })
        EXPECT_THROW(TransferFunction::fromJson(bad), DataError) << bad;
}

TEST(GradientTf, LinearRampMatchesClosedForm) {
    // s = 2 z: the gradient magnitude is 2 (data value per world unit) everywhere, the value grows along the
    // ray. The oracle integrates the closed-form classification at g = 2 along z.
    const Dims n{9, 9, 33};
    const Volume v = makeFloatVolume(n, [](double, double, double z) { return float(2.0 * z); });
    const TransferFunction tf = TransferFunction::fromJson(kRampTf);
    auto oracleAt = [](double z) -> std::array<double, 4> {
        const double s = 2.0 * z;
        const double tau1 = (s < 8.0     ? 0.0
                             : s < 8.5   ? 0.02 * (s - 8.0)
                             : s <= 56.0 ? 0.01
                             : s < 56.5  ? 0.01 - 0.02 * (s - 56.0)
                                         : 0.0) *
                            0.75;
        const double box = s >= 20.0 && s <= 40.0 ? 0.1 : 0.0;
        const double gauss = 0.2 * std::exp(-0.5 * ((s - 46.0) / 3.0) * ((s - 46.0) / 3.0));
        const double tau = tau1 + box + gauss;
        if (tau <= 0.0) return {0, 0, 0, 0};
        return {(0.2 * tau1 + box) / tau, (0.2 * tau1 + 0.5 * box + gauss) / tau, tau1 / tau, tau};
    };
    const auto want = integrate(oracleAt, 0.0, 32.0);
    const Scene s = expectRampPixel(v, tf, want);
    EXPECT_GT(want[3], 0.5);
    // Beyond every widget's gradient range (s = 20 z: g = 20) only the value axis remains, at the gradient
    // opacity's last factor: the same image as that TF without widgets, scaled.
    const Volume steep = makeFloatVolume(n, [](double, double, double z) { return float(20.0 * z); });
    const ImageBuffer steepImg = GridRenderer(computeContext(), steep, tf, s).render();
    TransferFunction plain = tf;
    plain.widgets.clear();
    plain.gradientOpacity.clear();
    for (auto& p : plain.extinction)
        p.tau *= 0.5;
    const ImageBuffer plainImg = GridRenderer(computeContext(), steep, plain, s).render();
    EXPECT_LT(test::maxAbsDiff(steepImg, plainImg), 1e-5);
}

// ParaView's box (imported from its state files): a Gaussian of opacity inside the box, sigma 0.3 of the box on each
// axis, read as opacity per unit distance. On the ramp s = 2 z (g = 2) the closed form along z is the oracle.
TEST(GradientTf, ParaViewBoxOnARampMatchesClosedForm) {
    const char* json = R"({"domain": [0, 64], "widgets": [{"type": "paraview_box", "value": [10, 50],
        "gradient": [1, 4], "color": [1, 0.5, 0.25], "opacity": 0.9, "unit_distance": 2}]})";
    const TransferFunction tf = TransferFunction::fromJson(json);
    ASSERT_EQ(tf.widgets.size(), 1u);
    EXPECT_EQ(tf.widgets[0].shape, TfWidgetShape::ParaViewBox);
    EXPECT_EQ(TransferFunction::fromJson(tf.toJson()).toJson(), tf.toJson());
    auto oracleTau = [](double s, double g) {
        if (s < 10.0 || s > 50.0 || g < 1.0 || g > 4.0) return 0.0;
        const double u = (s - 30.0) / 12.0, v = (g - 2.5) / 0.9;
        return -std::log(1.0 - 0.9 * std::exp(-0.5 * (u * u + v * v))) / 2.0;
    };
    for (double s : {5.0, 10.0, 22.0, 30.0, 49.0, 51.0})
        for (double g : {0.5, 1.0, 2.5, 3.9, 4.5})
            EXPECT_NEAR(tf.classify(s, g)[3], oracleTau(s, g), 1e-12) << s << ", " << g;
    // An opacity of 1 at the centre is an extinction of kMaxImportedExtinction per unit distance, not infinity.
    const TransferFunction full = TransferFunction::fromJson(R"({"domain": [0, 64], "widgets": [{"type":
        "paraview_box", "value": [10, 50], "gradient": [1, 4], "color": [1, 1, 1], "opacity": 1}]})");
    EXPECT_EQ(full.classify(30.0, 2.5)[3], kMaxImportedExtinction);

    const Dims n{9, 9, 33};
    const Volume v = makeFloatVolume(n, [](double, double, double z) { return float(2.0 * z); });
    const auto want = integrate(
        [&](double z) -> std::array<double, 4> {
            const double tau = oracleTau(2.0 * z, 2.0);
            return {1.0, 0.5, 0.25, tau};
        },
        0.0, 32.0);
    const Scene s = expectRampPixel(v, tf, want);
    EXPECT_GT(want[3], 0.5);
    // Refused at load: opacity outside [0, 1], a unit distance of 0, an extinction (a ParaView box has none).
    for (const std::string& bad : {
             std::string(R"({"domain": [0, 9], "widgets": [{"type": "paraview_box", "value": [1, 2],
                 "gradient": [0, 1], "color": [1, 1, 1], "opacity": 1.5}]})"),
             std::string(R"({"domain": [0, 9], "widgets": [{"type": "paraview_box", "value": [1, 2],
                 "gradient": [0, 1], "color": [1, 1, 1], "opacity": 0.5, "unit_distance": 0}]})"),
             std::string(R"({"domain": [0, 9], "widgets": [{"type": "paraview_box", "value": [1, 2],
                 "gradient": [0, 1], "color": [1, 1, 1], "opacity": 0.5, "extinction": 1}]})"),
             std::string(R"({"domain": [0, 9], "widgets": [{"type": "paraview_box", "value": [2, 2],
                 "gradient": [0, 1], "color": [1, 1, 1], "opacity": 0.5}]})"),
         })
        EXPECT_THROW(TransferFunction::fromJson(bad), DataError) << bad;
}

TEST(GradientTf, SphereShellByGradientMatchesChordLengths) {
    // A distance field from the centre: |gradient| = 1 off the centre. A box on values [8, 12] and gradients
    // [0.8, 1.2] is the shell between radii 8 and 12; the oracle is its chord length through each pixel.
    const Dims n{33, 33, 33};
    const Volume v = makeFloatVolume(n, [](double x, double y, double z) {
        return float(std::sqrt((x - 16) * (x - 16) + (y - 16) * (y - 16) + (z - 16) * (z - 16)));
    });
    const TransferFunction tf = TransferFunction::fromJson(
        R"({"domain": [0, 30], "widgets": [{"type": "box", "value": [8, 12], "gradient": [0.8, 1.2],
            "color": [1, 0.8, 0.6], "extinction": 0.3}]})");
    const int w = 16;
    const double h = 30.0;
    Scene s = orthoScene(n, h, w, w);
    s.step = 0.05;
    const ImageBuffer img = GridRenderer(computeContext(), v, tf, s).render();
    const ImageBuffer ref = referenceRender(v, tf, s, {.step = 0.05});
    double worstKernel = 0.0, worstRef = 0.0, sumKernel = 0.0;
    for (int y = 0; y < w; ++y)
        for (int x = 0; x < w; ++x) {
            const double px = ((x + 0.5) / w - 0.5) * h, py = ((y + 0.5) / w - 0.5) * h;
            const double d2 = px * px + py * py;
            const double len =
                2.0 * (std::sqrt(std::max(0.0, 144.0 - d2)) - std::sqrt(std::max(0.0, 64.0 - d2)));
            const double a = 1.0 - std::exp(-0.3 * len);
            worstKernel = std::max(worstKernel, std::abs(img.at(x, y, 3) - a));
            sumKernel += std::abs(img.at(x, y, 3) - a);
            worstRef = std::max(worstRef, std::abs(ref.at(x, y, 3) - a));
            EXPECT_NEAR(img.at(x, y, 1), 0.8 * img.at(x, y, 3), 1e-5);
        }
    // The trilinear distance field is not the exact distance (it overestimates between voxels by up to
    // h^2 / (8 r)): the shell's radii move by a few hundredths, most where a ray grazes the inner sphere.
    EXPECT_LT(worstKernel, 0.06);
    EXPECT_LT(worstRef, 0.06);
    EXPECT_LT(sumKernel / (w * w), 0.015);
    EXPECT_LT(test::maxAbsDiff(img, ref), 0.01);
}

TEST(GradientTf, FlatDataHasGradientZero) {
    const Dims n{9, 9, 17};
    const Volume v = makeFloatVolume(n, [](double, double, double) { return 30.0f; });
    const TransferFunction tf = TransferFunction::fromJson(
        R"({"domain": [0, 64], "color": [[0, 0, 0, 1]], "extinction": [[0, 0.05]],
            "gradient_opacity": [[0, 0.4], [1, 1]],
            "widgets": [{"type": "box", "value": [20, 40], "gradient": [0, 0.5], "color": [1, 0, 0],
                         "extinction": 0.1}]})");
    const double tau = 0.05 * 0.4 + 0.1;
    const double alpha = 1.0 - std::exp(-tau * 16.0);
    Scene s = orthoScene(n, 4.0, 4, 4);
    s.step = 0.5;
    const ImageBuffer img = GridRenderer(computeContext(), v, tf, s).render();
    for (int y = 0; y < 4; ++y)
        for (int x = 0; x < 4; ++x) {
            EXPECT_NEAR(img.at(x, y, 3), alpha, 2e-5);
            EXPECT_NEAR(img.at(x, y, 0), alpha * 0.1 / tau, 2e-5);
            EXPECT_NEAR(img.at(x, y, 2), alpha * 0.02 / tau, 2e-5);
        }
}

TEST(GradientTf, NanVoxelsStayFiniteAndLocal) {
    const Dims n{9, 9, 33};
    auto ramp = [](double, double, double z) { return float(2.0 * z); };
    const Volume clean = makeFloatVolume(n, ramp);
    const Volume holed = makeFloatVolume(n, [&](double x, double y, double z) {
        return x <= 2.0 ? std::numeric_limits<float>::quiet_NaN() : ramp(x, y, z);
    });
    const TransferFunction tf = TransferFunction::fromJson(kRampTf);
    Scene s = orthoScene(n, 8.0, 8, 8);
    s.step = 0.1;
    const ImageBuffer a = GridRenderer(computeContext(), clean, tf, s).render();
    const ImageBuffer b = GridRenderer(computeContext(), holed, tf, s).render();
    for (int y = 0; y < 8; ++y)
        for (int x = 0; x < 8; ++x)
            for (int c = 0; c < 4; ++c) {
                const float got = b.at(x, y, c);
                ASSERT_TRUE(std::isfinite(got)) << x << "," << y << "," << c;
                EXPECT_GE(got, 0.0f);
                EXPECT_LE(got, 1.0f + 1e-5f);
                // Image x runs toward world -x here: columns 0-3 are world x 7.5-4.5, whose samples and central
                // differences (one voxel each way) read no voxel at x <= 2.
                if (x <= 3) EXPECT_NEAR(got, a.at(x, y, c), 1e-6) << x << "," << y << "," << c;
            }
}

TEST(GradientTf, CombinationsWithoutAGradientAxisAreRefused) {
    const Dims n{9, 9, 17};
    const Volume v = makeFloatVolume(n, [](double, double, double z) { return float(2.0 * z); });
    const TransferFunction tf = TransferFunction::fromJson(kRampTf);
    Scene base = orthoScene(n, 4.0, 4, 4);
    Scene pre = base;
    pre.preintegration = Preintegration::Table2d;
    EXPECT_THROW(GridRenderer(computeContext(), v, tf, pre), UsageError);
    Scene mip = base;
    mip.mode = RenderMode::Mip;
    EXPECT_THROW(GridRenderer(computeContext(), v, tf, mip), UsageError);
    EXPECT_THROW(referenceRender(v, tf, pre), UsageError);
    TableSpec spec;
    EXPECT_THROW(generatePreintegrationTable(tf, spec, {}, &computeContext()), UsageError);
    // A renderer holding a plain TF refuses the gradient TF for a pre-integrated scene, and keeps its TF.
    TransferFunction plain = tf;
    plain.widgets.clear();
    plain.gradientOpacity.clear();
    GridRenderer r(computeContext(), v, plain, pre);
    const ImageBuffer before = r.render();
    EXPECT_THROW(r.setTransferFunction(tf), UsageError);
    EXPECT_EQ(test::maxAbsDiff(before, r.render()), 0.0);
    // The plan says what the gradient TF compiled and dropped.
    GridRenderer g(computeContext(), v, tf, base);
    EXPECT_TRUE(g.plan().gradientTf);
    EXPECT_FALSE(g.plan().skipping);
}

} // namespace
