// Iso-surface hits of the ray marcher: kernel roots vs the double reference's exact cubic roots, an analytic
// sphere, crossings inside one step, hard rays, and iso mixed with dvr.
#include "TestUtil.hpp"

#include "core/Volume.hpp"
#include "host/io/VolumeIo.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/Scene.hpp"
#include "render/VecMath.hpp"
#include "render/grid/GridRenderer.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <random>
#include <string>

namespace {

using namespace volcl;
using volcl::test::computeContext;
using volcl::test::makeFloatVolume;
using volcl::test::maxAbsDiff;

/// A TF that adds nothing: iso scenes only show their surfaces.
TransferFunction clearTf(double lo, double hi) {
    TransferFunction tf;
    tf.domain = {lo, hi};
    tf.color = {{lo, {1, 1, 1}}};
    tf.extinction = {{lo, 0.0}};
    return tf;
}

Scene isoScene(const Camera& cam, int w, int h, std::vector<IsoLayer> isos, double step) {
    Scene s;
    s.camera = cam;
    s.width = w;
    s.height = h;
    s.mode = RenderMode::Iso;
    s.step = step;
    s.earlyTermination = 1.0;
    s.effects.isosurfaces = std::move(isos);
    return s;
}

Camera ortho(Vec3 eye, Vec3 target, double height) {
    Camera c;
    c.eye = eye;
    c.target = target;
    c.height = height;
    return c;
}

/// Trilinear interpolation of v at world point w (clamped to the grid), in double.
double trilinear(const Volume& v, const std::vector<float>& vals, const Vec3& w) {
    const Dims d = v.dims();
    const std::size_t n[3] = {d.x, d.y, d.z};
    std::size_t i0[3], i1[3];
    double f[3];
    for (int a = 0; a < 3; ++a) {
        const double x = std::clamp((w[a] - v.origin[a]) / v.spacing[a], 0.0, double(n[a] - 1));
        i0[a] = std::min(std::size_t(x), n[a] - 2);
        i1[a] = i0[a] + 1;
        f[a] = x - double(i0[a]);
    }
    double s = 0.0;
    for (int c = 0; c < 8; ++c) {
        const std::size_t i = c & 1 ? i1[0] : i0[0], j = c & 2 ? i1[1] : i0[1], k = c & 4 ? i1[2] : i0[2];
        s += double(vals[v.index(i, j, k)]) * (c & 1 ? f[0] : 1 - f[0]) * (c & 2 ? f[1] : 1 - f[1]) *
             (c & 4 ? f[2] : 1 - f[2]);
    }
    return s;
}

/// Kernel depth vs reference depth. A float root is off by the float error of the sample position (a few
/// ulp of the ray parameter, ~1e-5 at distances ~100) over cos(theta), theta between the ray and the
/// surface normal; near-tangent hits (cos(theta) < kMinCos) are counted apart, since no float renderer
/// places them to 1e-4 along the ray (their distance to the surface, error * cos(theta), is still tiny).
constexpr double kMinCos = 0.1;
struct DepthComparison {
    double worst = 0.0, worstTangent = 0.0, worstDistance = 0.0;
    int both = 0, tangent = 0, onlyOne = 0;
};
DepthComparison compareDepth(const ImageBuffer& a, const ImageBuffer& b, const Volume& v, const Camera& cam) {
    DepthComparison c;
    const std::vector<float> vals = v.toFloat();
    for (int y = 0; y < a.height; ++y)
        for (int x = 0; x < a.width; ++x) {
            const float da = a.at(x, y, 4), db = b.at(x, y, 4);
            const CameraRay ray = cameraRay(cam, a.width, a.height, x, y);
            // |cos(theta)| = |ds/dt| / |grad s| at the hit, by central differences.
            auto cosTheta = [&](double t) {
                const double h = 1e-3;
                const Vec3 p = add(ray.origin, scale(ray.direction, t));
                auto s = [&](const Vec3& q) { return trilinear(v, vals, q); };
                const double along =
                    std::abs(s(add(p, scale(ray.direction, h))) - s(add(p, scale(ray.direction, -h))));
                Vec3 g;
                for (int k = 0; k < 3; ++k) {
                    Vec3 e{0, 0, 0};
                    e[std::size_t(k)] = h;
                    g[std::size_t(k)] = s(add(p, e)) - s(sub(p, e));
                }
                return norm(g) > 0.0 ? along / norm(g) : 0.0;
            };
            if (std::isinf(da) != std::isinf(db)) {
                // Only a near-tangent ray may legitimately see a crossing on one side of float rounding.
                if (cosTheta(std::isinf(da) ? double(db) : double(da)) >= kMinCos) ++c.onlyOne;
            } else if (!std::isinf(da)) {
                const double e = std::abs(double(da) - double(db)), ct = cosTheta(double(db));
                c.worstDistance = std::max(c.worstDistance, e * ct);
                if (ct >= kMinCos) {
                    ++c.both;
                    c.worst = std::max(c.worst, e);
                } else {
                    ++c.tangent;
                    c.worstTangent = std::max(c.worstTangent, e);
                }
            }
        }
    return c;
}

// (a) Kernel roots against the reference's exact roots of the trilinear cubic: a sphere and random smooth
// fields, steps from 0.25 to 4 voxels (the exact root does not depend on the step), several iso-values.
TEST(RenderIso, KernelRootsMatchExactTrilinearRoots) {
    double worst = 0.0, worstTangent = 0.0, worstDistance = 0.0;
    int hits = 0, tangent = 0, mismatched = 0;
    // Sphere |x - c|^2 (not trilinear: the trilinear surface differs from the sphere, the roots may not).
    const Dims n{40, 40, 40};
    const double c = 19.5;
    const Volume sphere = makeFloatVolume(n, [&](double x, double y, double z) {
        return (x - c) * (x - c) + (y - c) * (y - c) + (z - c) * (z - c);
    });
    for (double step : {0.25, 1.0, 4.0}) {
        const Scene s =
            isoScene(ortho({c, c, -30}, {c, c, c}, 36.0), 40, 40, {{15.0 * 15.0, {1, 1, 1, 1}}}, step);
        const ImageBuffer img = GridRenderer(computeContext(), sphere, clearTf(0, 2000), s).render();
        const ImageBuffer ref = referenceRender(sphere, clearTf(0, 2000), s, {.step = 1.0});
        const DepthComparison d = compareDepth(img, ref, sphere, *s.camera);
        EXPECT_LT(d.worst, 1e-4) << "sphere, step " << step;
        EXPECT_EQ(d.onlyOne, 0) << "sphere, step " << step;
        EXPECT_GT(d.both, 800);
        EXPECT_LT(d.worstDistance, 1e-4);
        worst = std::max(worst, d.worst);
        worstTangent = std::max(worstTangent, d.worstTangent);
        worstDistance = std::max(worstDistance, d.worstDistance);
        hits += d.both;
        tangent += d.tangent;
        mismatched += d.onlyOne;
    }
    // Random smooth fields: sums of products of sines, two transparent iso-values, orthographic and
    // perspective views.
    std::mt19937 rng(12345);
    std::uniform_real_distribution<double> freq(0.15, 0.6), phase(0.0, 6.3);
    for (int field = 0; field < 3; ++field) {
        std::array<std::array<double, 6>, 3> w{};
        for (auto& t : w)
            for (int i = 0; i < 6; ++i)
                t[std::size_t(i)] = i < 3 ? freq(rng) : phase(rng);
        const Dims m{30, 26, 28};
        const Volume v = makeFloatVolume(m, [&](double x, double y, double z) {
            double s = 1.0;
            for (const auto& t : w)
                s += 0.33 * std::sin(t[0] * x + t[3]) * std::sin(t[1] * y + t[4]) * std::sin(t[2] * z + t[5]);
            return s;
        });
        Camera persp;
        persp.projection = Projection::Perspective;
        persp.eye = {-12, 40, -25};
        persp.target = {14.5, 12.5, 13.5};
        persp.fovYDeg = 40.0;
        for (const Camera& cam : {ortho({14.5, 12.5, -20}, {14.5, 12.5, 13.5}, 28.0), persp})
            for (double step : {0.5, 3.0}) {
                const Scene s =
                    isoScene(cam, 36, 32, {{1.2, {1, 0.2, 0.2, 0.6}}, {0.75, {0.2, 0.2, 1, 0.5}}}, step);
                const ImageBuffer img = GridRenderer(computeContext(), v, clearTf(0, 2), s).render();
                const ImageBuffer ref = referenceRender(v, clearTf(0, 2), s, {.step = 1.0});
                const DepthComparison d = compareDepth(img, ref, v, cam);
                EXPECT_LT(d.worst, 1e-4) << "field " << field << " step " << step;
                EXPECT_EQ(d.onlyOne, 0) << "field " << field << " step " << step;
                EXPECT_GT(d.both, 200);
                // Every crossing of both layers is composited: colours agree with the reference.
                EXPECT_LT(maxAbsDiff(img, ref), 1e-5) << "field " << field << " step " << step;
                EXPECT_LT(d.worstDistance, 1e-4);
                worst = std::max(worst, d.worst);
                worstTangent = std::max(worstTangent, d.worstTangent);
                worstDistance = std::max(worstDistance, d.worstDistance);
                hits += d.both;
                tangent += d.tangent;
                mismatched += d.onlyOne;
            }
    }
    RecordProperty("worst_kernel_vs_exact_root_voxels", std::to_string(worst));
    RecordProperty("hits_compared", std::to_string(hits));
    RecordProperty("hit_mismatches", std::to_string(mismatched));
    RecordProperty("near_tangent_hits", std::to_string(tangent));
    RecordProperty("near_tangent_worst_root_difference_voxels", std::to_string(worstTangent));
    RecordProperty("worst_difference_times_cos_theta_voxels", std::to_string(worstDistance));
}

// (a, continued) Real data: the iron protein (uint8, 68^3) at two iso-values, and a smooth field on an
// anisotropic grid with an offset origin (the tolerance is along the ray in world units; here <= voxels).
TEST(RenderIso, KernelRootsMatchExactRootsOnRealAndAnisotropicVolumes) {
    std::filesystem::path data;
    VOLCL_REQUIRE_SHARED_DATA(data);
    const Volume iron = readVolume(data / "regular" / "ironProt.vtk");
    Camera persp;
    persp.projection = Projection::Perspective;
    persp.eye = {-40, 90, -60};
    persp.target = {33.5, 33.5, 33.5};
    persp.fovYDeg = 45.0;
    double worst = 0.0;
    int hits = 0;
    for (double step : {0.5, 2.0}) {
        const Scene s =
            isoScene(persp, 48, 48, {{40.0, {1, 0.8, 0.2, 0.4}}, {120.0, {0.3, 0.5, 1, 1}}}, step);
        const ImageBuffer img = GridRenderer(computeContext(), iron, clearTf(0, 255), s).render();
        const ImageBuffer ref = referenceRender(iron, clearTf(0, 255), s, {.step = 1.0});
        const DepthComparison d = compareDepth(img, ref, iron, persp);
        EXPECT_LT(d.worst, 1e-4) << "ironProt step " << step;
        EXPECT_EQ(d.onlyOne, 0) << "ironProt step " << step;
        EXPECT_GT(d.both, 400);
        EXPECT_LT(d.worstDistance, 1e-4);
        EXPECT_LT(maxAbsDiff(img, ref), 1e-5);
        worst = std::max(worst, d.worst);
        hits += d.both;
    }
    Volume aniso = makeFloatVolume({24, 30, 20}, [](double x, double y, double z) {
        return std::sin(0.4 * x) * std::cos(0.3 * y) + 0.5 * std::sin(0.5 * z + 0.3 * x);
    });
    aniso.spacing = {0.5, 0.4, 0.8};
    aniso.origin = {-3.0, 2.0, 1.0};
    const Camera cam = ortho({-20, -10, -15}, {2.75, 7.8, 8.6}, 16.0);
    const Scene s = isoScene(cam, 40, 40, {{0.3, {1, 1, 1, 0.5}}, {-0.4, {1, 0, 0, 1}}}, 0.3);
    const ImageBuffer img = GridRenderer(computeContext(), aniso, clearTf(-2, 2), s).render();
    const ImageBuffer ref = referenceRender(aniso, clearTf(-2, 2), s, {.step = 1.0});
    const DepthComparison d = compareDepth(img, ref, aniso, cam);
    EXPECT_LT(d.worst, 1e-4 * 0.4) << "anisotropic"; // 1e-4 of the smallest spacing
    EXPECT_EQ(d.onlyOne, 0);
    EXPECT_GT(d.both, 500);
    worst = std::max(worst, d.worst);
    RecordProperty("worst_root_difference_real_and_anisotropic", std::to_string(worst));
    RecordProperty("hits_compared", std::to_string(hits + d.both));
}

// (b) Within 1e-3 voxel of an analytic sphere. The volume holds a cap of a sphere of radius R = 1000 voxels
// (centre far outside), field |p - c| - R stored as float. Bound: trilinear interpolation of f errs by at
// most (h^2/8) sum_a max|d2f/dx_a^2| <= 3 / (8 r) = 3.75e-4 voxel (h = 1, r >= R - 1 near the surface), the
// root by 1e-5 voxel, float positions by ~1e-5: the hit lies within 4e-4 voxel of the sphere (distance
// ||x - c| - R|) and within 4e-4 / cos(theta) along the ray (checked where cos(theta) >= 0.5).
TEST(RenderIso, HitsWithin1e3VoxelOfAnalyticSphere) {
    const double R = 1000.0;
    const Dims n{48, 48, 40};
    const Vec3 c{23.5, 23.5, 30.0 - R}; // the top of the sphere at z = 30, the cap falls ~0.6 over the volume
    const Volume v = makeFloatVolume(n, [&](double x, double y, double z) {
        return std::sqrt((x - c[0]) * (x - c[0]) + (y - c[1]) * (y - c[1]) + (z - c[2]) * (z - c[2])) - R;
    });
    Camera persp;
    persp.projection = Projection::Perspective;
    persp.eye = {-20, 70, 90};
    persp.target = {23.5, 23.5, 29.0};
    persp.fovYDeg = 35.0;
    const std::vector<Camera> cams{ortho({23.5, 23.5, 80}, {23.5, 23.5, 0}, 44.0),
                                   ortho({-10, 0, 70}, {23.5, 23.5, 29.0}, 30.0), persp};
    double worstDistance = 0.0, worstAlong = 0.0, worstAlongRef = 0.0;
    int hits = 0;
    for (const Camera& cam : cams)
        for (double step : {0.5, 2.0}) {
            const int w = 40, h = 40;
            const Scene s = isoScene(cam, w, h, {{0.0, {1, 1, 1, 1}}}, step);
            const ImageBuffer img = GridRenderer(computeContext(), v, clearTf(-10, 60), s).render();
            const ImageBuffer ref = referenceRender(v, clearTf(-10, 60), s, {.step = 1.0});
            for (int y = 0; y < h; ++y)
                for (int x = 0; x < w; ++x) {
                    const CameraRay ray = cameraRay(cam, w, h, x, y);
                    // Analytic intersection with the sphere (the near root of |o + t d - c| = R).
                    const Vec3 oc = sub(ray.origin, c);
                    const double b = dot(oc, ray.direction), q = dot(oc, oc) - R * R;
                    const double tSphere = -b - std::sqrt(b * b - q);
                    const Vec3 p = add(ray.origin, scale(ray.direction, tSphere));
                    const bool inBox =
                        p[0] >= 0 && p[0] <= 47 && p[1] >= 0 && p[1] <= 47 && p[2] >= 0 && p[2] <= 39;
                    const float depth = img.at(x, y, 4);
                    if (!inBox) continue;
                    ASSERT_TRUE(std::isfinite(depth)) << x << "," << y;
                    ++hits;
                    const Vec3 hit = add(ray.origin, scale(ray.direction, double(depth)));
                    worstDistance = std::max(worstDistance, std::abs(norm(sub(hit, c)) - R));
                    const double cosTheta = std::abs(dot(ray.direction, normalized(sub(p, c))));
                    if (cosTheta >= 0.5) {
                        worstAlong = std::max(worstAlong, std::abs(double(depth) - tSphere));
                        worstAlongRef = std::max(worstAlongRef, std::abs(double(ref.at(x, y, 4)) - tSphere));
                    }
                }
        }
    EXPECT_GT(hits, 4000);
    EXPECT_LT(worstDistance, 1e-3);
    EXPECT_LT(worstAlong, 1e-3);
    RecordProperty("worst_distance_to_sphere_voxels", std::to_string(worstDistance));
    RecordProperty("worst_along_ray_error_cos_ge_half_voxels", std::to_string(worstAlong));
    RecordProperty("reference_worst_along_ray_error_voxels", std::to_string(worstAlongRef));
}

// (c) A shell thinner than the step: every sample of the march lies outside it (a sign test between samples
// sees nothing), yet both crossings are found and composited.
TEST(RenderIso, ShellThinnerThanTheStepIsHit) {
    const Dims n{12, 12, 20};
    // One voxel-thick slab: 1 on the plane z = 10, 0 elsewhere; s >= 0.5 for z in [9.5, 10.5].
    const Volume v = makeFloatVolume(n, [](double, double, double z) { return z == 10.0 ? 1.0 : 0.0; });
    for (double step : {3.0, 2.25}) {
        // Eye plane z = -50, box entry z = 0: the samples lie at z = 0, step, 2 step, ... where s = 0.
        for (int k = 0; k * step <= 19.0; ++k)
            ASSERT_TRUE(std::abs(k * step - 10.0) >= 1.0)
                << "a sample inside the shell would defeat the test";
        const Camera cam = ortho({5.5, 5.5, -50}, {5.5, 5.5, 10}, 8.0);
        const Scene s = isoScene(cam, 6, 6, {{0.5, {1, 0, 0, 0.5}}}, step);
        const ImageBuffer img = GridRenderer(computeContext(), v, clearTf(0, 1), s).render();
        for (int y = 0; y < 6; ++y)
            for (int x = 0; x < 6; ++x) {
                EXPECT_NEAR(img.at(x, y, 4), 59.5, 1e-4) << step; // front face z = 9.5
                EXPECT_NEAR(img.at(x, y, 3), 0.75, 1e-6) << step; // front and back face composited
                EXPECT_NEAR(img.at(x, y, 0), 0.75, 1e-6) << step;
            }
        // Oblique rays through the slab: the trilinear field is linear in z, so the faces are exact planes.
        const Camera tilt = ortho({-20, -10, -40}, {5.5, 5.5, 10}, 5.0);
        const Scene t = isoScene(tilt, 5, 5, {{0.5, {1, 0, 0, 0.5}}}, step);
        const ImageBuffer ti = GridRenderer(computeContext(), v, clearTf(0, 1), t).render();
        for (int y = 0; y < 5; ++y)
            for (int x = 0; x < 5; ++x) {
                const CameraRay ray = cameraRay(tilt, 5, 5, x, y);
                const double tPlane = (9.5 - ray.origin[2]) / ray.direction[2];
                const Vec3 p = add(ray.origin, scale(ray.direction, tPlane));
                if (p[0] < 0 || p[0] > 11 || p[1] < 0 || p[1] > 11) continue;
                EXPECT_NEAR(ti.at(x, y, 4), tPlane, 1e-4) << step << " " << x << "," << y;
            }
    }
}

// (d) Iso-values equal to voxel values; rays along cell faces, edges and the diagonal; grazing rays. A linear
// field is reproduced exactly by trilinear interpolation, so the surfaces are exact planes.
TEST(RenderIso, HardRaysOnAnExactPlane) {
    const Dims n{16, 16, 16};
    const Volume v = makeFloatVolume(n, [](double x, double y, double z) { return x + 2.0 * y + 3.0 * z; });
    const TransferFunction tf = clearTf(0, 90);
    double worst = 0.0, worstRef = 0.0;
    auto check = [&](const Camera& cam, int w, int h, double iso, double step, const char* what) {
        const Scene s = isoScene(cam, w, h, {{iso, {1, 1, 1, 1}}}, step);
        const ImageBuffer img = GridRenderer(computeContext(), v, tf, s).render();
        const ImageBuffer ref = referenceRender(v, tf, s, {.step = 1.0});
        int checked = 0;
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                const CameraRay ray = cameraRay(cam, w, h, x, y);
                const Vec3 g{1, 2, 3};
                const double tPlane = (iso - dot(g, ray.origin)) / dot(g, ray.direction);
                const Vec3 p = add(ray.origin, scale(ray.direction, tPlane));
                const bool inside =
                    p[0] >= 0 && p[0] <= 15 && p[1] >= 0 && p[1] <= 15 && p[2] >= 0 && p[2] <= 15;
                // Entering the box already on the far side (s >= iso at the entry) is no crossing.
                if (!inside || dot(g, ray.direction) < 0) continue;
                double t0 = -1e300; // box entry
                for (int a = 0; a < 3; ++a)
                    if (ray.direction[a] != 0.0)
                        t0 = std::max(t0, std::min((0.0 - ray.origin[a]) / ray.direction[a],
                                                   (15.0 - ray.origin[a]) / ray.direction[a]));
                if (tPlane <= t0 + 1e-9) continue;
                ++checked;
                const float depth = img.at(x, y, 4);
                ASSERT_TRUE(std::isfinite(depth)) << what << " " << x << "," << y;
                // Distance to the plane (the along-ray error of a grazing ray is that over the grazing
                // angle).
                const double dist =
                    std::abs(double(depth) - tPlane) * std::abs(dot(g, ray.direction)) / norm(g);
                worst = std::max(worst, dist);
                worstRef = std::max(worstRef, std::abs(double(ref.at(x, y, 4)) - tPlane));
                EXPECT_LT(dist, 1e-4) << what << " " << x << "," << y;
            }
        EXPECT_GT(checked, 0) << what;
    };
    // Orthographic rays along +z at integer x, y (faces and edges of cells); iso-values hit voxel values.
    for (double iso : {30.0, 42.0, 45.5})
        check(ortho({7.5, 7.5, -20}, {7.5, 7.5, 7.5}, 8.0), 8, 8, iso, 0.5, "along z");
    // Along x on the plane y = 5, z = 5 (a cell edge), iso equal to the voxel value at x = 3.
    check(ortho({-20, 5, 5}, {7.5, 5, 5}, 1e-3), 1, 1, 3.0 + 10.0 + 15.0, 0.7, "edge");
    // The main diagonal through the grid nodes (0,0,0), (1,1,1), ...: iso = 6 k sits on a node.
    for (double iso : {6.0, 48.0, 51.0})
        check(ortho({-10, -10, -10}, {15, 15, 15}, 1e-3), 1, 1, iso, 0.5, "diagonal");
    // Grazing: nearly parallel to the plane x + 2y + 3z = 40, direction (3, 0, -1 + eps) normalised.
    for (double eps : {1e-2, 1e-3}) {
        Camera g;
        // Enters the box at x = 0 where s = 40 - 5 eps: the crossing lies ~5.3 voxels further along the ray.
        g.target = {0.0, 2.0, (36.0 - 5.0 * eps) / 3.0};
        g.eye = {-30.0, 2.0, g.target[2] + 10.0 * (1.0 - eps)};
        g.height = 4e-3;
        check(g, 3, 3, 40.0, 0.5, "grazing");
    }
    RecordProperty("worst_distance_to_plane_voxels", std::to_string(worst));
    RecordProperty("reference_worst_along_ray_error", std::to_string(worstRef));
}

// (e) Iso-surfaces mixed into dvr, transparent layers in ray order, shading, skipping on and off: kernel vs
// reference.
TEST(RenderIso, MixedWithDvrAndShadedMatchReference) {
    const Dims n{36, 32, 30};
    const Volume v = makeFloatVolume(n, [](double x, double y, double z) {
        const double r =
            std::sqrt((x - 17.5) * (x - 17.5) + (y - 15.5) * (y - 15.5) + (z - 14.5) * (z - 14.5));
        return 100.0 - 3.0 * r + 3.0 * std::sin(0.7 * x);
    });
    TransferFunction tf;
    tf.domain = {0, 100};
    tf.color = {{0, {0.2, 0.4, 1.0}}, {100, {1.0, 0.8, 0.2}}};
    tf.extinction = {{0, 0.0}, {40, 0.0}, {55, 0.05}, {100, 0.2}};
    for (bool shaded : {false, true}) {
        ImageBuffer ref;
        for (bool skipping : {true, false}) {
            Scene s;
            Camera cam = ortho({-20, 60, -30}, {17.5, 15.5, 14.5}, 40.0);
            s.camera = cam;
            s.width = 40;
            s.height = 36;
            s.step = 0.5;
            s.earlyTermination = 1.0;
            s.skipping = skipping ? SkipMode::On : SkipMode::Off;
            s.effects.isosurfaces = {{60.0, {1, 0.3, 0.3, 0.4}}, {80.0, {0.3, 1, 0.3, 0.7}}};
            if (shaded) {
                Light l;
                l.kind = LightKind::Directional;
                l.vector = {0.3, -0.5, -0.8};
                s.lights = {l};
                s.effects.shading = true;
                s.effects.diffuse = 0.7;
                s.effects.specular = 0.2;
            }
            const ImageBuffer img = GridRenderer(computeContext(), v, tf, s).render();
            if (ref.pixels.empty())
                ref = referenceRender(v, tf, s, {.step = 0.05}); // skipping changes nothing
            const DepthComparison d = compareDepth(img, ref, v, cam);
            EXPECT_LT(d.worst, 1e-4) << shaded << skipping;
            EXPECT_EQ(d.onlyOne, 0);
            EXPECT_GT(d.both, 300);
            EXPECT_LT(imageRmse(img, ref), 2e-3) << shaded << skipping;
            RecordProperty(std::string("rmse_dvr_iso") + (shaded ? "_shaded" : "") +
                               (skipping ? "_skip" : ""),
                           std::to_string(imageRmse(img, ref)));
        }
    }
}

} // namespace
