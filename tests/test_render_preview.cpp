// Preview tiers (shear-warp, discrete ray casting): kernels against their C++ references, both against the
// double ray-march reference (fine-step oracle) on analytic scenes, and the hard cases.
#include "TestUtil.hpp"

#include "core/Error.hpp"
#include "core/Volume.hpp"
#include "host/io/VolumeIo.hpp"
#include "render/RenderInput.hpp"
#include "render/grid/GridRenderer.hpp"
#include "render/grid/PreviewRenderer.hpp"
#include "render/grid/PreviewTiers.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

namespace volcl {
namespace {

using test::computeContext;
using test::makeFloatVolume;
using test::maxAbsDiff;

/// Extinction rising from 0 at s = 0 to tau at s = 8, colour from blue to orange over the same values.
TransferFunction rampTf(double tau) {
    TransferFunction tf;
    tf.domain = {-40.0, 40.0};
    tf.color = {{0.0, {0.2, 0.3, 1.0}}, {8.0, {1.0, 0.6, 0.1}}};
    tf.extinction = {{-40.0, 0.0}, {0.0, 0.0}, {8.0, tau}};
    return tf;
}

/// A sphere of radius r about the box centre: s = r - distance (positive inside), in voxel units.
Volume sphereVolume(Dims n, double r) {
    const double cx = double(n.x - 1) / 2, cy = double(n.y - 1) / 2, cz = double(n.z - 1) / 2;
    return makeFloatVolume(n, [=](double x, double y, double z) {
        return r - std::sqrt((x - cx) * (x - cx) + (y - cy) * (y - cy) + (z - cz) * (z - cz));
    });
}

/// A slab at 45 degrees to x and z: s = 6 - |x - z| / sqrt(2) (positive within 6 voxels of the plane x = z).
Volume slabVolume(Dims n) {
    return makeFloatVolume(n,
                           [](double x, double, double z) { return 6.0 - std::abs(x - z) / std::sqrt(2.0); });
}

/// Orthographic (or perspective) camera looking along `dir` at the centre of `v`'s box, showing all of it.
Scene sceneLooking(const Volume& v, Vec3 dir, int size = 24,
                   Projection projection = Projection::Orthographic) {
    const WorldBox box = gridBounds(v);
    const Vec3 centre{box.origin[0] + box.extent[0] / 2, box.origin[1] + box.extent[1] / 2,
                      box.origin[2] + box.extent[2] / 2};
    const double diagonal = std::sqrt(box.extent[0] * box.extent[0] + box.extent[1] * box.extent[1] +
                                      box.extent[2] * box.extent[2]);
    const double len = std::sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
    Scene s;
    Camera c;
    c.projection = projection;
    c.target = centre;
    for (int i = 0; i < 3; ++i)
        c.eye[std::size_t(i)] =
            centre[std::size_t(i)] - dir[std::size_t(i)] / len * 3.0 * std::max(diagonal, 1.0);
    c.up = std::abs(dir[1]) > 0.9 * len ? Vec3{0, 0, 1} : Vec3{0, 1, 0};
    c.height = 1.05 * std::max(diagonal, 1.0);
    c.fovYDeg = 2.0 * std::atan(0.55 / 3.0) * 180.0 / M_PI + 1.0; // the box from 3 diagonals away
    s.camera = c;
    s.width = size;
    s.height = size;
    s.earlyTermination = 1.0;
    return s;
}

void expectFiniteBounded(const ImageBuffer& img, const std::string& what) {
    for (float v : img.pixels) {
        ASSERT_TRUE(std::isfinite(v)) << what;
        ASSERT_GE(v, -1e-6f) << what;
        ASSERT_LE(v, 1.0f + 1e-5f) << what;
    }
}

ImageBuffer renderTier(const Volume& v, const TransferFunction& tf, Scene s, GridMethod m) {
    s.gridMethod = m;
    GridPreviewRenderer r(computeContext(), v, tf, s);
    return r.render();
}

ImageBuffer cppReference(const Volume& v, const TransferFunction& tf, const Scene& s, GridMethod m) {
    return m == GridMethod::ShearWarp ? preview::shearWarpReference(v, tf, s)
                                      : preview::discreteRayCastReference(v, tf, s);
}

const std::vector<Vec3> kViews = {
    {0, 0, 1},     {0, 0, -1},    {1, 0, 0},        {0, -1, 0},       // along an axis (no shear)
    {1, 1, 1},     {-1, 1, -1},   {1, 1, 0},        {0.3, -0.5, 0.8}, // exactly diagonal: principal axes tie
    {1, 0.999, 1}, {1, 1.001, 1}, {-0.7, 0.2, 0.4},                   // either side of the diagonal, oblique
};

TEST(PreviewTiers, KernelsMatchTheirCppReferences) {
    const Volume sphere = sphereVolume({21, 18, 15}, 6.5);
    const TransferFunction tf = rampTf(0.4);
    for (GridMethod m : {GridMethod::ShearWarp, GridMethod::Drc})
        for (const Vec3& dir : kViews) {
            Scene s = sceneLooking(sphere, dir);
            s.earlyTermination = 0.95; // early termination (opaque pixel links) must not change the image
            const std::string what = std::string(gridMethodName(m)) + " view " + std::to_string(dir[0]) +
                                     "," + std::to_string(dir[1]) + "," + std::to_string(dir[2]);
            const ImageBuffer kernel = renderTier(sphere, tf, s, m);
            expectFiniteBounded(kernel, what);
            EXPECT_LE(maxAbsDiff(kernel, cppReference(sphere, tf, s, m)), 2e-3) << what;
        }
}

TEST(PreviewTiers, AnalyticScenesWithinTheirErrorOfTheFineStepOracle) {
    // The oracle: the double-precision ray integral at a 0.05-voxel step with the exact TF (no shear, no
    // voxel walk). Shear-warp samples bilinearly in slices one voxel apart; DRC takes the nearest voxel.
    // Bounds: about twice the RMSE measured when these tests were written (docs/rendering.md, "Preview tiers").
    struct Case {
        const char* name;
        Volume volume;
        double shearWarpRmse, drcRmse;
    };
    const std::vector<Case> cases = {
        {"sphere", sphereVolume({25, 25, 25}, 9.0), 0.02, 0.04},
        {"slab at 45 degrees", slabVolume({25, 25, 25}), 0.02, 0.04},
    };
    const TransferFunction tf = rampTf(0.25);
    for (const Case& c : cases)
        for (const Vec3& dir : {Vec3{0, 0, 1}, Vec3{1, 1, 1}, Vec3{0.3, -0.5, 0.8}, Vec3{1, 0, 1}}) {
            const Scene s = sceneLooking(c.volume, dir, 32);
            const ImageBuffer oracle = referenceRender(c.volume, tf, s, {.step = 0.05});
            const std::string what =
                std::string(c.name) + " view " + std::to_string(dir[0]) + "," + std::to_string(dir[1]);
            EXPECT_LE(imageRmse(renderTier(c.volume, tf, s, GridMethod::ShearWarp), oracle), c.shearWarpRmse)
                << what;
            EXPECT_LE(imageRmse(renderTier(c.volume, tf, s, GridMethod::Drc), oracle), c.drcRmse) << what;
        }
}

TEST(PreviewTiers, AxisSwitchAtTheDiagonalIsContinuous) {
    // Either side of the diagonal the principal axis differs; the images must not jump.
    const Volume sphere = sphereVolume({23, 23, 23}, 8.0);
    const TransferFunction tf = rampTf(0.3);
    const ImageBuffer a =
        renderTier(sphere, tf, sceneLooking(sphere, {1, 1, 0.999}, 32), GridMethod::ShearWarp);
    const ImageBuffer b =
        renderTier(sphere, tf, sceneLooking(sphere, {1, 1, 1.001}, 32), GridMethod::ShearWarp);
    const ImageBuffer d = renderTier(sphere, tf, sceneLooking(sphere, {1, 1, 1}, 32), GridMethod::ShearWarp);
    EXPECT_LE(imageRmse(a, b), 0.01);
    EXPECT_LE(imageRmse(a, d), 0.01);
}

TEST(PreviewTiers, DegenerateSizesAreFiniteAndMatchTheOracle) {
    const TransferFunction tf = rampTf(0.5);
    for (const Dims n :
         {Dims{1, 1, 1}, Dims{1, 6, 5}, Dims{6, 1, 5}, Dims{6, 5, 1}, Dims{2, 2, 2}, Dims{2, 7, 3}})
        for (const Vec3& dir : {Vec3{0, 0, 1}, Vec3{1, 1, 1}, Vec3{1, 0, 0}}) {
            const Volume v =
                makeFloatVolume(n, [](double x, double y, double z) { return 4.0 + x - y + 0.5 * z; });
            const Scene s = sceneLooking(v, dir, 9);
            const ImageBuffer oracle = referenceRender(v, tf, s, {.step = 0.02});
            const bool flat = n.x == 1 || n.y == 1 || n.z == 1;
            for (GridMethod m : {GridMethod::ShearWarp, GridMethod::Drc}) {
                const std::string what = std::string(gridMethodName(m)) + " " + std::to_string(n.x) + "x" +
                                         std::to_string(n.y) + "x" + std::to_string(n.z) + " view " +
                                         std::to_string(dir[0]) + "," + std::to_string(dir[1]) + "," +
                                         std::to_string(dir[2]);
                const ImageBuffer img = renderTier(v, tf, s, m);
                expectFiniteBounded(img, what);
                EXPECT_LE(maxAbsDiff(img, cppReference(v, tf, s, m)), 2e-3) << what;
                if (m == GridMethod::ShearWarp && flat) {
                    // A grid one voxel thick has no area in its slices: shear-warp shows nothing. (The ray
                    // marcher shows it only to rays lying exactly in its plane.)
                    for (float p : img.pixels)
                        ASSERT_EQ(p, 0.0f) << what;
                    continue;
                }
                // The intermediate image has one pixel per voxel: the box's edges blur over a voxel, which on a
                // 2-voxel grid is all of it, but its centre pixel stays close. DRC holds each voxel's value over
                // half a voxel either side: on such grids that is the whole error.
                EXPECT_LE(imageRmse(img, oracle), m == GridMethod::ShearWarp ? 0.12 : 0.06) << what;
                if (!flat && m == GridMethod::ShearWarp)
                    EXPECT_NEAR(img.at(4, 4, 3), oracle.at(4, 4, 3), 0.01) << what;
            }
        }
}

TEST(PreviewTiers, AnisotropicSpacingFollowsTheWorldBox) {
    Volume v = sphereVolume({25, 13, 49}, 9.0);
    // Voxel coordinates of a sphere stretched to an ellipsoid; with spacing (1, 2, 0.5) it is round in world.
    v = makeFloatVolume({25, 13, 49}, [](double x, double y, double z) {
        const double dx = x - 12, dy = (y - 6) * 2.0, dz = (z - 24) * 0.5;
        return 9.0 - std::sqrt(dx * dx + dy * dy + dz * dz);
    });
    v.spacing = {1.0, 2.0, 0.5};
    v.origin = {3.0, -2.0, 10.0};
    const TransferFunction tf = rampTf(0.25);
    for (const Vec3& dir : {Vec3{0, 0, 1}, Vec3{0, 1, 0}, Vec3{1, 1, 1}, Vec3{-0.2, 0.9, 0.3}}) {
        const Scene s = sceneLooking(v, dir, 32);
        const ImageBuffer oracle = referenceRender(v, tf, s, {.step = 0.05});
        for (GridMethod m : {GridMethod::ShearWarp, GridMethod::Drc}) {
            const ImageBuffer img = renderTier(v, tf, s, m);
            EXPECT_LE(maxAbsDiff(img, cppReference(v, tf, s, m)), 2e-3) << gridMethodName(m);
            EXPECT_LE(imageRmse(img, oracle), 0.04)
                << gridMethodName(m) << " view " << dir[0] << "," << dir[1];
        }
    }
}

TEST(PreviewTiers, EmptyTfDrawsNothingAndFullyOpaqueShowsTheFrontValue) {
    const Volume sphere = sphereVolume({19, 19, 19}, 7.0);
    TransferFunction empty = rampTf(0.0);
    empty.extinction = {{-40.0, 0.0}};
    TransferFunction opaque = rampTf(0.0);
    opaque.extinction = {{-40.0, 0.0}, {0.0, 0.0}, {0.001, 1e4}}; // opaque from the surface inward
    for (GridMethod m : {GridMethod::ShearWarp, GridMethod::Drc})
        for (const Vec3& dir : {Vec3{0, 0, 1}, Vec3{1, 1, 1}}) {
            Scene s = sceneLooking(sphere, dir, 16);
            const ImageBuffer none = renderTier(sphere, empty, s, m);
            for (float v : none.pixels)
                ASSERT_EQ(v, 0.0f) << gridMethodName(m);
            s.earlyTermination = 0.995;
            const ImageBuffer img = renderTier(sphere, opaque, s, m);
            expectFiniteBounded(img, std::string(gridMethodName(m)) + " opaque");
            // The centre pixel looks into the sphere: opaque, with the colour near the surface (s just above 0).
            EXPECT_GE(img.at(8, 8, 3), 0.99f) << gridMethodName(m);
            EXPECT_LE(maxAbsDiff(img, cppReference(sphere, opaque, s, m)), 2e-3) << gridMethodName(m);
        }
}

TEST(PreviewTiers, PerspectiveIsRefusedByShearWarpAndDrawnByDrc) {
    const Volume sphere = sphereVolume({21, 21, 21}, 8.0);
    const TransferFunction tf = rampTf(0.3);
    Scene s = sceneLooking(sphere, {0.2, 0.3, 1}, 24, Projection::Perspective);
    s.gridMethod = GridMethod::ShearWarp;
    EXPECT_THROW(GridPreviewRenderer(computeContext(), sphere, tf, s), UsageError);
    const ImageBuffer drc = renderTier(sphere, tf, s, GridMethod::Drc);
    EXPECT_LE(maxAbsDiff(drc, cppReference(sphere, tf, s, GridMethod::Drc)), 2e-3);
    EXPECT_LE(imageRmse(drc, referenceRender(sphere, tf, s, {.step = 0.05})), 0.04);
}

TEST(PreviewTiers, RefusesWhatTheyCannotDrawWithOneLine) {
    const Volume sphere = sphereVolume({9, 9, 9}, 3.0);
    const TransferFunction tf = rampTf(0.3);
    const Scene base = sceneLooking(sphere, {0, 0, 1}, 8);
    const std::vector<std::function<void(Scene&)>> refused = {
        [](Scene& s) { s.mode = RenderMode::Mip; },
        [](Scene& s) { s.effects.shading = true; },
        [](Scene& s) {
            s.effects.isosurfaces = {{1.0, {1, 1, 1, 1}}};
        },
        [](Scene& s) {
            s.effects.clipPlanes = {{{1, 0, 0}, -4.0}};
        },
        [](Scene& s) { s.preintegration = Preintegration::Table2d; },
        [](Scene& s) { s.filter = ReconstructionFilter::Cubic; },
    };
    for (GridMethod m : {GridMethod::ShearWarp, GridMethod::Drc})
        for (const auto& change : refused) {
            Scene s = base;
            s.gridMethod = m;
            change(s);
            try {
                GridPreviewRenderer r(computeContext(), sphere, tf, s);
                ADD_FAILURE() << gridMethodName(m) << " accepted a scene it cannot draw";
            } catch (const UsageError& e) {
                const std::string msg = e.what();
                EXPECT_NE(msg.find("render.method"), std::string::npos) << msg;
                EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
            }
        }
    Volume nan = sphere;
    nan.values<float>()[40] = std::numeric_limits<float>::quiet_NaN();
    Scene s = base;
    s.gridMethod = GridMethod::ShearWarp;
    EXPECT_THROW(GridPreviewRenderer(computeContext(), nan, tf, s), DataError);
    // The factory routes render.method to the tier, and refuses it for inputs that are not grids.
    const RenderInput in = RenderInput::borrow(sphere);
    EXPECT_NE(dynamic_cast<GridPreviewRenderer*>(in.makeRenderer(computeContext(), tf, s).get()), nullptr);
    // render.method parses both families and names the field on a typo.
    Scene parsed = Scene::fromJson(R"({"render": {"method": "drc"}})");
    EXPECT_EQ(parsed.gridMethod, GridMethod::Drc);
    EXPECT_THROW(Scene::fromJson(R"({"render": {"method": "shearwarp"}})"), UsageError);
    EXPECT_EQ(Scene::fromJson(parsed.toJson()).gridMethod, GridMethod::Drc);
}

TEST(PreviewTiers, TfChangeRebuildsTheRunsAndViewsReuseThem) {
    const Volume sphere = sphereVolume({21, 19, 17}, 7.0);
    Scene s = sceneLooking(sphere, {0.2, 0.1, 1}, 16);
    s.gridMethod = GridMethod::ShearWarp;
    GridPreviewRenderer r(computeContext(), sphere, rampTf(0.3), s);
    r.render();
    const std::string before = r.statistics();
    TransferFunction narrow = rampTf(0.3);
    narrow.extinction = {{-40.0, 0.0}, {4.0, 0.0}, {8.0, 0.6}}; // only the core: fewer visible cells
    r.setTransferFunction(narrow);
    const ImageBuffer changed = r.render();
    EXPECT_NE(r.statistics(), before);
    EXPECT_LE(maxAbsDiff(changed, preview::shearWarpReference(sphere, narrow, s)), 2e-3);
    // A new view along another principal axis builds that axis's runs; the first axis's stay.
    const Scene side = sceneLooking(sphere, {1, 0.1, 0.2}, 16);
    r.setView(*side.camera, 16, 16, s.step);
    Scene sideScene = side;
    sideScene.gridMethod = GridMethod::ShearWarp;
    EXPECT_LE(maxAbsDiff(r.render(), preview::shearWarpReference(sphere, narrow, sideScene)), 2e-3);
    EXPECT_NE(r.statistics().find("principal axis x"), std::string::npos) << r.statistics();
}

TEST(PreviewTiers, MriTiersAreCloseToTheRayMarcher) {
    std::filesystem::path data;
    VOLCL_REQUIRE_SHARED_DATA(data);
    const Volume v = test::brainWebMri(data);
    // The smooth MRI transfer function of the rendering benchmarks (bench/render/mri_tf.json).
    TransferFunction tf;
    tf.domain = {0, 255};
    tf.color = {{0, {0.2, 0.3, 0.9}},
                {70, {0.9, 0.5, 0.3}},
                {110, {0.95, 0.8, 0.6}},
                {160, {1.0, 0.95, 0.85}},
                {255, {1, 1, 1}}};
    tf.extinction = {{0, 0.0}, {40, 0.0}, {70, 0.004}, {110, 0.015}, {160, 0.04}, {255, 0.08}};
    Scene s = sceneLooking(v, {0.3, -0.2, 1}, 96);
    s.earlyTermination = 0.995;
    const ImageBuffer marched = GridRenderer(computeContext(), v, tf, s).render();
    for (GridMethod m : {GridMethod::ShearWarp, GridMethod::Drc}) {
        const ImageBuffer img = renderTier(v, tf, s, m);
        expectFiniteBounded(img, std::string(gridMethodName(m)));
        EXPECT_LE(imageRmse(img, marched), 0.03) << gridMethodName(m);
    }
}

} // namespace
} // namespace volcl
