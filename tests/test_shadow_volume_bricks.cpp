// Light-volume shadows of compressed bricks (.vcz): against the brick renderer's shadow rays and the grid
// renderer's light volume of the decoded data on hard cases, no seams at brick faces, when a volume is rebuilt,
// and the memory bound.
#include "ShadowTestUtil.hpp"
#include "TestUtil.hpp"

#include "core/Error.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/Reference.hpp"
#include "render/Scene.hpp"
#include "render/bricks/BrickField.hpp"
#include "render/bricks/BrickRenderer.hpp"
#include "render/grid/GridRenderer.hpp"
#include "wavelet/Codec.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <memory>

namespace volcl {
namespace {

using test::computeContext;
using test::makeFloatVolume;

constexpr double kTop = 250.0; // voxel values in [0, kTop]: uint8 for the lossless (integer lifting) files

/// Extinction 0 below 0.1 kTop, rising to `tau` at kTop; colour warm to cold.
TransferFunction rampTf(double tau) {
    TransferFunction tf;
    tf.domain = {0.0, kTop};
    tf.color = {{0.0, {1.0, 0.8, 0.6}}, {kTop, {0.6, 0.8, 1.0}}};
    tf.extinction = {{0.0, 0.0}, {0.1 * kTop, 0.0}, {kTop, tau}};
    return tf;
}

/// tests/test_shadow_volume.cpp's scenes, values scaled to kTop: a ball over a slab, a one-voxel sheet over one.
Volume sphereOverSlab(Dims n) {
    return makeFloatVolume(n, [](double x, double y, double z) {
        const double r = std::sqrt((x - 15.5) * (x - 15.5) + (y - 15.5) * (y - 15.5) + (z - 21) * (z - 21));
        return kTop * std::max(std::clamp(6.0 - r + 0.5, 0.0, 1.0), z >= 4 && z <= 8 ? 0.4 : 0.0);
    });
}
Volume sheetOverSlab(Dims n) {
    return makeFloatVolume(n, [](double x, double, double z) {
        return kTop * (z == 16.0 && x < 13.0 ? 1.0 : z >= 3.0 && z <= 6.0 ? 0.3 : 0.0);
    });
}

Volume toU8(const Volume& v) {
    Volume u(v.dims(), ScalarType::UInt8);
    for (std::size_t i = 0; i < v.voxelCount(); ++i)
        u.values<std::uint8_t>()[i] = std::uint8_t(std::lround(v.values<float>()[i]));
    return u;
}

/// `v` coded with `brick`^3 bricks and 2 levels: lossless (as uint8) or within 1 (0.4 % of the range).
std::shared_ptr<const VczReader> encode(const Volume& v, std::size_t brick, bool lossless) {
    CodecOptions o;
    o.brick = {brick, brick, brick};
    o.levels = 2;
    if (!lossless) {
        o.rate = RateMode::MaxError;
        o.target = 1.0;
    }
    return std::make_shared<const VczReader>(encodeVolume(computeContext(), lossless ? toU8(v) : v, o),
                                             "shadow.vcz");
}

/// Lit from `light` with shadows by `method`, seen from above and the side (the slab and the shadow show).
Scene shadowScene(Dims n, const Light& light, ShadowMethod method, int cell = 1) {
    Scene s = test::orthoScene(n, 50, 32, 32);
    s.camera->eye = {15.5, -40, 60};
    s.camera->target = {15.5, 15.5, 10};
    s.camera->up = {0, 0, 1};
    s.step = 0.25;
    s.lights = {light};
    s.effects.shading = s.effects.shadingGiven = true;
    s.effects.gradient = GradientKind::Central; // as the bricks (the grid's gradient cache is quantised)
    s.effects.shadows = true;
    s.effects.shadowStep = 0.25;
    s.effects.shadowMethod = method;
    s.effects.lightVolumeCell = cell;
    return s;
}

/// `forcedLevel` >= 0: every brick of the view drawn at that level.
ImageBuffer brickFrame(const std::shared_ptr<const VczReader>& r, const TransferFunction& tf, const Scene& s,
                       int forcedLevel = -1) {
    BrickRenderer br(computeContext(), r, 0, tf, s);
    if (forcedLevel >= 0) br.setForcedLevels(std::vector<int>(r->header().brickCount(), forcedLevel));
    EXPECT_EQ(br.plan().shadowVolume, s.effects.shadowMethod == ShadowMethod::Volume);
    return br.render();
}

ImageBuffer gridFrame(const Volume& v, const TransferFunction& tf, const Scene& s) {
    GridRenderer g(computeContext(), v, tf, s);
    EXPECT_TRUE(g.plan().shadowVolume);
    return g.render();
}

void expectFiniteBounded(const ImageBuffer& img) {
    for (float v : img.pixels) {
        ASSERT_TRUE(std::isfinite(v));
        ASSERT_GE(v, -1e-6f);
        ASSERT_LE(v, 1.0f + 1e-5f);
    }
}

const Light kSun{LightKind::Directional, {0.3, 0.4, 0.87}, {1, 1, 1}, 1.0};
const Light kInside{LightKind::Point, {22, 12, 27}, {1, 1, 1}, 1.0}; // inside the 32^3 box, above the scene

// The hard cases of tests/test_shadow_volume.cpp as .vcz files (bricks of 8 and 16, lossless and lossy), a
// directional light and a point light inside the volume. The brick light volume (one-voxel cells: every brick
// at level 0) against (a) the brick renderer's shadow rays, the exact method on the same bricks, and (b) the
// grid renderer's light volume of the decoded data: the same field and sweeps, float noise apart.
// Measured RMSE against rays: ball 7.7e-3 to 7.8e-3 (sun, oblique: the bicubic slice lookups, as on grids) and
// 3.5e-3 to 3.7e-3 (point light), sheet 2.5e-3 (sun) and 3.7e-3 (point light); against the grid: 0.
TEST(ShadowVolumeBricks, HardCasesMatchRaysAndTheGridLightVolume) {
    const Dims n{32, 32, 32};
    const TransferFunction tf = rampTf(0.6);
    for (const auto& [scene, volume] : {std::pair{"ball over slab", sphereOverSlab(n)},
                                        std::pair{"one-voxel sheet over slab", sheetOverSlab(n)}})
        for (std::size_t brick : {8u, 16u})
            for (bool lossless : {true, false}) {
                const auto reader = encode(volume, brick, lossless);
                const Volume decoded = reader->decodeFrame(computeContext(), 0);
                for (const Light& light : {kSun, kInside}) {
                    const std::string name =
                        std::string(scene) + ", brick " + std::to_string(brick) +
                        (lossless ? ", lossless" : ", lossy") +
                        (light.kind == LightKind::Point ? ", point light inside" : ", sun");
                    SCOPED_TRACE(name);
                    const Scene s = shadowScene(n, light, ShadowMethod::Volume);
                    const ImageBuffer vol = brickFrame(reader, tf, s);
                    expectFiniteBounded(vol);
                    Scene rays = s;
                    rays.effects.shadowMethod = ShadowMethod::Rays;
                    const double toRays = imageRmse(vol, brickFrame(reader, tf, rays));
                    const double toGrid = imageRmse(vol, gridFrame(decoded, tf, s));
                    std::cout << name << ": RMSE against brick rays " << toRays
                              << ", against the grid light volume " << toGrid << '\n';
                    EXPECT_LT(toRays, 1e-2);
                    EXPECT_LT(toGrid, 1e-6);
                }
            }
}

// A shadow edge crossing brick faces at coarse levels. Seen from straight above, one pixel per voxel (pixel k
// on voxel k), the sheet's shadow edge runs across the faces of 8-voxel bricks at x and y = 8, 16, 24. Cells of
// 2 and 4 voxels read the lossy bricks at levels 1 and 2. Along every row and column, the brick frame minus the
// grid frame of the decoded data (same cell) has no step at a face larger than its steps elsewhere; and the
// brick frame equals the grid frame of its own field (brickNodeValues at that level) up to float noise.
// Measured, cells 2 and 4: largest step of the difference at faces 3.1e-3 and 2.3e-3, elsewhere 2.6e-2 and
// 6.5e-2; RMSE against the brick shadow rays 9.8e-3 and 2.3e-2 (the grid's light volume: 2.1e-2, 3.5e-2),
// against the grid's light volume 1.8e-2 and 4.7e-2; against the field's own grid frame 0.
TEST(ShadowVolumeBricks, NoSeamAtBrickFaces) {
    const Dims n{32, 32, 32};
    const TransferFunction tf = rampTf(0.8);
    const Volume v = sheetOverSlab(n);
    const auto reader = encode(v, 8, false);
    const Volume decoded = reader->decodeFrame(computeContext(), 0);
    for (int cell : {2, 4}) {
        SCOPED_TRACE("cell " + std::to_string(cell));
        Scene s = shadowScene(n, {LightKind::Directional, normalized({0.5, 0.3, 1.0}), {1, 1, 1}, 1.0},
                              ShadowMethod::Volume, cell);
        s.camera->eye = {15.5, 15.5, 80};
        s.camera->target = {15.5, 15.5, 10};
        s.camera->up = {0, 1, 0};
        s.camera->height = 32;
        const ImageBuffer got = brickFrame(reader, tf, s);
        const ImageBuffer grid = gridFrame(decoded, tf, s);
        // The oracle of the field: the view drawn at the light volume's level too, against a grid frame of the
        // node values at that level.
        const int level = cell == 2 ? 1 : 2;
        const Volume field = brickNodeValues(computeContext(), *reader, 0, std::vector<int>(64, level),
                                             std::vector<float>(64, 0.0f));
        EXPECT_LT(imageRmse(brickFrame(reader, tf, s, level), gridFrame(field, tf, s)), 1e-6)
            << "the field's own grid frame";
        auto diff = [&](int x, int y, int c) { return double(got.at(x, y, c)) - double(grid.at(x, y, c)); };
        double atFace = 0.0, elsewhere = 0.0;
        for (int c = 0; c < 4; ++c)
            for (int a = 0; a < 32; ++a)
                for (int b = 0; b + 1 < 32; ++b) {
                    // Pixels b and b + 1 along a row (x) and along a column (y); b = 7, 15, 23 straddle a face.
                    const double row = std::abs(diff(b + 1, a, c) - diff(b, a, c));
                    const double col = std::abs(diff(a, b + 1, c) - diff(a, b, c));
                    double& worst = (b + 1) % 8 == 0 ? atFace : elsewhere;
                    worst = std::max({worst, row, col});
                }
        Scene rays = s;
        rays.effects.shadowMethod = ShadowMethod::Rays;
        const ImageBuffer rayFrame = brickFrame(reader, tf, rays);
        std::cout << "cell " << cell << ": RMSE against rays: bricks " << imageRmse(got, rayFrame)
                  << ", grid " << imageRmse(grid, rayFrame) << '\n';
        std::cout << "cell " << cell << ": largest step of brick - grid at brick faces " << atFace
                  << ", elsewhere " << elsewhere << ", RMSE against the grid " << imageRmse(got, grid)
                  << '\n';
        EXPECT_LE(atFace, std::max(1.5 * elsewhere, 2e-3));
        // The coarse level smooths the sheet as the coarse light grid does: closer to the rays than the grid's
        // light volume of the full-resolution data at the same cell.
        EXPECT_LT(imageRmse(got, rayFrame), cell == 2 ? 1.5e-2 : 3e-2);
        EXPECT_LT(imageRmse(got, rayFrame), imageRmse(grid, rayFrame));
        EXPECT_LT(imageRmse(got, grid), cell == 2 ? 2.5e-2 : 6e-2);
    }
}

// As ShadowVolume.RebuiltOnlyWhenTheLightTfOrFieldChanges for grids: a camera move alone keeps a directional
// light's volume, a head light keeps it while it turns less than the tolerance; a new TF, light or cell rebuilds.
TEST(ShadowVolumeBricks, RebuiltOnlyWhenTheLightTfOrFieldChanges) {
    const Dims n{16, 16, 16};
    const Volume v = makeFloatVolume(n, [](double x, double y, double z) {
        const double r = std::sqrt((x - 7.5) * (x - 7.5) + (y - 7.5) * (y - 7.5) + (z - 10) * (z - 10));
        return kTop * std::max(std::clamp(4.5 - r, 0.0, 1.0), z >= 2 && z <= 4 ? 0.4 : 0.0);
    });
    const auto reader = encode(v, 8, true);
    Scene s = shadowScene(n, kSun, ShadowMethod::Volume);
    BrickRenderer r(computeContext(), reader, 0, rampTf(0.8), s);
    test::expectCameraMoveKeepsAndTfRebuilds(r, s, rampTf(0.5));
    Scene moved = s;
    moved.lights = {{LightKind::Directional, {0, 0, 1}, {1, 1, 1}, 1.0}};
    r.setScene(moved);
    r.render();
    EXPECT_EQ(r.lightVolumeBuilds(), 3) << "a new light";
    moved.effects.lightVolumeCell = 2;
    r.setScene(moved);
    r.render();
    EXPECT_EQ(r.lightVolumeBuilds(), 4) << "a new cell (and level)";
    EXPECT_NE(r.statistics().find("light volumes: 4 built from the bricks at level 1"), std::string::npos)
        << r.statistics();

    test::expectHeadLightTolerance(s, [&](const Scene& head) {
        return std::make_unique<BrickRenderer>(computeContext(), reader, 0, rampTf(0.8), head);
    });
}

// The plan keeps the volume method (no rewrite to rays) and says where the extinction comes from; a cell whose
// field and volumes exceed render.cache_mb is coarsened with a line saying so, and a budget that even 64-voxel
// cells exceed is refused with one line naming the file.
TEST(ShadowVolumeBricks, PlanStatesLevelAndMemoryBound) {
    const Dims n{32, 32, 32};
    const auto reader = encode(sphereOverSlab(n), 8, true);
    const TransferFunction tf = rampTf(0.6);
    Scene s = shadowScene(n, kSun, ShadowMethod::Volume, 2);
    BrickRenderer r(computeContext(), reader, 0, tf, s);
    EXPECT_TRUE(r.plan().shadowVolume);
    EXPECT_NE(r.plan().defines.toOptions().find("-DSHADOW_VOLUME"), std::string::npos);
    const std::string explain = r.plan().explain();
    EXPECT_NE(explain.find("light-attenuation volume per light (2-voxel cells, extinction from the bricks at "
                           "level 1"),
              std::string::npos)
        << explain;
    EXPECT_EQ(explain.find("march shadow rays"), std::string::npos) << explain;
    // Cell 1: a level-0 field of 32^3 floats and 32^3 nodes, 0.26 MB; 0.2 MB holds 2-voxel cells (36 kB).
    Scene tight = s;
    tight.effects.lightVolumeCell = 1;
    tight.cacheMb = 0.2;
    const EffectPlan p = r.planEffects(tight);
    EXPECT_NE(p.explain().find("(2-voxel cells, extinction from the bricks at level 1"), std::string::npos)
        << p.explain();
    EXPECT_NE(p.explain().find("coarsened from 1-voxel cells to fit render.cache_mb"), std::string::npos)
        << p.explain();
    tight.cacheMb = 0.001;
    try {
        (void)r.planEffects(tight);
        ADD_FAILURE() << "a budget below the coarsest light volume was accepted";
    } catch (const UsageError& e) {
        EXPECT_NE(std::string(e.what()).find("shadow.vcz"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("render.cache_mb"), std::string::npos) << e.what();
        EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
    }
    tight.cacheMb = 0.2;
    r.setScene(tight);
    expectFiniteBounded(r.render());
}

} // namespace
} // namespace volcl
