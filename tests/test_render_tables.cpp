// The ray marcher through its tables: shading by the pre-integrated lighting table and iso-surfaces by the
// iso-surface table, against the per-sample paths and the double reference.
#include "TestUtil.hpp"

#include "core/Volume.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/Scene.hpp"
#include "render/VecMath.hpp"
#include "render/grid/GridRenderer.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <string>

namespace {

using namespace volcl;
using volcl::test::computeContext;
using volcl::test::makeFloatVolume;

TransferFunction rampTf() {
    TransferFunction tf;
    tf.domain = {0.0, 40.0};
    tf.color = {{0.0, {1.0, 0.3, 0.1}}, {20.0, {0.2, 0.9, 0.3}}, {40.0, {0.1, 0.4, 1.0}}};
    tf.extinction = {{0.0, 0.0}, {10.0, 0.02}, {30.0, 0.15}, {40.0, 0.05}};
    return tf;
}

Scene litScene(Dims n, double step) {
    Scene s = volcl::test::orthoScene(n, 44.0, 24, 24);
    s.camera->eye = {20 + 30, 20 + 20, -60};
    s.step = step;
    s.preintegration = Preintegration::Table2d;
    s.tableSize = 64;
    s.effects.shading = true;
    s.effects.shadingGiven = true;
    s.lights = {{LightKind::Directional, {0.3, 0.5, -0.8}, {1, 1, 1}, 1.0}};
    return s;
}

double maxAbs(const ImageBuffer& a, const ImageBuffer& b) {
    double m = 0.0;
    for (std::size_t i = 0; i < a.pixels.size(); ++i)
        m = std::max(m, double(std::abs(a.pixels[i] - b.pixels[i])));
    return m;
}

TEST(PreintegratedLighting, PlannedOnlyWhereTheTableApplies) {
    const Volume v = makeFloatVolume({9, 9, 9}, [](double x, double, double) { return x; });
    const TransferFunction tf = rampTf();
    Scene s = litScene(v.dims(), 0.5);
    s.effects.shadingPreintegrated = true;
    EXPECT_TRUE(planEffects(s, v, tf).preintLighting);
    Scene p = s;
    p.preintegration = Preintegration::None;
    EXPECT_FALSE(planEffects(p, v, tf).preintLighting);
    p.preintegration = Preintegration::Table3d;
    EXPECT_FALSE(planEffects(p, v, tf).preintLighting);
    Scene unlit = s;
    unlit.lights.clear();
    EXPECT_FALSE(planEffects(unlit, v, tf).preintLighting);
}

TEST(PreintegratedLighting, ConstantNormalEqualsMidpointLighting) {
    // A linear field has one gradient everywhere: front and back diffuse terms sum to the segment colour, so
    // without specular the table's lighting equals lighting the segment at its midpoint.
    const Volume v =
        makeFloatVolume({41, 41, 41}, [](double x, double y, double) { return 0.6 * x + 0.3 * y; });
    const TransferFunction tf = rampTf();
    Scene s = litScene(v.dims(), 0.5);
    s.effects.specular = 0.0;
    GridRenderer mid(computeContext(), v, tf, s);
    Scene t = s;
    t.effects.shadingPreintegrated = true;
    GridRenderer table(computeContext(), v, tf, t);
    ASSERT_TRUE(table.plan().preintLighting) << table.plan().explain();
    EXPECT_LE(maxAbs(mid.render(), table.render()), 2e-3);
}

TEST(PreintegratedLighting, StaysCloseToTheReferenceOnCurvedData) {
    // A sphere's distance field: the normal turns along every segment. The table path interpolates the
    // normal between the segment ends (diffuse linearised, specular at the emission centroid); it must stay
    // close to the per-sample reference, converge with the step, and stay within a small factor of lighting
    // each segment at its midpoint (measured: 1.4e-3 vs 7.5e-4 at step 1, 3.8e-3 vs 3.0e-3 at step 2).
    const Volume v = makeFloatVolume({41, 41, 41}, [](double x, double y, double z) {
        return std::sqrt((x - 20) * (x - 20) + (y - 20) * (y - 20) + (z - 20) * (z - 20));
    });
    const TransferFunction tf = rampTf();
    double previous = 0.0;
    for (double step : {1.0, 2.0}) {
        SCOPED_TRACE("step " + std::to_string(step));
        Scene s = litScene(v.dims(), step);
        GridRenderer mid(computeContext(), v, tf, s);
        Scene t = s;
        t.effects.shadingPreintegrated = true;
        GridRenderer table(computeContext(), v, tf, t);
        const ImageBuffer ref = referenceRender(v, tf, s, {0.05, 0});
        const double eMid = imageRmse(mid.render(), ref), eTable = imageRmse(table.render(), ref);
        std::cout << "  [pre-integrated lighting] step " << step << ": RMSE table " << eTable << ", midpoint "
                  << eMid << '\n';
        EXPECT_LE(eTable, 0.01);
        EXPECT_LE(eTable, 3.0 * eMid + 1e-4);
        EXPECT_GT(eTable, previous) << "error grows with the step";
        previous = eTable;
    }
}

TEST(PreintegratedLighting, MidpointLightingWeightsSpecularByOpacity) {
    // 2D pre-integration lit at the segment midpoint lights the straight colour and weights it by the
    // segment's opacity, as point sampling does; lighting the associated colour added the specular term once
    // per segment whatever its opacity (RMSE ~0.5 on the MRI scene).
    const Volume v = makeFloatVolume({41, 41, 41}, [](double x, double y, double z) {
        return std::sqrt((x - 20) * (x - 20) + (y - 20) * (y - 20) + (z - 20) * (z - 20));
    });
    const TransferFunction tf = rampTf();
    Scene s = litScene(v.dims(), 0.5);
    s.effects.specular = 0.6;
    GridRenderer mid(computeContext(), v, tf, s);
    Scene point = s;
    point.preintegration = Preintegration::None;
    GridRenderer per(computeContext(), v, tf, point);
    const ImageBuffer ref = referenceRender(v, tf, s, {0.05, 0});
    const double eMid = imageRmse(mid.render(), ref), ePoint = imageRmse(per.render(), ref);
    EXPECT_LE(eMid, 5e-3);
    EXPECT_LE(eMid, 2.0 * ePoint + 1e-4) << "midpoint " << eMid << ", per sample " << ePoint;
}

TEST(IsoTable, FindsTheSurfacesTheRootsFind) {
    const Volume v = makeFloatVolume({41, 41, 41}, [](double x, double y, double z) {
        return std::sqrt((x - 20) * (x - 20) + (y - 20) * (y - 20) + (z - 20) * (z - 20));
    });
    TransferFunction tf;
    tf.domain = {0.0, 40.0};
    tf.color = {{0.0, {1, 1, 1}}};
    tf.extinction = {{0.0, 0.0}};
    Scene s = volcl::test::orthoScene(v.dims(), 44.0, 32, 32);
    s.mode = RenderMode::Iso;
    s.step = 0.5;
    s.tableSize = 256;
    s.effects.isosurfaces = {{12.0, {1.0, 0.5, 0.2, 0.4}}, {16.0, {0.2, 0.6, 1.0, 1.0}}};
    s.effects.shading = false;
    s.effects.shadingGiven = true;
    GridRenderer roots(computeContext(), v, tf, s);
    Scene t = s;
    t.effects.isoTable = true;
    GridRenderer table(computeContext(), v, tf, t);
    ASSERT_TRUE(table.plan().isoTable) << table.plan().explain();
    const ImageBuffer a = roots.render(), b = table.render();
    int differ = 0, both = 0;
    double depthErr = 0.0;
    for (int y = 0; y < s.height; ++y)
        for (int x = 0; x < s.width; ++x) {
            const double aa = a.at(x, y, 3), ab = b.at(x, y, 3);
            if (std::abs(aa - ab) > 0.05) ++differ;
            // Depth away from the silhouette (rays meeting the outer sphere at cos > 0.6): at grazing angles the
            // half-node rounding of the end values moves the crossing far along the ray.
            const double px = 44.0 / s.width, rx = (x + 0.5 - 0.5 * s.width) * px,
                         ry = (y + 0.5 - 0.5 * s.height) * px;
            if (aa > 0 && ab > 0) {
                ++both;
                if (std::hypot(rx, ry) < 0.8 * 16.0)
                    depthErr = std::max(depthErr, double(std::abs(a.at(x, y, 4) - b.at(x, y, 4))));
            }
        }
    // Silhouette pixels may differ (a grazing ray crosses twice inside one step: the table sees no change).
    EXPECT_LE(differ, s.width * s.height / 20) << differ << " pixels differ";
    EXPECT_GT(both, s.width * s.height / 3);
    // The table places a surface at its segment's midpoint: within a step, plus the half-node rounding of
    // each end value (34.6 / 255 / 2 data units over |grad| cos = 0.6 at least).
    EXPECT_LE(depthErr, s.step + 0.1);
    // Dvr mixes surfaces by their roots: the table is dropped there.
    Scene d = t;
    d.mode = RenderMode::Dvr;
    EXPECT_FALSE(planEffects(d, v, tf).isoTable);
}

} // namespace
