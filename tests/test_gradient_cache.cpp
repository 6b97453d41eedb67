// The gradient cache: the build kernel against its C++ reference, decoded normals against analytic ones,
// and shaded frames from the packet kernel against the double reference (central differences) on hard cases.
#include "TestUtil.hpp"

#include "core/Volume.hpp"
#include "host/io/VolumeIo.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/Reference.hpp"
#include "render/Scene.hpp"
#include "render/grid/GradientCache.hpp"
#include "render/grid/GridDetail.hpp"
#include "render/grid/GridRenderer.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <functional>
#include <iostream>
#include <string>

namespace volcl {
namespace {

using test::computeContext;
using test::makeFloatVolume;
using test::orthoScene;

/// The volume quantised to uint8 (values clamped to [0, 255]).
Volume toUInt8(const Volume& f) {
    Volume v(f.dims(), ScalarType::UInt8);
    auto out = v.values<std::uint8_t>();
    for (std::size_t i = 0; i < f.voxelCount(); ++i)
        out[i] = std::uint8_t(std::clamp(std::lround(f.valueAt(i)), 0L, 255L));
    v.spacing = f.spacing;
    return v;
}

/// Sphere distance field: R - |x - c| in voxel units (world units with `spacing`), positive inside.
Volume sphereField(Dims n, double radius, Vec3 spacing = {1, 1, 1}) {
    const Vec3 c{double(n.x - 1) / 2 * spacing[0], double(n.y - 1) / 2 * spacing[1],
                 double(n.z - 1) / 2 * spacing[2]};
    Volume v = makeFloatVolume(n, [&](double x, double y, double z) {
        const double dx = x * spacing[0] - c[0], dy = y * spacing[1] - c[1], dz = z * spacing[2] - c[2];
        return radius - std::sqrt(dx * dx + dy * dy + dz * dz);
    });
    v.spacing = spacing;
    return v;
}

/// The words the device builds (without the spare one).
std::vector<std::uint32_t> deviceWords(const Volume& v,
                                       GradientCacheFormat format = GradientCacheFormat::Octahedral) {
    ComputeContext& cc = computeContext();
    std::vector<cl_uchar> bytes(v.byteSize() + scalarSize(v.type()), 0);
    std::memcpy(bytes.data(), v.bytes().data(), v.byteSize());
    auto buf = cc.upload(bytes, CL_MEM_READ_ONLY);
    VolclGridParams g = grid_detail::gridParams(v, grid_detail::buildMacrocells(v, 8));
    g.gradientMax = gradientCacheScale(v.spacing, grid_detail::valueRange(v));
    const int type = v.type() == ScalarType::UInt8    ? 1
                     : v.type() == ScalarType::UInt16 ? 2
                     : v.type() == ScalarType::Int16  ? 3
                                                      : 0;
    GradientCacheBuffer c = buildGradientCache(cc, buf.get(), type, g, format);
    EXPECT_GE(c.buildMs, 0.0);
    std::vector<cl_uint> w = cc.download(c.words);
    EXPECT_EQ(w.size(), v.voxelCount() + 1);
    EXPECT_EQ(w.back(), 0u) << "the spare word";
    return {w.begin(), w.end() - 1};
}

TEST(GradientCache, KernelMatchesHostReferenceBitForBit) {
    std::vector<std::pair<std::string, Volume>> cases;
    cases.push_back({"float sphere", sphereField({19, 17, 15}, 6.0)});
    cases.push_back({"uint8 staircase", toUInt8(makeFloatVolume({12, 9, 7}, [](double x, double y, double z) {
                         return 20.0 * std::floor((x + 2 * y + 3 * z) / 6.0);
                     }))});
    cases.push_back({"anisotropic", sphereField({11, 13, 9}, 5.0, {0.5, 1.0, 2.5})});
    cases.push_back({"flat", makeFloatVolume({6, 5, 4}, [](double, double, double) { return 3.0; })});
    cases.push_back(
        {"one voxel wide", makeFloatVolume({1, 6, 5}, [](double, double y, double z) { return y * z; })});
    Volume nan = sphereField({8, 8, 8}, 3.0);
    nan.values<float>()[nan.index(4, 4, 4)] = std::nanf("");
    cases.push_back({"NaN voxel", nan});
    for (const auto& [name, v] : cases) {
        const float gMax = gradientCacheScale(v.spacing, grid_detail::valueRange(v));
        const std::vector<std::uint32_t> want = gradientCacheReference(v, gMax);
        const std::vector<std::uint32_t> got = deviceWords(v);
        ASSERT_EQ(got.size(), want.size()) << name;
        std::size_t diff = 0;
        for (std::size_t i = 0; i < got.size(); ++i)
            diff += got[i] != want[i];
        EXPECT_EQ(diff, 0u) << name;
        if (name == std::string("flat"))
            for (std::uint32_t w : got)
                EXPECT_EQ(w, 0u) << "a flat region packs as the zero gradient";
    }
}

/// A volume of `type` holding f's values (rounded; the caller keeps them in the type's range).
Volume integerVolume(Dims n, ScalarType type, const std::function<double(double, double, double)>& f) {
    const Volume src = makeFloatVolume(n, f);
    Volume v(n, type);
    for (std::size_t i = 0; i < v.voxelCount(); ++i) {
        const long x = std::lround(src.valueAt(i));
        if (type == ScalarType::UInt8) v.values<std::uint8_t>()[i] = std::uint8_t(x);
        if (type == ScalarType::UInt16) v.values<std::uint16_t>()[i] = std::uint16_t(x);
        if (type == ScalarType::Int16) v.values<std::int16_t>()[i] = std::int16_t(x);
    }
    return v;
}

// Integer volumes spanning at most 511 keep their central differences exactly: the device's words equal the
// reference's, and every decoded gradient equals the central difference computed here in double.
TEST(GradientCache, ExactFormHoldsTheCentralDifferences) {
    std::vector<std::pair<std::string, Volume>> cases;
    cases.push_back(
        {"uint8 full range", integerVolume({13, 11, 9}, ScalarType::UInt8, [](double x, double y, double z) {
             return std::fmod(97.0 * x + 31.0 * y * y + 7.0 * z, 256.0);
         })});
    cases.push_back({"uint16 spanning 511",
                     integerVolume({9, 8, 7}, ScalarType::UInt16, [](double x, double y, double z) {
                         return 40000.0 + ((int(x) + int(y) + int(z)) % 2 ? 511.0 : 0.0);
                     })});
    Volume aniso = integerVolume({7, 9, 11}, ScalarType::Int16, [](double x, double y, double z) {
        return -200.0 + 30.0 * x - 11.0 * y + 17.0 * z;
    });
    aniso.spacing = {0.5, 1.25, 3.0};
    cases.push_back({"int16 anisotropic, negative", aniso});
    cases.push_back(
        {"one voxel wide", integerVolume({1, 6, 5}, ScalarType::UInt8,
                                         [](double, double y, double z) { return 9.0 * y * z; })});
    for (const auto& [name, v] : cases) {
        const ValueRange range = grid_detail::valueRange(v);
        ASSERT_EQ(gradientCacheFormat(v.type(), range.max - range.min), GradientCacheFormat::ExactDifferences)
            << name;
        const std::vector<std::uint32_t> want =
            gradientCacheReference(v, 1.0f, GradientCacheFormat::ExactDifferences);
        EXPECT_EQ(deviceWords(v, GradientCacheFormat::ExactDifferences), want) << name;
        const Dims n = v.dims();
        double worst = 0.0;
        for (std::size_t z = 0; z < n.z; ++z)
            for (std::size_t y = 0; y < n.y; ++y)
                for (std::size_t x = 0; x < n.x; ++x) {
                    auto at = [&](std::size_t i, std::size_t j, std::size_t k) {
                        return v.valueAt(v.index(i, j, k));
                    };
                    auto lo = [](std::size_t i) { return i > 0 ? i - 1 : 0; };
                    auto hi = [](std::size_t i, std::size_t m) { return std::min(i + 1, m - 1); };
                    const Vec3 cd{(at(hi(x, n.x), y, z) - at(lo(x), y, z)) / (2 * v.spacing[0]),
                                  (at(x, hi(y, n.y), z) - at(x, lo(y), z)) / (2 * v.spacing[1]),
                                  (at(x, y, hi(z, n.z)) - at(x, y, lo(z))) / (2 * v.spacing[2])};
                    const Vec3 g = unpackExactGradient(want[v.index(x, y, z)], v.spacing);
                    for (int a = 0; a < 3; ++a)
                        worst = std::max(worst, std::abs(g[std::size_t(a)] - cd[std::size_t(a)]));
                }
        EXPECT_EQ(worst, 0.0) << name;
    }
    // One more than 511, or float voxels: the octahedral form.
    EXPECT_EQ(gradientCacheFormat(ScalarType::UInt16, 512.0), GradientCacheFormat::Octahedral);
    EXPECT_EQ(gradientCacheFormat(ScalarType::Float32, 10.0), GradientCacheFormat::Octahedral);
}

// Decoded normals of a sphere's distance field against the analytic normals, and decoded gradients against
// the exact central differences they quantise.
TEST(GradientCache, SphereNormalsCloseToAnalytic) {
    for (const Vec3 spacing : {Vec3{1, 1, 1}, Vec3{0.7, 1.3, 2.0}}) {
        const Dims n{33, 31, 29};
        const Volume v = sphereField(n, 12.0, spacing);
        const float gMax = gradientCacheScale(v.spacing, grid_detail::valueRange(v));
        const std::vector<std::uint32_t> words = gradientCacheReference(v, gMax);
        const Vec3 c{16 * spacing[0], 15 * spacing[1], 14 * spacing[2]};
        double worstAnalytic = 0.0, worstQuant = 0.0, worstMag = 0.0;
        std::size_t checked = 0;
        for (std::size_t z = 1; z + 1 < n.z; ++z)
            for (std::size_t y = 1; y + 1 < n.y; ++y)
                for (std::size_t x = 1; x + 1 < n.x; ++x) {
                    const Vec3 p{x * spacing[0] - c[0], y * spacing[1] - c[1], z * spacing[2] - c[2]};
                    const double r = norm(p);
                    if (r < 4.0 || r > 11.0) continue; // away from the centre's kink and the border
                    const Vec3 g = unpackGradient(words[v.index(x, y, z)], gMax);
                    const Vec3 normal = scale(g, 1.0 / norm(g)), want = scale(p, -1.0 / r);
                    worstAnalytic = std::max(worstAnalytic, std::acos(std::min(1.0, dot(normal, want))));
                    auto at = [&](std::size_t i, std::size_t j, std::size_t k) {
                        return v.valueAt(v.index(i, j, k));
                    };
                    const Vec3 cd{(at(x + 1, y, z) - at(x - 1, y, z)) / (2 * spacing[0]),
                                  (at(x, y + 1, z) - at(x, y - 1, z)) / (2 * spacing[1]),
                                  (at(x, y, z + 1) - at(x, y, z - 1)) / (2 * spacing[2])};
                    worstQuant = std::max(worstQuant,
                                          std::acos(std::min(1.0, dot(normal, scale(cd, 1.0 / norm(cd))))));
                    const double l1 = std::abs(cd[0]) + std::abs(cd[1]) + std::abs(cd[2]);
                    const double gl1 = std::abs(g[0]) + std::abs(g[1]) + std::abs(g[2]);
                    worstMag = std::max(worstMag, std::abs(gl1 - l1) / l1);
                    ++checked;
                }
        ASSERT_GT(checked, 1000u);
        const double deg = 180.0 / M_PI;
        EXPECT_LT(worstQuant * deg, 0.06) << "12-bit octahedral directions";
        EXPECT_LT(worstMag, 1.0 / 32.0 + 1e-6) << "4 mantissa bits, rounded";
        // The central differences' own error on the sphere (curvature) dominates the quantisation.
        EXPECT_LT(worstAnalytic * deg, 3.0)
            << "spacing " << spacing[0] << "," << spacing[1] << "," << spacing[2];
    }
}

/// A shaded test scene: head light, default Blinn-Phong, step 0.25.
Scene shadedScene(Dims n, double h, GradientKind g) {
    Scene s = orthoScene(n, h, 40, 36);
    s.camera->eye = {s.camera->target[0] + 30, s.camera->target[1] - 20, -40.0};
    test::shadeWithHeadLight(s, g);
    return s;
}

TransferFunction rampTf(double lo, double hi, double tauMax) {
    TransferFunction tf;
    tf.domain = {lo, hi};
    tf.color = {{lo, {1.0, 0.6, 0.3}}, {hi, {0.4, 0.7, 1.0}}};
    tf.extinction = {{lo, 0.0}, {lo + 0.3 * (hi - lo), 0.0}, {hi, tauMax}};
    return tf;
}

struct ShadedCase {
    std::string name;
    Volume volume;
    TransferFunction tf;
    double h;
    double bound;        ///< RMSE of the cache (trilinear) against the reference
    double boundNearest; ///< the same for the nearest voxel's gradient
};

/// Hard cases shaded from the cache: each against the reference and against on-the-fly central
/// differences on the per-ray kernel; the packet kernel must take them.
TEST(GradientCache, ShadedFramesMatchReferenceOnHardCases) {
    std::vector<ShadedCase> cases;
    cases.push_back({"sphere", sphereField({24, 24, 24}, 9.0), rampTf(-2, 9, 1.5), 28, 1e-4, 3e-3});
    cases.push_back({"anisotropic sphere", sphereField({24, 16, 40}, 9.0, {1.0, 1.5, 0.6}),
                     rampTf(-2, 9, 1.5), 30, 1e-4, 4e-3});
    // 8-bit staircase: the sphere quantised to 32 levels of uint8.
    cases.push_back({"8-bit staircase",
                     toUInt8(makeFloatVolume({24, 24, 24},
                                             [](double x, double y, double z) {
                                                 const double r = std::sqrt((x - 11.5) * (x - 11.5) +
                                                                            (y - 11.5) * (y - 11.5) +
                                                                            (z - 11.5) * (z - 11.5));
                                                 return 8.0 *
                                                        std::floor(std::max(0.0, 255.0 - 24.0 * r) / 8.0);
                                             })),
                     rampTf(0, 255, 0.8), 28, 1.2e-4, 5e-3});
    // A one-voxel-thick plate at z = 10 and a one-voxel-thick rod along y.
    cases.push_back({"1-voxel-thick",
                     makeFloatVolume({20, 20, 20},
                                     [](double x, double, double z) {
                                         return (z == 10.0 ? 100.0 : 0.0) +
                                                (x == 6.0 && z == 5.0 ? 100.0 : 0.0);
                                     }),
                     rampTf(0, 100, 4.0), 24, 3e-3, 7e-2});
    // Flat: constant value, no gradient anywhere: lit as facing the light, no NaN.
    cases.push_back({"flat", makeFloatVolume({12, 12, 12}, [](double, double, double) { return 50.0; }),
                     rampTf(0, 60, 0.3), 16, 1e-6, 1e-6});
    for (const ShadedCase& c : cases) {
        const Dims n = c.volume.dims();
        for (GradientKind g : {GradientKind::Cache, GradientKind::CacheNearest}) {
            const Scene s = shadedScene(n, c.h, g);
            GridRenderer r(computeContext(), c.volume, c.tf, s);
            const bool exact = c.volume.type() == ScalarType::UInt8; // spans at most 255: the exact form
            EXPECT_EQ(r.plan().gradientCache, g == GradientKind::CacheNearest ? 2
                                              : exact                         ? 3
                                                                              : 1)
                << c.name << "\n"
                << r.plan().explain();
            const ImageBuffer img = r.render();
            for (float px : img.pixels)
                ASSERT_TRUE(std::isfinite(px)) << c.name;
            EXPECT_GE(r.gradientCacheBuildMs(), 0.0);
            const ImageBuffer ref = referenceRender(c.volume, c.tf, s, {.step = 0.05});
            const double e = imageRmse(img, ref);
            Scene sc = s;
            sc.effects.gradient = GradientKind::Central;
            const double eCentral =
                imageRmse(GridRenderer(computeContext(), c.volume, c.tf, sc).render(), ref);
            std::cout << c.name << (g == GradientKind::Cache ? ", cache: RMSE " : ", cache-nearest: RMSE ")
                      << e << " (central differences " << eCentral << ")\n";
            if (g == GradientKind::Cache)
                EXPECT_LT(e, c.bound) << c.name << " (central differences: " << eCentral << ")";
            else // the nearest voxel's gradient: facets; on a one-voxel plate the plate's own voxels are flat
                EXPECT_LT(e, c.boundNearest) << c.name << " (central differences: " << eCentral << ")";
        }
    }
}

// The packet kernel with every common effect beside the cache: 2D and 3D pre-integration, clipping, early
// termination, skipping; NaN voxels stay unlit in their colour.
TEST(GradientCache, PacketShadingWithPreintegrationClippingAndSkipping) {
    const Dims n{24, 24, 24};
    const Volume v = sphereField(n, 9.0);
    const TransferFunction tf = rampTf(-2, 9, 1.5);
    for (Preintegration pre : {Preintegration::None, Preintegration::Table2d, Preintegration::Table3d}) {
        Scene s = shadedScene(n, 28, GradientKind::Cache);
        s.preintegration = pre;
        s.skipping = SkipMode::On;
        s.earlyTermination = 0.99;
        s.effects.clipPlanes = {{{0.6, 0.0, 0.8}, -14.0}};
        GridRenderer r(computeContext(), v, tf, s);
        EXPECT_EQ(r.plan().gradientCache, 1) << r.plan().explain();
        EXPECT_TRUE(r.plan().clipping);
        const ImageBuffer img = r.render();
        Scene exact = s;
        exact.earlyTermination = 1.0;
        const ImageBuffer ref = referenceRender(v, tf, exact, {.step = 0.05});
        EXPECT_LT(imageRmse(img, ref), 6e-3) << preintegrationName(pre);
    }
    // Directional and point lights under a perspective camera: per-lane light directions and half vectors.
    Scene s = shadedScene(n, 28, GradientKind::Cache);
    s.camera->projection = Projection::Perspective;
    s.camera->fovYDeg = 40.0;
    s.lights = {Light{LightKind::Directional, {0.3, 0.5, -0.8}, {1, 0.9, 0.8}, 1.0},
                Light{LightKind::Point, {40, 12, 0}, {0.5, 0.4, 0.3}, 1.0},
                Light{LightKind::Head, {0, 0, 0}, {0.3, 0.3, 0.3}, 1.0}};
    s.effects.shininess = 20.5; // a non-integer exponent: exp2(n log2 x)
    GridRenderer r(computeContext(), v, tf, s);
    EXPECT_EQ(r.plan().gradientCache, 1) << r.plan().explain();
    EXPECT_LT(imageRmse(r.render(), referenceRender(v, tf, s, {.step = 0.05})), 3e-3);
}

// One head light under an orthographic camera takes its own path in shade_packet ((g.v)^2 / |g|^2 and half
// the exponent); the same light given as a directional light toward the eye takes the general light loop
// (reciprocal square root, half vector). Both must give the same image: integer, odd and fractional
// exponents, a coloured light, with and without shadows from the light volume.
TEST(GradientCache, HeadLightPathMatchesTheLightLoop) {
    const Dims n{24, 24, 24};
    const Volume v = toUInt8(makeFloatVolume(n, [](double x, double y, double z) {
        const double r =
            std::sqrt((x - 11.5) * (x - 11.5) + (y - 11.5) * (y - 11.5) + (z - 11.5) * (z - 11.5));
        return std::max(0.0, 250.0 - 22.0 * r);
    }));
    const TransferFunction tf = rampTf(0, 250, 0.8);
    for (bool shadows : {false, true})
        for (double shininess : {32.0, 5.0, 20.5, 0.0}) {
            Scene head = shadedScene(n, 28, GradientKind::Cache);
            head.effects.shininess = shininess;
            head.effects.shadows = shadows;
            head.lights[0].color = {1.0, 0.8, 0.5};
            Scene dir = head;
            const Vec3 e = head.camera->eye, t = head.camera->target;
            dir.lights[0].kind = LightKind::Directional;
            dir.lights[0].vector = {e[0] - t[0], e[1] - t[1], e[2] - t[2]}; // toward the eye (normalised)
            GridRenderer rh(computeContext(), v, tf, head), rd(computeContext(), v, tf, dir);
            EXPECT_EQ(rh.plan().gradientCache, 3) << rh.plan().explain();
            EXPECT_EQ(rd.plan().gradientCache, 3) << rd.plan().explain();
            const ImageBuffer a = rh.render(), b = rd.render();
            double maxDiff = 0.0, maxValue = 0.0;
            for (std::size_t i = 0; i < a.pixels.size(); ++i) {
                ASSERT_TRUE(std::isfinite(a.pixels[i]));
                maxDiff = std::max(maxDiff, double(std::fabs(a.pixels[i] - b.pixels[i])));
                maxValue = std::max(maxValue, double(a.pixels[i]));
            }
            EXPECT_GT(maxValue, 0.1) << "the sphere is visible";
            EXPECT_LT(maxDiff, 2e-5) << "shininess " << shininess << (shadows ? ", shadows" : "");
        }
}

// Scenes the packet kernel does not take keep central differences, and say so.
TEST(GradientCache, FallsBackToCentralDifferencesWithAReason) {
    const Dims n{12, 12, 12};
    const Volume v = sphereField(n, 4.0);
    const TransferFunction tf = rampTf(-2, 4, 1.0);
    Scene s = shadedScene(n, 14, GradientKind::Cache);
    s.effects.isosurfaces = {{1.0, {1, 1, 1, 0.5}}};
    EffectPlan p = planEffects(s, v, tf);
    EXPECT_EQ(p.gradientCache, 0);
    EXPECT_NE(p.explain().find("gradient cache: iso-surfaces"), std::string::npos) << p.explain();
    s.effects.isosurfaces.clear();
    s.filter = ReconstructionFilter::Cubic;
    p = planEffects(s, v, tf);
    EXPECT_EQ(p.gradientCache, 0);
    EXPECT_NE(p.explain().find("analytic gradient"), std::string::npos) << p.explain();
    s.filter = ReconstructionFilter::Linear;
    s.effects.gradient = GradientKind::Central;
    EXPECT_EQ(planEffects(s, v, tf).gradientCache, 0);
    s.effects.gradient = GradientKind::CacheNearest;
    EXPECT_EQ(planEffects(s, v, tf).gradientCache, 2);
}

// BrainWeb MRI: the cached-gradient frame against the double reference, next to on-the-fly central
// differences at the same step.
TEST(GradientCache, MriShadedCloseToReference) {
    std::filesystem::path data;
    VOLCL_REQUIRE_SHARED_DATA(data);
    const Volume mri = test::brainWebMri(data);
    // The same voxels as float: the octahedral form (uint8 spanning 255 takes the exact form).
    const Volume asFloat = test::asFloat32(mri);
    const std::filesystem::path bench = std::filesystem::path(VOLCL_SOURCE_DIR) / "bench/render";
    Scene s = Scene::fromFile(bench / "mri_scene.json");
    const TransferFunction tf = TransferFunction::fromFile(bench / "mri_tf.json").fittedTo({0, 255});
    s.width = 64;
    s.height = 64;
    s.earlyTermination = 1.0;
    s.lights = {Light{LightKind::Head, {0, 0, -1}, {1, 1, 1}, 1.0}};
    s.effects.shading = true;
    s.effects.shadingGiven = true;
    const ImageBuffer ref = referenceRender(mri, tf, s, {.step = 0.1});
    Scene sc = s;
    sc.effects.gradient = GradientKind::Central;
    const double eCentral = imageRmse(GridRenderer(computeContext(), mri, tf, sc).render(), ref);
    for (const Volume* v : {&mri, static_cast<const Volume*>(&asFloat)}) {
        GridRenderer r(computeContext(), *v, tf, s);
        const bool exact = v == &mri;
        ASSERT_EQ(r.plan().gradientCache, exact ? 3 : 1) << r.plan().explain();
        const double e = imageRmse(r.render(), ref);
        std::cout << "MRI 64x64, shaded: RMSE cache (" << (exact ? "exact" : "octahedral") << ") " << e
                  << ", central differences " << eCentral << '\n';
        EXPECT_LT(e, (exact ? 1.01 : 1.2) * eCentral + (exact ? 1e-5 : 1e-3))
            << "central differences: " << eCentral;
    }
}

} // namespace
} // namespace volcl
