// Multiple scattering: the OpenCL path tracer against its double reference and analytic oracles (white
// furnace, emission-absorption, single scattering), Monte Carlo convergence, seeds, hard cases; clouds.
#include "TestUtil.hpp"

#include "core/Error.hpp"
#include "core/Volume.hpp"
#include "host/io/VolumeIo.hpp"
#include "host/phantoms/Cloud.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/EffectPlan.hpp"
#include "render/Scene.hpp"
#include "render/grid/GridRenderer.hpp"
#include "render/grid/PathTracer.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <limits>

namespace {

using namespace volcl;
using volcl::test::computeContext;
using volcl::test::makeFloatVolume;
using volcl::test::orthoScene;

TransferFunction rampTf(double tauMax, std::array<double, 3> rgb = {1.0, 1.0, 1.0}) {
    TransferFunction tf;
    tf.domain = {0.0, 1.0};
    tf.color = {{0.0, rgb}};
    tf.extinction = {{0.0, 0.0}, {1.0, tauMax}};
    return tf;
}

/// A soft ball of density 1 at the centre falling to 0 at radius r (0 outside: majorant 0 in the corners).
Volume ball(Dims n, double r) {
    const double cx = double(n.x - 1) / 2, cy = double(n.y - 1) / 2, cz = double(n.z - 1) / 2;
    return makeFloatVolume(n, [=](double x, double y, double z) {
        const double d = std::sqrt((x - cx) * (x - cx) + (y - cy) * (y - cy) + (z - cz) * (z - cz));
        return std::max(0.0, 1.0 - d / r);
    });
}

Scene multipleScene(Dims n, int samples) {
    Scene s = orthoScene(n, double(n.x - 1), 8, 8);
    s.effects.scattering = true;
    s.effects.scatteringOrder = ScatteringOrder::Multiple;
    s.effects.albedo = 1.0;
    s.effects.samples = samples;
    s.effects.maxBounces = 4096;
    return s;
}

/// Mean over pixels of channel c of a minus channel d of b, and the standard error of that mean (pixels as
/// independent estimates).
struct MeanDiff {
    double mean = 0.0, se = 0.0;
};
MeanDiff meanDiff(const ImageBuffer& a, int c, const ImageBuffer& b, int d) {
    double s = 0.0, s2 = 0.0;
    const double n = double(a.width) * double(a.height);
    for (int y = 0; y < a.height; ++y)
        for (int x = 0; x < a.width; ++x) {
            const double v = double(a.at(x, y, c)) - double(b.at(x, y, d));
            s += v;
            s2 += v * v;
        }
    const double m = s / n;
    return {m, std::sqrt(std::max(s2 / n - m * m, 0.0) / n)};
}

void expectFinite(const ImageBuffer& img) {
    for (float v : img.pixels) {
        ASSERT_TRUE(std::isfinite(v));
        ASSERT_GE(v, -1e-6f);
    }
}

// A closed medium of albedo 1 under a uniform sky of radiance 1 scatters out exactly the light it takes in:
// every pixel's scattered radiance equals its coverage (rgb = a), whatever the phase function.
TEST(PathTrace, WhiteFurnaceConservesEnergyForEveryPhase) {
    const Dims n{17, 17, 17};
    const Volume v = makeFloatVolume(n, [](double, double, double) { return 1.0; });
    const TransferFunction tf = rampTf(0.25); // optical depth 4 across the box
    for (double g : {-0.99, 0.0, 0.99}) {
        Scene s = multipleScene(n, 64);
        s.effects.phaseG = g;
        s.effects.emission = false;
        s.effects.environment = {1, 1, 1};
        GridRenderer r(computeContext(), v, tf, s);
        ASSERT_TRUE(r.plan().pathTracing) << r.plan().explain();
        const ImageBuffer img = r.render();
        expectFinite(img);
        for (int c = 0; c < 3; ++c) {
            const MeanDiff d = meanDiff(img, c, img, 3);
            EXPECT_LT(std::abs(d.mean), 4.0 * d.se + 2e-3) << "g " << g << " channel " << c << " se " << d.se;
            if (c == 0)
                std::cout << "furnace g " << g << ": mean(rgb - a) " << d.mean << ", SE " << d.se << '\n';
        }
        EXPECT_GT(img.at(4, 4, 3), 0.95f); // the medium is thick: the furnace test is not trivial
        // Albedo 0.5 absorbs: clearly less comes out than goes in.
        s.effects.albedo = 0.5;
        r.setScene(s);
        const ImageBuffer half = r.render();
        EXPECT_LT(meanDiff(half, 0, half, 3).mean, -0.2) << "g " << g;
    }
}

// Albedo 0 with emission is the emission-absorption integral of the ray marcher.
TEST(PathTrace, AlbedoZeroIsEmissionAbsorption) {
    const Dims n{17, 17, 17};
    const Volume v = ball(n, 8.0);
    const TransferFunction tf = rampTf(0.6, {1.0, 0.5, 0.25});
    Scene s = multipleScene(n, 128);
    s.effects.albedo = 0.0;
    GridRenderer r(computeContext(), v, tf, s);
    ASSERT_TRUE(r.plan().pathTracing);
    const ImageBuffer img = r.render();
    Scene dvr = s;
    dvr.effects.scattering = false;
    dvr.step = 0.02;
    const ImageBuffer ref = referenceRender(v, tf, dvr, {.step = 0.02});
    for (int c = 0; c < 4; ++c) {
        const MeanDiff d = meanDiff(img, c, ref, c);
        EXPECT_LT(std::abs(d.mean), 4.0 * d.se + 1e-3) << "channel " << c;
    }
    EXPECT_LT(imageRmse(img, ref), 0.03);
    // No emission and no scattering: black, exactly.
    s.effects.emission = false;
    s.effects.albedo = 0.0;
    s.lights = {Light{LightKind::Directional, {0, 0, -1}, {1, 1, 1}, 1.0}};
    EXPECT_FALSE(GridRenderer(computeContext(), v, tf, s).plan().pathTracing); // dropped: nothing to show
}

// Restricted to one bounce, the path tracer computes single scattering: the ray marcher's lit integral
// with shadow rays.
TEST(PathTrace, OneBounceEqualsSingleScattering) {
    const Dims n{17, 17, 17};
    const Volume v = ball(n, 8.0);
    const TransferFunction tf = rampTf(0.5, {0.9, 0.7, 0.5});
    Scene single = orthoScene(n, 16.0, 8, 8);
    single.step = 0.02;
    single.lights = {Light{LightKind::Directional, {0.4, 0.6, -0.7}, {1, 1, 1}, 2.0}};
    single.effects.scattering = true;
    single.effects.albedo = 0.8;
    single.effects.phaseG = 0.3;
    single.effects.shadows = true;
    single.effects.shadowStep = 0.02;
    const ImageBuffer ref = referenceRender(v, tf, single, {.step = 0.02});
    GridRenderer marcher(computeContext(), v, tf, single);
    EXPECT_LT(imageRmse(marcher.render(), ref), 3e-3);
    Scene pt = single;
    pt.effects.scatteringOrder = ScatteringOrder::Multiple;
    pt.effects.maxBounces = 1;
    pt.effects.samples = 256;
    GridRenderer r(computeContext(), v, tf, pt);
    const ImageBuffer img = r.render();
    for (int c = 0; c < 4; ++c) {
        const MeanDiff d = meanDiff(img, c, ref, c);
        EXPECT_LT(std::abs(d.mean), 4.0 * d.se + 1e-3) << "channel " << c << " se " << d.se;
    }
    EXPECT_LT(imageRmse(img, ref), 0.02);
    std::cout << "one bounce vs single scattering: RMSE " << imageRmse(img, ref) << ", mean R diff "
              << meanDiff(img, 0, ref, 0).mean << " (SE " << meanDiff(img, 0, ref, 0).se << ")\n";
    // More bounces add light.
    pt.effects.maxBounces = 64;
    r.setScene(pt);
    EXPECT_GT(meanDiff(r.render(), 0, img, 0).mean, 0.005);
}

// The octave approximation of multiple scattering: kernel against the double reference, and closer to the
// path tracer's multiple scattering than single scattering is.
TEST(PathTrace, OctaveApproximationMatchesReferenceAndBeatsSingle) {
    const Dims n{17, 17, 17};
    const Volume v = ball(n, 8.0);
    const TransferFunction tf = rampTf(0.8, {1, 1, 1});
    Scene s = orthoScene(n, 16.0, 8, 8);
    s.step = 0.05;
    s.lights = {Light{LightKind::Directional, {0.4, 0.6, -0.7}, {1, 1, 1}, 2.0}};
    s.effects.scattering = true;
    s.effects.albedo = 0.95;
    s.effects.phaseG = 0.5;
    s.effects.emission = false;
    s.effects.shadows = true;
    s.effects.shadowStep = 0.05;
    const ImageBuffer single = GridRenderer(computeContext(), v, tf, s).render();
    Scene oct = s;
    oct.effects.octaves = 4;
    GridRenderer r(computeContext(), v, tf, oct);
    EXPECT_NE(r.plan().defines.toOptions().find("-DMS_OCTAVES=4"), std::string::npos);
    const ImageBuffer approx = r.render();
    EXPECT_LT(imageRmse(approx, referenceRender(v, tf, oct, {.step = 0.05})), 3e-3);
    Scene pt = s;
    pt.effects.scatteringOrder = ScatteringOrder::Multiple;
    pt.effects.samples = 512;
    const ImageBuffer multiple = GridRenderer(computeContext(), v, tf, pt).render();
    std::cout << "against the path tracer: octaves(4) RMSE " << imageRmse(approx, multiple) << ", single "
              << imageRmse(single, multiple) << '\n';
    EXPECT_LT(imageRmse(approx, multiple), imageRmse(single, multiple))
        << "octaves " << imageRmse(approx, multiple) << ", single " << imageRmse(single, multiple);
}

// Kernel and double reference draw the same random stream: their images agree within Monte Carlo error
// (and, path for path, mostly exactly).
TEST(PathTrace, KernelMatchesDoubleReference) {
    const Dims n{21, 17, 13};
    const Volume v = ball(n, 9.0);
    const TransferFunction tf = rampTf(0.8, {1.0, 0.8, 0.6});
    Scene s = multipleScene(n, 32);
    s.effects.albedo = 0.9;
    s.effects.phaseG = 0.5;
    s.effects.environment = {0.2, 0.3, 0.5};
    s.lights = {Light{LightKind::Directional, {0.3, 0.8, -0.5}, {1, 1, 1}, 1.5},
                Light{LightKind::Head, {0, 0, -1}, {1, 1, 1}, 0.5}};
    GridRenderer r(computeContext(), v, tf, s);
    const ImageBuffer img = r.render();
    const ImageBuffer ref = pathTraceReference(v, tf, s);
    expectFinite(img);
    for (int c = 0; c < 4; ++c) {
        const MeanDiff d = meanDiff(img, c, ref, c);
        EXPECT_LT(std::abs(d.mean), 4.0 * d.se + 1e-3) << "channel " << c;
    }
    // Same stream: closer to the reference than to the kernel's own image under another seed (the noise); float
    // and double paths part ways now and then (a collision test that lands within rounding), so not equal.
    Scene other = s;
    other.effects.seed = 77;
    r.setScene(other);
    const double noise = imageRmse(img, r.render()), gap = imageRmse(img, ref);
    std::cout << "kernel vs reference: same-seed RMSE " << gap << ", other-seed RMSE " << noise << '\n';
    EXPECT_LT(gap, 0.8 * noise) << "same-seed RMSE " << gap << ", other-seed RMSE " << noise;
}

// Error against a converged reference falls as 1/sqrt(samples).
TEST(PathTrace, RmseFallsAsInverseSquareRootOfSamples) {
    const Dims n{17, 17, 17};
    const Volume v = ball(n, 8.0);
    const TransferFunction tf = rampTf(0.8, {1.0, 0.9, 0.8});
    Scene s = multipleScene(n, 4096);
    s.effects.albedo = 0.95;
    s.lights = {Light{LightKind::Directional, {0.5, 0.5, -0.7}, {1, 1, 1}, 1.0}};
    s.effects.seed = 99;
    GridRenderer r(computeContext(), v, tf, s);
    const ImageBuffer converged = r.render();
    std::vector<double> logN, logE;
    for (int spp : {4, 16, 64}) {
        s.effects.samples = spp;
        s.effects.seed = 7;
        r.setScene(s);
        logN.push_back(std::log(double(spp)));
        logE.push_back(std::log(imageRmse(r.render(), converged)));
    }
    const double slope = (logE[2] - logE[0]) / (logN[2] - logN[0]);
    std::cout << "convergence: RMSE " << std::exp(logE[0]) << ", " << std::exp(logE[1]) << ", "
              << std::exp(logE[2]) << " at 4, 16, 64 spp; slope " << slope << '\n';
    EXPECT_NEAR(slope, -0.5, 0.12) << "rmse " << std::exp(logE[0]) << " " << std::exp(logE[1]) << " "
                                   << std::exp(logE[2]);
}

TEST(PathTrace, SameSeedSameImageAndProgressiveEqualsOneShot) {
    const Dims n{17, 17, 17};
    const Volume v = ball(n, 8.0);
    const TransferFunction tf = rampTf(0.8);
    Scene s = multipleScene(n, 8);
    s.effects.albedo = 0.9;
    s.lights = {Light{LightKind::Directional, {0, 1, -1}, {1, 1, 1}, 1.0}};
    GridRenderer r(computeContext(), v, tf, s);
    const ImageBuffer a = r.render();
    const ImageBuffer b = GridRenderer(computeContext(), v, tf, s).render();
    EXPECT_EQ(a.pixels, b.pixels);
    r.setScene(s); // starts the accumulation over
    EXPECT_EQ(r.accumulateSamples(4), 4);
    EXPECT_EQ(r.accumulateSamples(4), 8);
    EXPECT_EQ(r.accumulatedImage().pixels, a.pixels);
    // Through the renderer interface (what the viewer calls): the same view keeps accumulating.
    r.setScene(s);
    VolumeRenderer& vr = r;
    vr.renderProgressive(4);
    r.setView(*s.camera, s.width, s.height, s.step);
    EXPECT_EQ(vr.renderProgressive(4).pixels, a.pixels);
    s.effects.seed = 2;
    r.setScene(s);
    EXPECT_NE(r.render().pixels, a.pixels);
}

TEST(PathTrace, MajorantZeroInPlacesAndEmptyVolume) {
    // Density only in the lower half of x: the other macrocells have majorant 0 and are crossed unsampled.
    const Dims n{33, 17, 17};
    const Volume v = makeFloatVolume(n, [](double x, double, double) { return x < 12 ? 0.8 : 0.0; });
    const TransferFunction tf = rampTf(0.5);
    Scene s = multipleScene(n, 16);
    s.camera->height = 16.0;
    s.width = 16;
    s.effects.albedo = 0.9;
    s.effects.environment = {1, 1, 1};
    s.lights = {Light{LightKind::Directional, {1, 0, 0}, {1, 1, 1}, 1.0}};
    {
        grid_detail::MacrocellGrid g = grid_detail::buildMacrocells(v, 8);
        const auto m = majorantGrid(g, tf);
        EXPECT_EQ(m.back(), 0.0f);
        EXPECT_GT(m.front(), 0.0f);
    }
    GridRenderer r(computeContext(), v, tf, s);
    const ImageBuffer img = r.render();
    const ImageBuffer ref = pathTraceReference(v, tf, s);
    expectFinite(img);
    for (int c = 0; c < 4; ++c) {
        const MeanDiff d = meanDiff(img, c, ref, c);
        EXPECT_LT(std::abs(d.mean), 4.0 * d.se + 1e-3) << "channel " << c;
    }
    // Pixels over the empty half (the camera's right vector is -x: pixel 0 sees x = 31) stay exactly 0.
    EXPECT_EQ(img.at(0, 4, 3), 0.0f);
    EXPECT_EQ(img.at(0, 4, 0), 0.0f);
    EXPECT_GT(img.at(15, 4, 3), 0.9f);
    const Volume empty = makeFloatVolume(n, [](double, double, double) { return 0.0; });
    for (float p : GridRenderer(computeContext(), empty, tf, s).render().pixels)
        ASSERT_EQ(p, 0.0f);
}

TEST(PathTrace, ExtremePhaseAndAlbedoStayFinite) {
    const Dims n{17, 17, 17};
    const Volume v = ball(n, 8.0);
    const TransferFunction tf = rampTf(2.0);
    for (double g : {-0.99, 0.99})
        for (double albedo : {0.0, 1.0}) {
            Scene s = multipleScene(n, 8);
            s.effects.albedo = albedo;
            s.effects.phaseG = g;
            s.lights = {Light{LightKind::Directional, {0, 0, -1}, {1, 1, 1}, 1.0}};
            const ImageBuffer img = GridRenderer(computeContext(), v, tf, s).render();
            expectFinite(img);
        }
}

TEST(PathTrace, RefusesBadInput) {
    const Dims n{9, 9, 9};
    Volume v = makeFloatVolume(n, [](double, double, double) { return 0.5; });
    v.values<float>()[5] = std::numeric_limits<float>::quiet_NaN();
    Scene s = multipleScene(n, 4);
    s.effects.environment = {1, 1, 1};
    // A NaN voxel takes the NaN colour (transparent by default): the image stays finite.
    expectFinite(GridRenderer(computeContext(), v, rampTf(1.0), s).render());
    TransferFunction negative = rampTf(1.0);
    negative.extinction = {{0.0, -0.5}, {1.0, 1.0}};
    EXPECT_THROW(negative.validate(), Error);
    EXPECT_THROW(Scene::fromJson(R"({"effects": {"scattering": {"order": "triple"}}})"), UsageError);
    EXPECT_THROW(Scene::fromJson(R"({"effects": {"scattering": {"order": "multiple", "samples": 0}}})"),
                 UsageError);
    EXPECT_THROW(Scene::fromJson(R"({"effects": {"scattering": {"samples": 2.5}}})"), UsageError);
    EXPECT_THROW(Scene::fromJson(R"({"effects": {"scattering": {"environment": [1, -1, 0]}}})").validate(),
                 UsageError);
    const Scene ok = Scene::fromJson(
        R"({"effects": {"scattering": {"order": "multiple", "samples": 32, "seed": 5, "bounces": 8, "albedo": 0.9,
            "environment": [0.1, 0.2, 0.3], "emission": false}}})");
    EXPECT_EQ(ok.effects.scatteringOrder, ScatteringOrder::Multiple);
    EXPECT_EQ(ok.effects.samples, 32);
    const Scene back = Scene::fromJson(ok.toJson());
    EXPECT_EQ(back.effects.seed, 5u);
    EXPECT_EQ(back.effects.maxBounces, 8);
    EXPECT_FALSE(back.effects.emission);
}

// Renderers without a path tracer (the shared planner's default) fall back to single scattering and say so.
TEST(PathTrace, PlannerFallsBackWithoutAPathTracer) {
    Scene s = multipleScene({9, 9, 9}, 4);
    s.lights = {Light{LightKind::Directional, {0, 0, -1}, {1, 1, 1}, 1.0}};
    const WorldBox box{{0, 0, 0}, {8, 8, 8}};
    const EffectPlan other = planEffects(s, box, {0.0, 1.0}, "cells");
    EXPECT_FALSE(other.pathTracing);
    EXPECT_TRUE(other.scattering);
    EXPECT_NE(other.explain().find("no path tracer"), std::string::npos) << other.explain();
    const EffectPlan grid = planEffects(s, box, {0.0, 1.0}, "cells", true);
    EXPECT_TRUE(grid.pathTracing);
    EXPECT_NE(grid.defines.toOptions().find("-DPATH_TRACE"), std::string::npos);
    EXPECT_EQ(grid.defines.toOptions().find("-DSCATTERING"), std::string::npos);
}

TEST(Cloud, SeededReproducibleAnySize) {
    CloudParams p;
    p.dims = {40, 30, 12};
    const Volume a = generateCloud(p, 1), b = generateCloud(p, 3);
    EXPECT_EQ(a.type(), ScalarType::UInt8);
    ASSERT_EQ(a.byteSize(), b.byteSize());
    EXPECT_TRUE(
        std::equal(a.bytes().begin(), a.bytes().end(), b.bytes().begin())); // thread count is irrelevant
    p.seed = 2;
    const Volume c = generateCloud(p);
    EXPECT_FALSE(std::equal(a.bytes().begin(), a.bytes().end(), c.bytes().begin()));
    // Some cloud, some clear sky, nothing at the very top.
    std::size_t filled = 0;
    for (auto x : a.values<std::uint8_t>())
        filled += x > 0;
    EXPECT_GT(filled, a.voxelCount() / 50);
    EXPECT_LT(filled, a.voxelCount() * 9 / 10);
    for (std::size_t j = 0; j < p.dims.y; ++j)
        for (std::size_t i = 0; i < p.dims.x; ++i)
            ASSERT_EQ(a.values<std::uint8_t>()[a.index(i, j, p.dims.z - 1)], 0);
    for (Dims d : {Dims{1, 1, 1}, Dims{1, 7, 1}, Dims{3, 1, 2}})
        EXPECT_EQ(generateCloud(CloudParams{d}).voxelCount(), d.count());
    EXPECT_EQ(roettgerCloudPreset().dims, (Dims{513, 513, 65}));
    p.coverage = 0.0;
    EXPECT_THROW(generateCloud(p), UsageError);
    p.coverage = 0.5;
    p.frequency = std::numeric_limits<double>::quiet_NaN();
    EXPECT_THROW(generateCloud(p), UsageError);
}

// The smoke simulation's VDB renders with multiple scattering; the kernel agrees with the reference.
TEST(PathTrace, SmokeVdbRenders) {
    std::filesystem::path data;
    VOLCL_REQUIRE_SHARED_DATA(data);
    const Volume v = readVolume(data / "vdb" / "smoke.vdb");
    ASSERT_EQ(v.dims(), (Dims{128, 64, 64}));
    double hi = 0.0;
    for (float x : v.toFloat())
        hi = std::max(hi, double(x));
    ASSERT_GT(hi, 0.0);
    TransferFunction tf = rampTf(1.0);
    tf.domain = {0.0, hi};
    tf.extinction = {{0.0, 0.0}, {hi, 0.5}};
    Scene s = multipleScene(v.dims(), 8);
    s.width = 24;
    s.height = 12;
    s.camera->height = 64.0;
    s.effects.albedo = 0.9;
    s.effects.phaseG = 0.5;
    s.effects.emission = false;
    s.effects.environment = {0.2, 0.2, 0.3};
    s.lights = {Light{LightKind::Directional, {0.3, 0.8, -0.5}, {1, 1, 1}, 2.0}};
    GridRenderer r(computeContext(), v, tf, s);
    const ImageBuffer img = r.render();
    expectFinite(img);
    const ImageBuffer ref = pathTraceReference(v, tf, s);
    double coverage = 0.0;
    for (int c = 0; c < 4; ++c) {
        const MeanDiff d = meanDiff(img, c, ref, c);
        EXPECT_LT(std::abs(d.mean), 4.0 * d.se + 1e-3) << "channel " << c;
    }
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x)
            coverage += img.at(x, y, 3);
    EXPECT_GT(coverage, 0.5); // some smoke in view
}

TEST(Cloud, GeneratedCloudRendersWithMultipleScattering) {
    CloudParams p;
    p.dims = {48, 48, 16};
    const Volume v = generateCloud(p);
    TransferFunction tf;
    tf.domain = {0.0, 255.0};
    tf.color = {{0.0, {1, 1, 1}}};
    tf.extinction = {{0.0, 0.0}, {255.0, 0.6}};
    Scene s = multipleScene(v.dims(), 4);
    s.camera->eye = {23.5, -60.0, 40.0};
    s.camera->up = {0, 0, 1};
    s.camera->height = 60.0;
    s.effects.albedo = 0.95;
    s.effects.emission = false;
    s.effects.environment = {0.2, 0.25, 0.35};
    s.lights = {Light{LightKind::Directional, {0.2, -0.3, 0.9}, {1, 1, 1}, 2.0}};
    const ImageBuffer img = GridRenderer(computeContext(), v, tf, s).render();
    expectFinite(img);
    double rgb = 0.0;
    for (float x : img.pixels)
        rgb += x;
    EXPECT_GT(rgb, 0.1);
}

} // namespace
