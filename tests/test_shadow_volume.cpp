// Shadows from light-attenuation volumes: the sweep kernel against its C++ reference, the volume against a
// closed-form shadow, rendered shadows against the exact secondary-ray reference on hard cases and the MRI,
// and when a volume is rebuilt.
#include "ShadowTestUtil.hpp"
#include "TestUtil.hpp"

#include "core/Error.hpp"
#include "core/Volume.hpp"
#include "host/io/VolumeIo.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/Scene.hpp"
#include "render/grid/GridDetail.hpp"
#include "render/grid/GridRenderer.hpp"
#include "render/grid/LightVolume.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>

namespace {

using namespace volcl;
using volcl::test::computeContext;
using volcl::test::makeFloatVolume;
using volcl::test::orthoScene;

/// Extinction 0 below value 0.1, rising to `tau` at 1; colour warm to cold.
TransferFunction rampTf(double tau) {
    TransferFunction tf;
    tf.domain = {0.0, 1.0};
    tf.color = {{0.0, {1.0, 0.8, 0.6}}, {1.0, {0.6, 0.8, 1.0}}};
    tf.extinction = {{0.0, 0.0}, {0.1, 0.0}, {1.0, tau}};
    return tf;
}

/// A ball of radius R (value 1, a one-voxel linear rim centred on the sphere) at c, over a slab (value 0.4)
/// of voxels z in [z0, z1] (a floor the shadow falls on).
Volume sphereOverSlab(Dims n, Vec3 c, double R, double z0, double z1) {
    return makeFloatVolume(n, [=](double x, double y, double z) {
        const double r =
            std::sqrt((x - c[0]) * (x - c[0]) + (y - c[1]) * (y - c[1]) + (z - c[2]) * (z - c[2]));
        const double ball = std::clamp(R - r + 0.5, 0.0, 1.0);
        const double slab = z >= z0 && z <= z1 ? 0.4 : 0.0;
        return std::max(ball, slab);
    });
}

/// The light volumes (optical depth) of `lights` on `v` built by the kernel, downloaded.
std::vector<float> deviceLightVolume(const Volume& v, const TransferFunction& tf,
                                     std::vector<SweptLight> lights, int cell, double step) {
    ComputeContext& cc = computeContext();
    std::vector<float> voxels = v.toFloat();
    voxels.push_back(0.0f); // the spare voxel grid_sample.h reads
    const DeviceBuffer<float> vol = cc.upload(voxels, CL_MEM_READ_ONLY);
    const std::vector<VolclTfKnot> knots = tf.packKnots();
    const DeviceBuffer<VolclTfKnot> kn = cc.upload(knots, CL_MEM_READ_ONLY);
    LightVolume lv;
    LightVolume::Inputs in;
    in.voxels = &vol.get();
    in.knots = &kn.get();
    in.knotCount = knots.size();
    in.defines.set("VOXEL_TYPE", 0LL);
    in.grid = grid_detail::gridParams(v, grid_detail::buildMacrocells(v, 8));
    in.lights = std::move(lights);
    in.cell = cell;
    in.step = step;
    EXPECT_TRUE(lv.update(cc, in));
    EXPECT_FALSE(lv.update(cc, in)) << "the same inputs keep the volume";
    return cc.download(lv.buffer(cc));
}

std::vector<double> hostLightVolume(const Volume& v, const TransferFunction& tf,
                                    const std::vector<SweptLight>& lights, int cell, double step) {
    return lightVolumeReference(v.toFloat(), grid_detail::gridParams(v, grid_detail::buildMacrocells(v, 8)),
                                tf, lights, cell, step);
}

double maxDiff(const std::vector<float>& a, const std::vector<double>& b) {
    EXPECT_EQ(a.size(), b.size());
    double m = 0.0;
    for (std::size_t i = 0; i < std::min(a.size(), b.size()); ++i)
        m = std::max(m, std::abs(double(a[i]) - b[i]));
    return m;
}

void expectFiniteBounded(const ImageBuffer& img) {
    for (float v : img.pixels) {
        ASSERT_TRUE(std::isfinite(v));
        ASSERT_GE(v, -1e-6f);
        ASSERT_LE(v, 1.0f + 1e-5f);
    }
}

/// A lit, shadowed scene of `n` seen along -z (orthographic), 32x32.
Scene shadowScene(Dims n, std::vector<Light> lights, ShadowMethod method, int cell = 1) {
    Scene s = orthoScene(n, double(std::max({n.x, n.y, n.z})) + 2.0, 32, 32);
    s.step = 0.25;
    s.lights = std::move(lights);
    s.effects.shading = s.effects.shadingGiven = true;
    s.effects.shadows = true;
    s.effects.shadowStep = 0.25;
    s.effects.shadowMethod = method;
    s.effects.lightVolumeCell = cell;
    return s;
}

/// RMSE of the volume method against the exact secondary-ray reference (double), and of the ray kernel.
struct ShadowErrors {
    double volume, rays;
};
ShadowErrors shadowErrors(const Volume& v, const TransferFunction& tf, const Scene& s) {
    GridRenderer r(computeContext(), v, tf, s);
    EXPECT_TRUE(r.plan().shadowVolume);
    const ImageBuffer vol = r.render();
    expectFiniteBounded(vol);
    Scene rays = s;
    rays.effects.shadowMethod = ShadowMethod::Rays;
    r.setScene(rays);
    EXPECT_FALSE(r.plan().shadowVolume);
    const ImageBuffer ray = r.render();
    const ImageBuffer ref = referenceRender(v, tf, s, {.step = 0.125});
    return {imageRmse(vol, ref), imageRmse(ray, ref)};
}

const Light kSun{LightKind::Directional, {0.3, 0.4, 0.87}, {1, 1, 1}, 1.0};

// The kernel and its C++ reference run the same sweeps: directional lights along an axis, along the diagonal
// and oblique, point lights inside and outside the box, full and coarse light grids, anisotropic spacing.
TEST(LightVolume, KernelMatchesItsReference) {
    Volume v = makeFloatVolume({17, 13, 11}, [](double x, double y, double z) {
        return 0.5 + 0.45 * std::sin(0.5 * x + 0.2 * y) * std::cos(0.4 * z - 0.3 * y);
    });
    v.spacing = {1.0, 0.7, 1.6};
    v.origin = {-3.0, 2.0, 1.0};
    const TransferFunction tf = rampTf(0.4);
    const std::vector<SweptLight> lights = {
        {false, {0, 0, 1}},        {false, normalized({1, 1, 1})}, {false, normalized({-0.3, 0.8, -0.5})},
        {true, {5.0, 6.0, 9.0}},   // inside the box
        {true, {30.0, -4.0, 5.0}}, // outside
    };
    for (int cell : {1, 3}) {
        SCOPED_TRACE("cell " + std::to_string(cell));
        const std::vector<float> dev = deviceLightVolume(v, tf, lights, cell, 0.3);
        const std::vector<double> host = hostLightVolume(v, tf, lights, cell, 0.3);
        // Optical depths (up to 4 here), float against double: 6e-5 at most.
        EXPECT_LT(maxDiff(dev, host), 2e-4);
        for (float depth : dev) {
            ASSERT_TRUE(std::isfinite(depth));
            ASSERT_GE(depth, 0.0f);
        }
    }
}

// The shadow of a ball in closed form: transmittance exp(-tau * chord) below it, 1 beside it. A ball of
// radius 6 lit from straight above (an axis) and from the diagonal.
TEST(LightVolume, BallShadowMatchesTheClosedForm) {
    const Dims n{33, 33, 33};
    const Vec3 c{16, 16, 22};
    const double R = 6.0, tau = 0.3;
    const Volume v = sphereOverSlab(n, c, R, -10, -10); // the ball alone
    TransferFunction tf;
    tf.domain = {0, 1};
    tf.color = {{0, {1, 1, 1}}};
    tf.extinction = {{0, 0.0}, {1, tau}}; // linear: the rim's ramp integrates to the chord
    for (const Vec3 dir : {Vec3{0, 0, 1}, normalized({1, 1, 1})}) {
        SCOPED_TRACE("light toward " + std::to_string(dir[0]) + "," + std::to_string(dir[1]) + "," +
                     std::to_string(dir[2]));
        const std::vector<float> depth = deviceLightVolume(v, tf, {{false, dir}}, 1, 0.25);
        double sum = 0.0, worst = 0.0;
        long count = 0;
        for (std::size_t k = 0; k < 8; ++k) // nodes below the ball
            for (std::size_t j = 0; j < n.y; ++j)
                for (std::size_t i = 0; i < n.x; ++i) {
                    // Chord of the ray from the node toward the light through the ball.
                    const Vec3 p{double(i), double(j), double(k)}, w = sub(p, c);
                    const double b = dot(w, dir), disc = b * b - (dot(w, w) - R * R);
                    const double chord = disc > 0.0 && -b > 0.0 ? 2.0 * std::sqrt(disc) : 0.0;
                    const double want = std::exp(-tau * chord);
                    const double e = std::abs(std::exp(-double(depth[v.index(i, j, k)])) - want);
                    // The rim: one voxel around the shadow's edge, where the voxelised ball differs.
                    if (disc > -2.0 * R && disc < 2.0 * R) continue;
                    sum += e * e;
                    worst = std::max(worst, e);
                    ++count;
                }
        EXPECT_GT(count, 1000);
        EXPECT_LT(std::sqrt(sum / double(count)), 5e-3);
        EXPECT_LT(worst, 0.03);
    }
}

// Rendered: a ball casting a shadow on a slab, lit along an axis, along the diagonal and obliquely, against the
// exact reference; the ray kernel's own error is the floor.
TEST(ShadowVolume, BallOverSlabMatchesTheReference) {
    const Dims n{32, 32, 32};
    const Volume v = sphereOverSlab(n, {15.5, 15.5, 21}, 6.0, 4, 8);
    const TransferFunction tf = rampTf(0.6);
    // Measured: 3.0e-3 along the axis and the diagonal (slice lookups land on nodes), 7.8e-3 oblique (the
    // bicubic slice lookups); the ray kernel: 0.3e-3 to 1.7e-3.
    for (const auto& [dir, tolerance] :
         {std::pair{Vec3{0, 0, 1}, 4e-3}, std::pair{normalized({1, 1, 1}), 4e-3},
          std::pair{Vec3{0.3, 0.4, 0.87}, 1e-2}}) {
        SCOPED_TRACE(std::to_string(dir[0]) + "," + std::to_string(dir[1]) + "," + std::to_string(dir[2]));
        Scene s = shadowScene(n, {{LightKind::Directional, dir, {1, 1, 1}, 1.0}}, ShadowMethod::Volume);
        s.camera->eye = {15.5, -40, 60}; // from above and the side: the slab and the shadow show
        s.camera->target = {15.5, 15.5, 10};
        s.camera->up = {0, 0, 1};
        s.camera->height = 50;
        const ShadowErrors e = shadowErrors(v, tf, s);
        EXPECT_LT(e.volume, tolerance);
        EXPECT_LT(e.rays, 2e-3);
    }
}

// Hard cases, each against the exact reference: a one-voxel-thick sheet over a slab (its shadow must not be
// lost between slices), a constant volume (no gradient anywhere), anisotropic spacing, a point light inside
// the volume, and a coarse light grid. Measured RMSE: sheet 4.8e-3 (axis) and 5.5e-3 (diagonal), constant
// 3.8e-3, anisotropic 9.3e-3, point light 4e-3, 4-voxel cells 4.2e-2 (a radius-5 ball on 4-voxel cells).
TEST(ShadowVolume, HardCasesMatchTheReference) {
    const Dims n{24, 24, 24};
    const TransferFunction tf = rampTf(1.0);
    struct Case {
        std::string name;
        Volume v;
        std::vector<Light> lights;
        int cell;
        double tolerance;
    };
    std::vector<Case> cases;
    cases.push_back(
        {"one-voxel sheet over a slab, light along z",
         makeFloatVolume(n,
                         [](double x, double, double z) {
                             return z == 16.0 && x < 14.0 ? 1.0 : z >= 3.0 && z <= 6.0 ? 0.3 : 0.0;
                         }),
         {{LightKind::Directional, {0, 0, 1}, {1, 1, 1}, 1.0}},
         1,
         6e-3});
    cases.push_back(
        {"one-voxel sheet, diagonal light",
         makeFloatVolume(n,
                         [](double x, double, double z) {
                             return z == 16.0 && x < 14.0 ? 1.0 : z >= 3.0 && z <= 6.0 ? 0.3 : 0.0;
                         }),
         {{LightKind::Directional, normalized({1, 1, 1}), {1, 1, 1}, 1.0}},
         1,
         7e-3});
    cases.push_back({"constant volume (flat: no gradient)",
                     makeFloatVolume(n, [](double, double, double) { return 0.3; }),
                     {kSun},
                     1,
                     5e-3});
    Volume aniso = sphereOverSlab(n, {11.5, 11.5, 15}, 5.0, 3, 6);
    aniso.spacing = {1.0, 0.6, 1.7};
    cases.push_back({"anisotropic spacing", std::move(aniso), {kSun}, 1, 1.2e-2});
    cases.push_back({"point light inside the volume",
                     sphereOverSlab(n, {8, 12, 14}, 4.0, 3, 6),
                     {{LightKind::Point, {14, 12, 16}, {1, 1, 1}, 1.0}},
                     1,
                     5e-3});
    cases.push_back({"coarse light grid (4-voxel cells)",
                     sphereOverSlab(n, {11.5, 11.5, 15}, 5.0, 3, 6),
                     {kSun},
                     4,
                     5e-2});
    for (Case& c : cases) {
        SCOPED_TRACE(c.name);
        Scene s = shadowScene(n, c.lights, ShadowMethod::Volume, c.cell);
        s.camera->eye = {11.5, -30, 50};
        s.camera->target = {11.5, 11.5, 8};
        s.camera->up = {0, 0, 1};
        s.camera->height = 40;
        Volume& v = c.v;
        if (v.spacing[1] != 1.0) { // world coordinates follow the spacing
            s.camera->eye = {11.5, -20, 60};
            s.camera->target = {11.5, 7, 12};
        }
        const ShadowErrors e = shadowErrors(v, tf, s);
        EXPECT_LT(e.volume, c.tolerance) << "rays: " << e.rays;
    }
}

// A camera move alone keeps a directional light's volume; a head light keeps it while it turns less than the
// tolerance; a new TF, light or cell rebuilds it.
TEST(ShadowVolume, RebuiltOnlyWhenTheLightTfOrFieldChanges) {
    const Dims n{16, 16, 16};
    const Volume v = sphereOverSlab(n, {7.5, 7.5, 10}, 4.0, 2, 4);
    const TransferFunction tf = rampTf(0.8);
    Scene s = shadowScene(n, {kSun}, ShadowMethod::Volume);
    GridRenderer r(computeContext(), v, tf, s);
    test::expectCameraMoveKeepsAndTfRebuilds(r, s, rampTf(0.5));
    Scene coarse = s;
    coarse.effects.lightVolumeCell = 2;
    r.setScene(coarse);
    r.render();
    EXPECT_EQ(r.lightVolumeBuilds(), 3) << "a new cell";
    EXPECT_NE(r.statistics().find("light volumes: 3 built"), std::string::npos) << r.statistics();

    test::expectHeadLightTolerance(
        s, [&](const Scene& head) { return std::make_unique<GridRenderer>(computeContext(), v, tf, head); });
}

// The scene keys, their refusals and what the grid planner compiles for rays and volume (bricks:
// ShadowVolumeBricks.PlanStatesLevelAndMemoryBound).
TEST(ShadowVolume, SceneKeysAndPlans) {
    Scene s = Scene::fromJson(R"({"volume": "v.nrrd", "effects": {"shadows": true, "shadow_method": "rays",
        "light_volume_cell": 3, "shadow_head_tolerance": 5}})",
                              ".");
    EXPECT_EQ(s.effects.shadowMethod, ShadowMethod::Rays);
    EXPECT_EQ(s.effects.lightVolumeCell, 3);
    EXPECT_EQ(s.effects.headLightToleranceDeg, 5.0);
    const Scene back = Scene::fromJson(s.toJson(), ".");
    EXPECT_EQ(back.effects.shadowMethod, ShadowMethod::Rays);
    EXPECT_EQ(back.effects.lightVolumeCell, 3);
    EXPECT_THROW(Scene::fromJson(R"({"volume": "v.nrrd", "effects": {"shadow_method": "maps"}})", "."),
                 UsageError);
    s.effects.lightVolumeCell = 0;
    EXPECT_THROW(s.validate(), UsageError);
    s.effects.lightVolumeCell = 65;
    EXPECT_THROW(s.validate(), UsageError);
    s.effects.lightVolumeCell = 1;
    s.effects.headLightToleranceDeg = 91;
    EXPECT_THROW(s.validate(), UsageError);
    s.effects.headLightToleranceDeg = 1;
    EXPECT_NO_THROW(s.validate());

    const Dims n{8, 8, 8};
    const Volume v = makeFloatVolume(n, [](double x, double, double) { return x / 8.0; });
    Scene lit = shadowScene(n, {kSun}, ShadowMethod::Volume, 2);
    const EffectPlan p = planEffects(lit, v, rampTf(1.0));
    EXPECT_TRUE(p.shadows && p.shadowVolume);
    EXPECT_NE(p.defines.toOptions().find("-DSHADOW_VOLUME"), std::string::npos);
    EXPECT_NE(p.explain().find("light-attenuation volume per light (2-voxel cells)"), std::string::npos)
        << p.explain();
    lit.effects.shadowMethod = ShadowMethod::Rays;
    const EffectPlan q = planEffects(lit, v, rampTf(1.0));
    EXPECT_TRUE(q.shadows && !q.shadowVolume);
    EXPECT_EQ(q.defines.toOptions().find("SHADOW_VOLUME"), std::string::npos);
}

// BrainWeb's MRI (../shared/data): the volume method against the ray kernel (the exact method, same steps),
// a directional light and a head light.
TEST(ShadowVolume, BrainWebMatchesTheRayMethod) {
    std::filesystem::path data;
    VOLCL_REQUIRE_SHARED_DATA(data);
    const auto path = data / "regular/t1_icbm_normal_1mm_pn0_rf0_180x216x180_uint8_1x1.bin-gz";
    if (!std::filesystem::exists(path)) GTEST_SKIP() << path << " is absent";
    ReadOptions o;
    o.dims = Dims{180, 216, 180};
    o.type = ScalarType::UInt8;
    const Volume v = readVolume(path, o);
    const TransferFunction tf =
        TransferFunction::fromFile(std::filesystem::path(VOLCL_SOURCE_DIR) / "bench/render/mri_tf.json");
    for (const Light& light : {kSun, Light{LightKind::Head, {0, 0, 0}, {1, 1, 1}, 1.0}}) {
        SCOPED_TRACE(light.kind == LightKind::Head ? "head light" : "directional light");
        Scene s;
        s.width = s.height = 64;
        s.step = 1.0;
        s.lights = {light};
        s.effects.shading = s.effects.shadingGiven = s.effects.shadows = true;
        s.effects.shadowStep = 1.0;
        GridRenderer r(computeContext(), v, tf, s);
        const ImageBuffer vol = r.render();
        expectFiniteBounded(vol);
        s.effects.shadowMethod = ShadowMethod::Rays;
        r.setScene(s);
        const ImageBuffer rays = r.render();
        EXPECT_LT(imageRmse(vol, rays), 5e-3);
    }
}

} // namespace
