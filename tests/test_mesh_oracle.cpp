// Mesh renderers on non-convex jittered tet meshes against a brute-force float64 oracle that never walks the mesh.
#include "MeshTestMeshes.hpp"
#include "TestUtil.hpp"

#include "host/mesh/MeshGenerator.hpp"
#include "render/CameraFraming.hpp"
#include "render/Reference.hpp"
#include "render/RenderInput.hpp"
#include "render/mesh/MeshReference.hpp"
#include "render/mesh/VisibilityOracle.hpp"
#include "render/mesh/VisibilitySort.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <iostream>

using namespace volcl;

namespace {

using test::hashUnit;
using test::jitteredMesh;
using test::jitteredSoup;

/// The scalar at x by barycentric interpolation (sub-tet volumes) of tet t's vertex values.
double barycentricScalar(const mesh::TetMesh& m, std::size_t t, const Vec3& x) {
    const auto& v = m.tets[t];
    auto vol = [](const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3) {
        return dot(sub(p1, p0), cross(sub(p2, p0), sub(p3, p0)));
    };
    Vec3 p[4];
    for (int i = 0; i < 4; ++i)
        p[i] = m.points[v[i]];
    const double total = vol(p[0], p[1], p[2], p[3]);
    double s = 0.0;
    for (int i = 0; i < 4; ++i) {
        Vec3 q[4] = {p[0], p[1], p[2], p[3]};
        q[i] = x;
        s += vol(q[0], q[1], q[2], q[3]) / total * double(m.scalars[v[i]]);
    }
    return s;
}

/// Brute force: every tet is intersected with the ray; the union of the intervals is cut at every interval end;
/// each piece takes its scalar from a tet covering its midpoint (a ray lying in a shared face counts once) and
/// is integrated front to back by the midpoint rule on steps of at most `step` (emission tau * colour); with
/// `xray` the pixel is instead 1 - exp(-optical depth) in every channel.
ReferencePixel oraclePixel(const mesh::TetMesh& m, const TransferFunction& tf, const CameraRay& ray,
                           double step, bool xray = false) {
    struct Span {
        double t0, t1;
        std::size_t tet;
    };
    std::vector<Span> spans;
    std::vector<double> cuts;
    for (std::size_t t = 0; t < m.tets.size(); ++t) {
        double t0, t1;
        if (!tetRayInterval(m, t, ray.origin, ray.direction, t0, t1)) continue;
        t0 = std::max(t0, 0.0);
        if (!(t1 > t0)) continue;
        spans.push_back({t0, t1, t});
        cuts.push_back(t0);
        cuts.push_back(t1);
    }
    std::sort(cuts.begin(), cuts.end());
    Vec3 rgb{0, 0, 0};
    double T = 1.0, depth = 0.0;
    for (std::size_t k = 0; k + 1 < cuts.size(); ++k) {
        const double a = cuts[k], b = cuts[k + 1];
        if (!(b > a)) continue;
        const double mid = 0.5 * (a + b);
        const Span* cover = nullptr;
        for (const Span& sp : spans)
            if (sp.t0 <= mid && mid <= sp.t1) {
                cover = &sp;
                break;
            }
        if (!cover) continue; // a gap between two parts of the mesh
        // The field is linear inside a tet, so the piece's scalar is linear between its ends.
        const double sa = barycentricScalar(m, cover->tet, add(ray.origin, scale(ray.direction, a)));
        const double sb = barycentricScalar(m, cover->tet, add(ray.origin, scale(ray.direction, b)));
        const int n = std::max(1, int(std::ceil((b - a) / step)));
        const double h = (b - a) / n;
        for (int i = 0; i < n; ++i) {
            const double s = sa + (sb - sa) * (i + 0.5) / n;
            depth += tf.extinctionAt(s) * h;
            const double alpha = 1.0 - std::exp(-tf.extinctionAt(s) * h);
            const auto c = tf.colorAt(s);
            rgb = add(rgb, scale(Vec3{c[0], c[1], c[2]}, T * alpha));
            T *= 1.0 - alpha;
        }
    }
    const double inf = std::numeric_limits<double>::infinity();
    if (xray) {
        const double a = -std::expm1(-depth);
        return {a, a, a, a, inf};
    }
    return {rgb[0], rgb[1], rgb[2], 1.0 - T, inf};
}

ImageBuffer oracleRender(const mesh::TetMesh& m, const TransferFunction& tf, const Scene& s) {
    return traceReferenceImage(s, *s.camera, false, 0, [&](const CameraRay& ray) {
        return oraclePixel(m, tf, ray, 1e-3, s.mode == RenderMode::Xray);
    });
}

/// Ramp TF over the mesh's values, about `depth` optical lengths across the unit cube.
TransferFunction rampOver(const mesh::TetMesh& m, double depth) {
    const double lo = m.valueMin, hi = m.valueMax;
    TransferFunction tf;
    tf.domain = {lo, hi};
    tf.color = {{lo, {0.1, 0.2, 1.0}}, {0.5 * (lo + hi), {1.0, 0.6, 0.2}}, {hi, {1.0, 1.0, 0.9}}};
    tf.extinction = {{lo, 0.3 * depth}, {lo + 0.4 * (hi - lo), depth}, {hi, 0.5 * depth}};
    return tf;
}

double maxAbsDiff(const ImageBuffer& a, const ImageBuffer& b) {
    double e = 0.0;
    for (int y = 0; y < a.height; ++y)
        for (int x = 0; x < a.width; ++x)
            for (int ch = 0; ch < 4; ++ch)
                e = std::max(e, std::abs(double(a.at(x, y, ch)) - double(b.at(x, y, ch))));
    return e;
}

double meanAlpha(const ImageBuffer& img) {
    double sum = 0;
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x)
            sum += img.at(x, y, 3);
    return sum / double(img.width * img.height);
}

struct View {
    std::string name;
    Camera camera;
    /// The k-buffer starts at the faces in front of the camera: from inside the mesh it misses the first part.
    bool eyeInside = false;
};

/// Orthographic and perspective views framing `box` (the unit cube), plus the views a test adds.
std::vector<View> views(std::vector<View> extra, const WorldBox& box = WorldBox{{0, 0, 0}, {1, 1, 1}}) {
    std::vector<View> v{
        {"ortho oblique", frameBox(box, orbitDirection(35.0, 25.0), Projection::Orthographic, 30.0, 1.0)},
        {"persp oblique", frameBox(box, orbitDirection(-50.0, -20.0), Projection::Perspective, 40.0, 1.0)}};
    v.insert(v.end(), extra.begin(), extra.end());
    return v;
}

struct Errors {
    double rmse = 0.0, maxAbs = 0.0;
};

/// The cell caster's and the double reference's images against the oracle's, printed and checked: cells within
/// 0.002 RMSE and 0.005 per channel, the reference within 1e-4 RMSE and 1e-3 (`what` names the case in messages).
void checkCellsAndReference(const std::string& what, const ImageBuffer& oracle, const ImageBuffer& cells,
                            const ImageBuffer& ref) {
    const Errors ec{imageRmse(cells, oracle), maxAbsDiff(cells, oracle)};
    const Errors er{imageRmse(ref, oracle), maxAbsDiff(ref, oracle)};
    std::cout << what << ": cells RMSE " << ec.rmse << " max " << ec.maxAbs << "; reference RMSE " << er.rmse
              << " max " << er.maxAbs << '\n';
    EXPECT_LE(ec.rmse, 0.002) << what << ": cells";
    EXPECT_LE(ec.maxAbs, 0.005) << what << ": cells";
    EXPECT_LE(er.rmse, 1e-4) << what << ": reference";
    EXPECT_LE(er.maxAbs, 1e-3) << what << ": reference";
}

/// Renders every view with the cell caster, the double reference, the k-buffer (with the default face order, the
/// cells' visibility order, and with the centroid sort) and projected tetrahedra (the scene's default sort) and
/// checks them against the oracle: the cell caster (float, pre-integration table) within 0.002 RMSE and 0.005
/// per channel, the exact reference within 1e-4 RMSE and 1e-3, the k-buffer (its face-order approximation)
/// within 0.005 RMSE, pt within 0.002 RMSE. With `layered` (tets overlapping in many
/// places) the k-buffer and pt are not rendered: they composite every layer and count overlapping parts more
/// than once, which they do not promise otherwise.
void checkAgainstOracle(const std::string& name, const mesh::TetMesh& m, const std::vector<View>& vs,
                        bool layered = false) {
    const TransferFunction tf = rampOver(m, 3.0);
    const RenderInput in = RenderInput::borrowMesh(m);
    Scene s;
    s.width = s.height = 32;
    s.camera = vs.front().camera;
    s.earlyTermination = 1.0;
    s.preintegration = Preintegration::Table3d;
    s.tableLengths = 32;
    Scene ks = s;
    ks.meshMethod = MeshMethod::KBuffer;
    Scene kcs = ks;
    kcs.meshSort = MeshSort::Centroid;
    Scene ps = s;
    ps.meshMethod = MeshMethod::ProjectedTetrahedra;
    // One renderer of each kind for all views: a view change keeps the mesh and the table on the device.
    const auto cellsRenderer = in.makeRenderer(test::computeContext(), tf, s);
    const auto kbufferRenderer = layered ? nullptr : in.makeRenderer(test::computeContext(), tf, ks);
    const auto kbufferCentroid = layered ? nullptr : in.makeRenderer(test::computeContext(), tf, kcs);
    const auto ptRenderer = layered ? nullptr : in.makeRenderer(test::computeContext(), tf, ps);
    // Lit iso mode where the features meet these meshes (holes, re-entries, perspective): two transparent layers
    // by the k-buffer against the cell caster's iso mode, and the cell caster against the reference.
    Scene is = s;
    is.mode = RenderMode::Iso;
    is.effects.shading = true;
    is.effects.shadingGiven = true;
    is.lights = {{LightKind::Directional, {0.3, -0.5, -1}, {1, 1, 1}, 1.0}};
    const double lo = m.valueMin, hi = m.valueMax;
    is.effects.isosurfaces = {{lo + 0.4 * (hi - lo), {1.0, 0.7, 0.4, 0.4}},
                              {lo + 0.65 * (hi - lo), {0.4, 0.6, 1.0, 0.5}}};
    Scene kis = is;
    kis.meshMethod = MeshMethod::KBuffer;
    Scene kcis = kis;
    kcis.meshSort = MeshSort::Centroid;
    const auto cellsIso = in.makeRenderer(test::computeContext(), tf, is);
    const auto kbufferIso = layered ? nullptr : in.makeRenderer(test::computeContext(), tf, kis);
    const auto kbufferIsoCentroid = layered ? nullptr : in.makeRenderer(test::computeContext(), tf, kcis);
    double isoCoverage = 0.0; // the layers show in the views on average (an eye in a cavity may see none)
    for (const View& v : vs) {
        s.camera = v.camera;
        const ImageBuffer oracle = oracleRender(m, tf, s);
        ASSERT_GT(meanAlpha(oracle), 0.05) << name << " " << v.name;
        cellsRenderer->setView(v.camera, s.width, s.height, s.step);
        const ImageBuffer cells = cellsRenderer->render();
        checkCellsAndReference(name + ", " + v.name, oracle, cells, meshReferenceRender(m, tf, s));
        for (VolumeRenderer* kr : {kbufferRenderer.get(), kbufferCentroid.get()}) {
            if (!kr) continue;
            const std::string order = kr == kbufferCentroid.get() ? "centroid" : "default order";
            kr->setView(v.camera, s.width, s.height, s.step);
            const ImageBuffer kbuf = kr->render();
            const Errors ek{imageRmse(kbuf, oracle), maxAbsDiff(kbuf, oracle)};
            std::cout << name << ", " << v.name << ": kbuffer (" << order << ") RMSE " << ek.rmse << " max "
                      << ek.maxAbs << '\n';
            if (!v.eyeInside) EXPECT_LE(ek.rmse, 0.005) << name << ", " << v.name << ": kbuffer " << order;
        }
        is.camera = v.camera;
        cellsIso->setView(v.camera, s.width, s.height, s.step);
        const ImageBuffer ci = cellsIso->render();
        const double eir = imageRmse(ci, meshReferenceRender(m, tf, is));
        EXPECT_LE(eir, 0.002) << name << ", " << v.name << ": cells iso against the reference";
        isoCoverage += meanAlpha(ci);
        for (VolumeRenderer* kr : {kbufferIso.get(), kbufferIsoCentroid.get()}) {
            if (!kr || v.eyeInside) continue;
            const std::string order = kr == kbufferIsoCentroid.get() ? "centroid" : "default order";
            kr->setView(v.camera, s.width, s.height, s.step);
            const double eik = imageRmse(kr->render(), ci);
            std::cout << name << ", " << v.name << ": iso cells vs reference RMSE " << eir << ", k-buffer ("
                      << order << ") vs cells RMSE " << eik << '\n';
            EXPECT_LE(eik, 0.005) << name << ", " << v.name << ": k-buffer iso " << order;
        }
        if (ptRenderer) {
            ptRenderer->setView(v.camera, s.width, s.height, s.step);
            const ImageBuffer pt = ptRenderer->render();
            const Errors ep{imageRmse(pt, oracle), maxAbsDiff(pt, oracle)};
            std::cout << name << ", " << v.name << ": pt RMSE " << ep.rmse << " max " << ep.maxAbs << '\n';
            EXPECT_LE(ep.rmse, 0.002) << name << ", " << v.name << ": pt";
        }
    }
    EXPECT_GT(isoCoverage / double(vs.size()), 0.02) << name << ": the iso layers must show";
}

/// X-ray (1 - exp(-optical depth)) of the cell caster and the reference against the oracle: every covered part
/// of the ray once, whatever order its walks take. Tolerances as for dvr.
void checkXrayAgainstOracle(const std::string& name, const mesh::TetMesh& m, const std::vector<View>& vs) {
    const TransferFunction tf = rampOver(m, 3.0);
    Scene s;
    s.width = s.height = 32;
    s.camera = vs.front().camera;
    s.mode = RenderMode::Xray;
    const auto cellsRenderer = RenderInput::borrowMesh(m).makeRenderer(test::computeContext(), tf, s);
    for (const View& v : vs) {
        s.camera = v.camera;
        const ImageBuffer oracle = oracleRender(m, tf, s);
        ASSERT_GT(meanAlpha(oracle), 0.05) << name << " " << v.name;
        cellsRenderer->setView(v.camera, s.width, s.height, s.step);
        const ImageBuffer cells = cellsRenderer->render();
        checkCellsAndReference(name + " xray, " + v.name, oracle, cells, meshReferenceRender(m, tf, s));
    }
}

Camera lookAt(Vec3 eye, Vec3 target, Vec3 up, Projection p, double heightOrFov) {
    Camera c;
    c.eye = eye;
    c.target = target;
    c.up = up;
    c.projection = p;
    if (p == Projection::Orthographic)
        c.height = heightOrFov;
    else
        c.fovYDeg = heightOrFov;
    return c;
}

} // namespace

bool tunnelOrNotch(double x, double y, double z) {
    const bool tunnel = std::abs(x - 0.5) < 0.15 && std::abs(y - 0.5) < 0.15; // along z, 2 x 2 cells of 8
    const bool notch = x > 0.7 && y > 0.6 && z > 0.3 && z < 0.8;
    return tunnel || notch;
}

TEST(MeshOracle, TunnelAndNotch) {
    const mesh::TetMesh m = jitteredMesh(8, 0.2, false, tunnelOrNotch);
    // A conforming mesh: every point of the cube minus the cut-outs is in exactly one tet.
    ASSERT_EQ(m.repairs.invertedTets, 0u);
    checkAgainstOracle(
        "tunnel+notch", m,
        views({{"ortho across the tunnel",
                lookAt({-3.0, 0.47, 0.52}, {0.5, 0.5, 0.5}, {0, 0, 1}, Projection::Orthographic, 1.2)},
               {"grazing along the tunnel",
                lookAt({0.52, 0.46, -4.0}, {0.5, 0.5, 0.5}, {0, 1, 0}, Projection::Orthographic, 0.45)},
               {"in the plane of the cube's faces and the tunnel's rim",
                lookAt({0.375, 0.5, -4.0}, {0.375, 0.5, 0.5}, {0, 1, 0}, Projection::Orthographic, 1.1)},
               {"persp into the tunnel",
                lookAt({0.62, 0.4, -0.8}, {0.5, 0.5, 0.5}, {0, 1, 0}, Projection::Perspective, 35.0)},
               {"persp eye in the tunnel",
                lookAt({0.5, 0.5, 0.5}, {0.7, 0.6, 1.5}, {0, 1, 0}, Projection::Perspective, 60.0)},
               {"persp eye in the mesh",
                lookAt({0.2, 0.2, 0.3}, {0.5, 0.5, 1.5}, {0, 1, 0}, Projection::Perspective, 60.0), true}}));
}

TEST(MeshOracle, EnclosedCavity) {
    // A cavity of cells around the centre, closed on every side: rays leave into it and enter again.
    const mesh::TetMesh m = jitteredMesh(8, 0.2, false, [](double x, double y, double z) {
        return (x - 0.5) * (x - 0.5) + (y - 0.45) * (y - 0.45) + (z - 0.55) * (z - 0.55) < 0.09;
    });
    ASSERT_EQ(m.repairs.invertedTets, 0u);
    checkAgainstOracle(
        "cavity", m,
        views(
            {{"persp from near a corner",
              lookAt({1.6, 1.4, -0.9}, {0.5, 0.5, 0.5}, {0, 1, 0}, Projection::Perspective, 30.0)},
             {"persp eye in the cavity",
              lookAt({0.5, 0.45, 0.55}, {0.2, 0.3, 1.5}, {0, 1, 0}, Projection::Perspective, 70.0), true}}));
}

TEST(MeshOracle, CombExitsAndReentersManyTimes) {
    // A U-shape with a second slot (a comb of three prongs): rays along x leave and re-enter twice, rays
    // along z graze the prongs' walls.
    const mesh::TetMesh m = jitteredMesh(10, 0.25, false, [](double x, double y, double) {
        return y > 0.3 && ((x > 0.2 && x < 0.4) || (x > 0.6 && x < 0.8));
    });
    ASSERT_EQ(m.repairs.invertedTets, 0u);
    checkAgainstOracle("comb", m,
                       views({{"ortho through the prongs", lookAt({-3.0, 0.65, 0.5}, {0.5, 0.65, 0.5},
                                                                  {0, 1, 0}, Projection::Orthographic, 0.7)},
                              {"grazing along the walls", lookAt({0.41, 0.6, -4.0}, {0.39, 0.6, 0.5},
                                                                 {0, 1, 0}, Projection::Orthographic, 0.8)},
                              {"persp through the slots", lookAt({-1.5, 0.9, 0.2}, {0.5, 0.6, 0.5}, {0, 1, 0},
                                                                 Projection::Perspective, 35.0)}}));
}

TEST(MeshOracle, FoldedTetsAndBumpySurfaceFromManyDirections) {
    // Every point jittered by 0.3 cells, the cube's faces too: the outer surface is concave in places and a few
    // tets fold over, leaving overlapping faces as boundary faces inside the mesh. Rays leave through them
    // while still inside other tets; the renderers must count the covered part of the ray once, as the
    // oracle does. Eight directions spread over the sphere, orthographic and perspective in turn.
    const mesh::TetMesh m = jitteredMesh(8, 0.3, true, [](double x, double y, double z) {
        const bool comb = y < 0.25 && ((x > 0.1 && x < 0.3) || (x > 0.6 && x < 0.8));
        return tunnelOrNotch(x, y, z) || comb;
    });
    ASSERT_GT(m.repairs.overlappingFaces, 0u); // the case this test is about
    std::vector<View> vs;
    for (int i = 0; i < 8; ++i) {
        const double az = 360.0 * (0.5 + 0.5 * hashUnit(i, 7)), el = 80.0 * hashUnit(i, 8);
        vs.push_back({"direction " + std::to_string(i),
                      frameBox(WorldBox{{0, 0, 0}, {1, 1, 1}}, orbitDirection(az, el),
                               i % 2 ? Projection::Perspective : Projection::Orthographic, 40.0, 1.0)});
    }
    checkAgainstOracle("folded", m, vs);
}

/// Where the heavily folded meshes have cells removed: the tunnel and notch, a cavity around (0.3, 0.3, 0.6).
bool tunnelNotchOrCavity(double x, double y, double z) {
    const bool cavity = (x - 0.3) * (x - 0.3) + (y - 0.3) * (y - 0.3) + (z - 0.6) * (z - 0.6) < 0.02;
    return tunnelOrNotch(x, y, z) || cavity;
}

TEST(MeshOracle, HeavilyFoldedMeshes) {
    // Every point, the surface's too, jittered by 0.35 to 0.5 cell widths: tens of tets fold over, in layers
    // that overlap one another and the tunnel's, notch's and cavity's walls. A ray leaves one layer while inside
    // others and meets entries of further layers inside covered parts; the oracle counts the union once. 0.5 is
    // the largest jitter at which neighbouring points cannot pass one another along an axis. The field is linear,
    // so overlapping tets agree on it and the check is one of coverage alone.
    for (const double jitter : {0.35, 0.4, 0.45, 0.5}) {
        const mesh::TetMesh m = jitteredMesh(8, jitter, true, tunnelNotchOrCavity, true);
        std::cout << "jitter " << jitter << ": " << m.tets.size() << " tets, " << m.repairs.invertedTets
                  << " inverted, " << m.repairs.overlappingFaces << " overlapping faces\n";
        ASSERT_GE(m.repairs.invertedTets, jitter < 0.4 ? 5u : 20u); // the case this test is about
        checkAgainstOracle(
            "folded " + std::to_string(jitter), m,
            views({{"grazing along the tunnel",
                    lookAt({0.52, 0.46, -4.0}, {0.5, 0.5, 0.5}, {0, 1, 0}, Projection::Orthographic, 0.5)}}),
            true);
    }
}

TEST(MeshOracle, InterpenetratingComponents) {
    // Two blocks in one mesh file that share no face but overlap in a slab (and a third block wholly inside the
    // first): the mesh builder's repairs see nothing, every tet is valid, yet rays cross two components at
    // once. The caster renders the union, as the oracle does (a linear field: the blocks agree where they overlap).
    const auto keep = [](double, double, double) { return false; };
    mesh::TetSoup soup = jitteredSoup({5, 5, 8}, {0, 0, 0}, {0.62, 0.62, 1}, 0.2, false, keep, 1, true);
    const auto append = [&soup](const mesh::TetSoup& part) {
        const auto base = std::uint32_t(soup.points.size());
        soup.points.insert(soup.points.end(), part.points.begin(), part.points.end());
        soup.scalars.insert(soup.scalars.end(), part.scalars.begin(), part.scalars.end());
        for (auto t : part.tets) {
            for (auto& v : t)
                v += base;
            soup.tets.push_back(t);
        }
    };
    append(jitteredSoup({5, 5, 6}, {0.41, 0.38, 0.1}, {1, 1, 0.9}, 0.2, false, keep, 2, true));
    append(jitteredSoup({2, 2, 2}, {0.1, 0.1, 0.2}, {0.3, 0.3, 0.4}, 0.1, false, keep, 3, true));
    const mesh::TetMesh m = mesh::buildTetMesh(std::move(soup), "interpenetrating", "f");
    ASSERT_EQ(m.repairs.invertedTets + m.repairs.overlappingFaces + m.repairs.nonManifoldFaces, 0u);
    checkAgainstOracle(
        "interpenetrating", m,
        views({{"ortho through the overlap",
                lookAt({0.5, -3.0, 0.5}, {0.5, 0.5, 0.5}, {0, 0, 1}, Projection::Orthographic, 1.2)},
               {"persp eye in both blocks",
                lookAt({0.5, 0.5, 0.5}, {0.2, 0.3, 1.5}, {0, 1, 0}, Projection::Perspective, 60.0), true}}),
        true);
    checkXrayAgainstOracle("interpenetrating", m,
                           {{"persp eye in both blocks", lookAt({0.5, 0.5, 0.5}, {0.2, 0.3, 1.5}, {0, 1, 0},
                                                                Projection::Perspective, 60.0)},
                            {"ortho through the overlap", lookAt({0.5, -3.0, 0.5}, {0.5, 0.5, 0.5}, {0, 0, 1},
                                                                 Projection::Orthographic, 1.2)}});
}

TEST(MeshOracle, AnisotropicBoxWithTunnelAlongX) {
    // A mesh none of the above resembles: 7 x 9 x 6 cells on a 1.3 x 0.8 x 0.6 box (cells of three shapes), its
    // own jitter seed, folded (0.42 cell widths), a tunnel along x, a slot from the top and a pocket in a side.
    // The field is not linear: where tets overlap the oracle and the renderers may take different tets' values.
    const auto removed = [](double x, double y, double z) {
        const bool tunnel = std::abs(y - 0.4) < 0.14 && std::abs(z - 0.3) < 0.12;
        const bool slot = x > 0.55 && x < 0.8 && y > 0.5;
        const bool pocket = x > 1.0 && z < 0.2 && y < 0.5;
        return tunnel || slot || pocket;
    };
    const Vec3 hi{1.3, 0.8, 0.6};
    const mesh::TetMesh m = mesh::buildTetMesh(jitteredSoup({7, 9, 6}, {0, 0, 0}, hi, 0.42, true, removed, 5),
                                               "anisotropic", "f");
    ASSERT_GT(m.repairs.invertedTets, 5u);
    const WorldBox box{{0, 0, 0}, hi};
    checkAgainstOracle("anisotropic", m,
                       views({{"grazing along the tunnel", lookAt({-4.0, 0.41, 0.31}, {0.65, 0.4, 0.3},
                                                                  {0, 0, 1}, Projection::Orthographic, 0.5)},
                              {"persp into the slot", lookAt({0.7, 1.8, 0.9}, {0.65, 0.4, 0.3}, {0, 0, 1},
                                                             Projection::Perspective, 40.0)}},
                             box),
                       true);
}

// ---- NaN cells: a tet with a NaN or +-Inf vertex value takes the NaN colour (docs/rendering.md, "NaN and Inf").

namespace {

/// Whether tet t has a vertex value that is not finite (the oracle's own test, not the renderers').
bool oracleNanTet(const mesh::TetMesh& m, std::size_t t) {
    for (auto v : m.tets[t])
        if (!std::isfinite(m.scalars[v])) return true;
    return false;
}

/// Fine-step point sampling of the documented rule: samples at the midpoints of steps of `step` along the ray
/// from its first tet on; each takes the tet that holds it (every tet intersected with the ray, no walk): in a
/// NaN tet it is a sample of the NaN colour (rgb, extinction nanTau) in dvr and ignored by mip and x-ray,
/// elsewhere the barycentric scalar through the TF. mip returns grey max(s) over the window of the mesh's
/// finite values (MIP_COLOR grey).
ReferencePixel nanOraclePixel(const mesh::TetMesh& m, const TransferFunction& tf, const Vec3& nanRgb,
                              double nanTau, RenderMode mode, const CameraRay& ray, double step) {
    struct Span {
        double t0, t1;
        std::size_t tet;
    };
    std::vector<Span> spans;
    for (std::size_t t = 0; t < m.tets.size(); ++t) {
        double t0, t1;
        if (tetRayInterval(m, t, ray.origin, ray.direction, t0, t1) && t1 > std::max(t0, 0.0))
            spans.push_back({std::max(t0, 0.0), t1, t});
    }
    const double inf = std::numeric_limits<double>::infinity();
    if (spans.empty()) return {0, 0, 0, 0, inf};
    std::sort(spans.begin(), spans.end(), [](const Span& a, const Span& b) { return a.t0 < b.t0; });
    double tEnd = 0.0;
    for (const Span& sp : spans)
        tEnd = std::max(tEnd, sp.t1);
    Vec3 rgb{0, 0, 0};
    double T = 1.0, depth = 0.0, mip = -inf;
    std::size_t first = 0;
    for (double t = spans.front().t0 + 0.5 * step; t < tEnd; t += step) {
        while (first < spans.size() && spans[first].t1 < t)
            ++first;
        const Span* cover = nullptr;
        for (std::size_t k = first; k < spans.size() && spans[k].t0 <= t; ++k)
            if (spans[k].t1 >= t) {
                cover = &spans[k];
                break;
            }
        if (!cover) continue;
        Vec3 c;
        double tau;
        if (oracleNanTet(m, cover->tet)) {
            if (mode != RenderMode::Dvr) continue;
            c = nanRgb;
            tau = nanTau;
        } else {
            const double s = barycentricScalar(m, cover->tet, add(ray.origin, scale(ray.direction, t)));
            mip = std::max(mip, s);
            const auto col = tf.colorAt(s);
            c = {col[0], col[1], col[2]};
            tau = tf.extinctionAt(s);
        }
        depth += tau * step;
        const double alpha = 1.0 - std::exp(-tau * step);
        rgb = add(rgb, scale(c, T * alpha));
        T *= 1.0 - alpha;
    }
    if (mode == RenderMode::Xray) {
        const double a = -std::expm1(-depth);
        return {a, a, a, a, inf};
    }
    if (mode == RenderMode::Mip) {
        if (mip == -inf) return {0, 0, 0, 0, inf};
        const double g = std::clamp((mip - m.valueMin) / (double(m.valueMax) - m.valueMin), 0.0, 1.0);
        return {g, g, g, g, inf};
    }
    return {rgb[0], rgb[1], rgb[2], 1.0 - T, inf};
}

/// A 6^3-cell jittered cube whose points within 0.22 of (0.55, 0.45, 0.5) are NaN, with one +Inf and one -Inf
/// point elsewhere, all inside the cube (rays enter through finite tets). `dropNan`: the same mesh without the
/// tets that touch a non-finite value.
mesh::TetMesh meshWithNanCells(bool dropNan) {
    mesh::TetSoup soup = jitteredSoup(
        {6, 6, 6}, {0, 0, 0}, {1, 1, 1}, 0.2, false, [](double, double, double) { return false; }, 7);
    auto nearest = [&](const Vec3& q) {
        std::size_t best = 0;
        for (std::size_t i = 1; i < soup.points.size(); ++i)
            if (norm(sub(soup.points[i], q)) < norm(sub(soup.points[best], q))) best = i;
        return best;
    };
    for (std::size_t i = 0; i < soup.points.size(); ++i)
        if (norm(sub(soup.points[i], Vec3{0.55, 0.45, 0.5})) < 0.22) soup.scalars[i] = NAN;
    soup.scalars[nearest({0.3, 0.7, 0.7})] = INFINITY;
    soup.scalars[nearest({0.7, 0.3, 0.3})] = -INFINITY;
    if (dropNan) {
        std::vector<mesh::Tet> kept;
        for (const auto& t : soup.tets)
            if (std::all_of(t.begin(), t.end(),
                            [&](std::uint32_t v) { return std::isfinite(soup.scalars[v]); }))
                kept.push_back(t);
        soup.tets = std::move(kept);
    }
    return mesh::buildTetMesh(std::move(soup), dropNan ? "without NaN cells" : "NaN cells", "f");
}

Scene nanScene(RenderMode mode) {
    Scene s;
    s.width = s.height = 32;
    s.mode = mode;
    s.earlyTermination = 1.0;
    s.preintegration = mode == RenderMode::Dvr ? Preintegration::Table3d : Preintegration::None;
    s.tableLengths = 32;
    return s;
}

} // namespace

TEST(MeshNan, CellsKBufferAndReferenceMatchPointSamplingOfTheRule) {
    const mesh::TetMesh m = meshWithNanCells(false);
    std::size_t nanTets = 0;
    for (std::size_t t = 0; t < m.tets.size(); ++t)
        nanTets += oracleNanTet(m, t) ? 1 : 0;
    ASSERT_GT(nanTets, 40u);
    const TransferFunction tf = rampOver(m, 3.0);
    const Vec3 nanRgb{1.0, 0.1, 0.9};
    const double nanAlpha = 0.9, nanTau = -std::log1p(-nanAlpha);
    const RenderInput in = RenderInput::borrowMesh(m);
    for (RenderMode mode : {RenderMode::Dvr, RenderMode::Xray}) { // mip: the next test (a closed form)
        Scene s = nanScene(mode);
        s.nanColor = {nanRgb[0], nanRgb[1], nanRgb[2], nanAlpha};
        s.camera = views({}).front().camera;
        Scene sampled = s; // the cell caster's point sampling
        sampled.preintegration = Preintegration::None;
        sampled.step = 0.004;
        Scene ks = s;
        ks.meshMethod = MeshMethod::KBuffer;
        const auto cells = in.makeRenderer(test::computeContext(), tf, s);
        EXPECT_NE(cells->plan().defines.toOptions().find("-DNAN_COLOR"), std::string::npos);
        const auto cellsSampled =
            mode == RenderMode::Dvr ? in.makeRenderer(test::computeContext(), tf, sampled) : nullptr;
        const auto kbuffer =
            mode == RenderMode::Dvr ? in.makeRenderer(test::computeContext(), tf, ks) : nullptr;
        Scene ps = s;
        ps.meshMethod = MeshMethod::ProjectedTetrahedra;
        const auto pt = mode == RenderMode::Dvr ? in.makeRenderer(test::computeContext(), tf, ps) : nullptr;
        for (const View& v : views({})) {
            s.camera = v.camera;
            const std::string what = std::string(renderModeName(mode)) + ", " + v.name;
            const ImageBuffer oracle = traceReferenceImage(s, *s.camera, false, 0, [&](const CameraRay& ray) {
                return nanOraclePixel(m, tf, nanRgb, nanTau, mode, ray, 2e-3);
            });
            ASSERT_GT(meanAlpha(oracle), 0.05) << what;
            auto check = [&](const std::string& who, const ImageBuffer& img, double tol) {
                const double rmse = imageRmse(img, oracle);
                std::cout << what << ": " << who << " RMSE " << rmse << " max " << maxAbsDiff(img, oracle)
                          << '\n';
                EXPECT_LE(rmse, tol) << what << ": " << who;
            };
            check("reference", meshReferenceRender(m, tf, s), 2e-3);
            cells->setView(v.camera, s.width, s.height, s.step);
            check("cells", cells->render(), 3e-3);
            if (cellsSampled) {
                cellsSampled->setView(v.camera, s.width, s.height, sampled.step);
                check("cells point-sampled", cellsSampled->render(), 3e-3);
            }
            if (kbuffer) {
                kbuffer->setView(v.camera, s.width, s.height, s.step);
                check("kbuffer", kbuffer->render(), 3e-3);
            }
            if (pt) {
                pt->setView(v.camera, s.width, s.height, s.step);
                check("pt", pt->render(), 3e-3);
            }
        }
    }
}

TEST(MeshNan, TransparentNanColourDrawsTheMeshWithoutItsNanCells) {
    // dvr with the default (transparent) NaN colour, and mip, x-ray and iso with an opaque one (they ignore it): the
    // images of the mesh with NaN cells are those of the mesh with its NaN cells removed.
    const mesh::TetMesh m = meshWithNanCells(false), without = meshWithNanCells(true);
    ASSERT_LT(without.tets.size(), m.tets.size());
    const TransferFunction tf = rampOver(m, 3.0);
    for (RenderMode mode : {RenderMode::Dvr, RenderMode::Xray, RenderMode::Mip, RenderMode::Iso})
        for (int method = 0; method < (mode == RenderMode::Dvr ? 4 : 1); ++method) {
            Scene s = nanScene(mode);
            s.camera = views({}).front().camera;
            if (mode != RenderMode::Dvr) s.nanColor = {1, 0, 1, 1};
            if (mode == RenderMode::Iso)
                s.effects.isosurfaces = {{0.5 * (m.valueMin + m.valueMax), {1, 0.8, 0.6, 0.7}}};
            if (method == 1) {
                s.preintegration = Preintegration::None;
                s.step = 0.004;
            }
            // k-buffer and pt: the same order of the shared cells in both meshes. Removing the NaN cells leaves a
            // cavity, whose convexified order (auxiliary cells over a bumpy wall) misplaces a few faces in
            // perspective where the full mesh's order does not (7 out-of-order pops at k = 2).
            if (method == 2) {
                s.meshMethod = MeshMethod::KBuffer;
                s.meshSort = MeshSort::Centroid;
            }
            if (method == 3) {
                s.meshMethod = MeshMethod::ProjectedTetrahedra;
                s.meshSort = MeshSort::Centroid;
            }
            if (mode == RenderMode::Mip) // both meshes' finite value ranges differ: one window for both
                s.window = std::array<double, 2>{0.5 * (m.valueMin + m.valueMax), m.valueMax - m.valueMin};
            const auto ra = RenderInput::borrowMesh(m).makeRenderer(test::computeContext(), tf, s);
            const auto rb = RenderInput::borrowMesh(without).makeRenderer(test::computeContext(), tf, s);
            for (const View& v : views({})) {
                s.camera = v.camera;
                const std::string what =
                    std::string(renderModeName(mode)) + " method " + std::to_string(method) + ", " + v.name;
                ra->setView(v.camera, s.width, s.height, s.step);
                rb->setView(v.camera, s.width, s.height, s.step);
                const ImageBuffer a = ra->render(), b = rb->render();
                ASSERT_GT(meanAlpha(b), 0.05) << what;
                std::cout << what << ": max difference " << maxAbsDiff(a, b) << '\n';
                EXPECT_LE(maxAbsDiff(a, b), 1e-5) << what;
                if (method == 0)
                    EXPECT_LE(maxAbsDiff(meshReferenceRender(m, tf, s), meshReferenceRender(without, tf, s)),
                              1e-9)
                        << what << ": reference";
            }
        }
}

TEST(MeshNan, FiniteMeshCompilesNoNanTestAndIgnoresTheNanColour) {
    const mesh::TetMesh m = jitteredMesh(6, 0.2, false, [](double, double, double) { return false; });
    const TransferFunction tf = rampOver(m, 3.0);
    for (int method = 0; method < 4; ++method) {
        Scene s = nanScene(RenderMode::Dvr);
        s.camera = views({}).front().camera;
        if (method == 1) s.preintegration = Preintegration::None;
        if (method == 2) s.meshMethod = MeshMethod::KBuffer;
        if (method == 3) s.meshMethod = MeshMethod::ProjectedTetrahedra;
        Scene magenta = s;
        magenta.nanColor = {1, 0, 1, 1};
        const auto r = RenderInput::borrowMesh(m).makeRenderer(test::computeContext(), tf, magenta);
        EXPECT_EQ(r->plan().defines.toOptions().find("NAN"), std::string::npos) << method;
        const ImageBuffer a = r->render();
        const ImageBuffer b =
            RenderInput::borrowMesh(m).makeRenderer(test::computeContext(), tf, s)->render();
        EXPECT_EQ(maxAbsDiff(a, b), 0.0) << method;
    }
}
