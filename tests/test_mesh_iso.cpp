// Lit iso-surfaces of tetrahedral meshes: smooth vertex normals against a sphere's analytic normals, the cell
// caster's smooth shading against the reference, and the k-buffer's iso mode against its C++ mirror and the
// cell caster's iso mode (generated and shared meshes).
#include "MeshTestUtil.hpp"
#include "TestUtil.hpp"

#include "core/Error.hpp"
#include "host/mesh/MeshGenerator.hpp"
#include "host/mesh/MeshIo.hpp"
#include "render/CameraFraming.hpp"
#include "render/RenderInput.hpp"
#include "render/VecMath.hpp"
#include "render/mesh/KBufferReference.hpp"
#include "render/mesh/KBufferRenderer.hpp"
#include "render/mesh/MeshGeometry.hpp"
#include "render/mesh/MeshReference.hpp"
#include "render/mesh/VertexNormals.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <random>

using namespace volcl;

namespace {

constexpr double kPi = 3.14159265358979323846;
const Vec3 kSphereCentre{0.04, -0.03, 0.02};

/// The distance to kSphereCentre on a jitter-free n^3 hex grid of [-1, 1]^3 split into tets.
mesh::TetMesh sphereDistanceMesh(std::size_t n) {
    return mesh::generateHexGridMesh({n, n, n}, {-1, -1, -1}, {1, 1, 1}, [](double x, double y, double z) {
        return norm(sub({x, y, z}, kSphereCentre));
    });
}

double angleDeg(const Vec3& a, const Vec3& b) {
    const double c = dot(a, b) / (norm(a) * norm(b));
    return std::acos(std::clamp(c, -1.0, 1.0)) * 180.0 / kPi;
}

/// Iso mode of the scene's iso-surfaces with one directional light, orthographic three-quarter view.
Scene isoScene(const mesh::TetMesh& m, int w, int h, std::vector<IsoLayer> layers, bool smooth = true) {
    Scene s;
    s.width = w;
    s.height = h;
    s.mode = RenderMode::Iso;
    s.camera = frameBox(meshBounds(m), orbitDirection(35.0, 25.0), Projection::Orthographic, 30.0, 1.0);
    s.earlyTermination = 1.0;
    s.effects.isosurfaces = std::move(layers);
    s.effects.shading = true;
    s.effects.shadingGiven = true;
    s.effects.smoothNormals = smooth;
    s.lights = {{LightKind::Directional, {0.3, -0.5, -1}, {1, 1, 1}, 1.0}};
    return s;
}

/// Three transparent layers at the quartiles of the point values (skewed fields such as the blunt fin's density
/// put most of the range into a few points).
std::vector<IsoLayer> threeLayers(const mesh::TetMesh& m) {
    std::vector<float> v;
    for (float x : m.scalars)
        if (std::isfinite(x)) v.push_back(x);
    std::sort(v.begin(), v.end());
    const auto q = [&](double f) { return double(v[std::size_t(f * double(v.size() - 1))]); };
    return {
        {q(0.25), {1.0, 0.7, 0.4, 0.35}}, {q(0.5), {0.4, 0.9, 0.5, 0.3}}, {q(0.75), {0.4, 0.6, 1.0, 0.45}}};
}

TransferFunction anyTf(const mesh::TetMesh& m) {
    TransferFunction tf;
    tf.domain = {m.valueMin, m.valueMax > m.valueMin ? m.valueMax : m.valueMin + 1.0};
    tf.color = {{tf.domain[0], {1, 1, 1}}};
    tf.extinction = {{tf.domain[0], 1.0}};
    return tf;
}

ImageBuffer renderWith(const mesh::TetMesh& m, const TransferFunction& tf, Scene s, MeshMethod method,
                       int k = 6) {
    s.meshMethod = method;
    s.kBufferDepth = k;
    const RenderInput in = RenderInput::borrowMesh(m);
    return in.makeRenderer(test::computeContext(), tf, s)->render();
}

double meanAlpha(const ImageBuffer& img) {
    const std::size_t c = img.channels.size();
    double sum = 0;
    for (std::size_t p = 0; p < std::size_t(img.width) * img.height; ++p)
        sum += img.pixels[p * c + 3];
    return sum / double(img.width * img.height);
}

ImageBuffer mirrorIso(KBufferRenderer& r) {
    KBufferMirrorInput in = test::kbufferMirrorInputOf(r);
    in.iso = true;
    in.shading = r.plan().shading;
    in.isoParams = r.isoFrameParams();
    in.lighting = r.lightFrameParams();
    in.normals = &r.pointNormals();
    return kbufferMirrorRender(in);
}

} // namespace

TEST(VertexNormals, SmoothNormalsAreCloserToTheSphereThanFlat) {
    // A sphere's distance field on a 12^3-cell grid: the true normal at x is (x - c) / |x - c|. Flat shading takes
    // each tet's constant gradient, smooth the vertex normals interpolated at the point: at random points of the
    // tets between radius 0.25 and 0.95 the smooth normal must be nearer the true one on average and at worst.
    const mesh::TetMesh m = sphereDistanceMesh(12);
    const std::vector<Vec3> vn = vertexNormals(m);
    ASSERT_EQ(vn.size(), m.points.size());
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    double flatSum = 0, smoothSum = 0, flatMax = 0, smoothMax = 0;
    std::size_t n = 0;
    for (std::size_t t = 0; t < m.tets.size(); ++t) {
        const auto& v = m.tets[t];
        Vec3 centroid{0, 0, 0};
        for (auto p : v)
            centroid = add(centroid, scale(m.points[p], 0.25));
        const double r = norm(sub(centroid, kSphereCentre));
        if (r < 0.25 || r > 0.95) continue;
        const Vec3 flat = mesh_detail::tetField(m, t).gradient;
        const TetNormalField smooth = tetNormalField(m, vn, t);
        for (int k = 0; k < 4; ++k) {
            double w[4], sum = 0;
            for (double& x : w)
                sum += (x = -std::log(1.0 - uni(rng))); // uniform on the simplex
            Vec3 x{0, 0, 0};
            for (int i = 0; i < 4; ++i)
                x = add(x, scale(m.points[v[std::size_t(i)]], w[i] / sum));
            const Vec3 truth = sub(x, kSphereCentre);
            const double ef = angleDeg(flat, truth), es = angleDeg(smooth.at(x), truth);
            flatSum += ef;
            smoothSum += es;
            flatMax = std::max(flatMax, ef);
            smoothMax = std::max(smoothMax, es);
            ++n;
        }
    }
    ASSERT_GT(n, 1000u);
    std::cout << "sphere distance field, " << n << " points: mean angle to the true normal flat "
              << flatSum / double(n) << " deg, smooth " << smoothSum / double(n) << " deg; max flat "
              << flatMax << ", smooth " << smoothMax << '\n';
    EXPECT_LT(smoothSum, 0.5 * flatSum);
    EXPECT_LT(smoothMax, flatMax);
}

TEST(VertexNormals, LinearFieldKeepsItsGradientAndNanTetsAddNothing) {
    // A linear field: every tet's gradient is the same, so every vertex normal and every interpolated normal is
    // that gradient; a NaN vertex's tets are skipped, and their other vertices keep the finite tets' mean.
    mesh::TetMesh m = mesh::generateHexGridMesh(
        {3, 3, 3}, {0, 0, 0}, {1, 2, 3}, [](double x, double y, double z) { return 2.0 * x - y + 0.5 * z; });
    const Vec3 g{2.0, -1.0, 0.5};
    for (const Vec3& n : vertexNormals(m))
        EXPECT_LT(norm(sub(n, g)), 1e-6); // float scalars
    m.scalars[0] = NAN;
    const std::vector<Vec3> vn = vertexNormals(m);
    EXPECT_EQ(vn[0][0], 0.0);
    for (std::size_t i = 1; i < vn.size(); ++i)
        EXPECT_LT(norm(sub(vn[i], g)), 1e-6) << i;
    const TetNormalField f = tetNormalField(m, vn, m.tets.size() - 1);
    EXPECT_LT(norm(sub(f.at(m.points[m.tets.back()[2]]), g)), 1e-6);
}

TEST(MeshIsoSmooth, CellsMatchTheReferenceFlatAndSmooth) {
    // The cell caster's shading with smooth and flat normals against the double reference (the same rule), and
    // smooth against the analytic sphere: the lit sphere r = 0.6 of a distance field, whose exact image is a
    // ray-sphere hit lit with the true normal. Smooth normals must be closer to it than flat ones.
    const mesh::TetMesh m = sphereDistanceMesh(10);
    const TransferFunction tf = anyTf(m);
    const double radius = 0.6;
    for (bool smooth : {true, false}) {
        Scene s = isoScene(m, 48, 48, {{radius, {1.0, 0.8, 0.5, 1.0}}}, smooth);
        const ImageBuffer cells = renderWith(m, tf, s, MeshMethod::Cells);
        const ImageBuffer ref = RenderInput::borrowMesh(m).renderReference(tf, s);
        EXPECT_LE(imageRmse(cells, ref), 2e-3) << "smooth " << smooth;
    }
    // The analytic image: orthographic rays of the same camera, Blinn-Phong with the scene's coefficients.
    Scene s = isoScene(m, 64, 64, {{radius, {1.0, 0.8, 0.5, 1.0}}});
    const Camera& cam = *s.camera;
    const Vec3 f = normalized(sub(cam.target, cam.eye)), rt = normalized(cross(f, cam.up)), up = cross(rt, f);
    const Vec3 L = normalized(s.lights[0].vector);
    double errSmooth = 0, errFlat = 0;
    std::size_t hits = 0;
    const ImageBuffer smoothImg = renderWith(m, tf, s, MeshMethod::Cells);
    Scene fs = s;
    fs.effects.smoothNormals = false;
    const ImageBuffer flatImg = renderWith(m, tf, fs, MeshMethod::Cells);
    const std::size_t ch = smoothImg.channels.size();
    for (int y = 0; y < s.height; ++y)
        for (int x = 0; x < s.width; ++x) {
            const double ndcX = 2.0 * (x + 0.5) / s.width - 1.0, ndcY = 1.0 - 2.0 * (y + 0.5) / s.height;
            const Vec3 o =
                add(cam.eye, add(scale(rt, ndcX * cam.height / 2.0), scale(up, ndcY * cam.height / 2.0)));
            const Vec3 oc = sub(o, kSphereCentre);
            const double b = dot(oc, f), c = dot(oc, oc) - radius * radius, disc = b * b - c;
            // Pixels whose rays pass well inside the sphere's rim: the faceted surface covers them too.
            if (disc < 0.3 * radius * radius) continue;
            const Vec3 hit = add(o, scale(f, -b - std::sqrt(disc)));
            const Vec3 N = normalized(sub(hit, kSphereCentre));
            const Vec3 V = scale(f, -1.0), H = normalized(add(L, V));
            const double lum = s.effects.ambient + s.effects.diffuse * std::max(dot(N, L), 0.0);
            const double spec = s.effects.specular * std::pow(std::max(dot(N, H), 0.0), s.effects.shininess);
            const std::array<double, 3> base{1.0, 0.8, 0.5};
            const std::size_t p = (std::size_t(y) * s.width + x) * ch;
            for (int k = 0; k < 3; ++k) {
                const double truth = base[k] * lum + spec;
                errSmooth += std::pow(smoothImg.pixels[p + k] - truth, 2.0);
                errFlat += std::pow(flatImg.pixels[p + k] - truth, 2.0);
            }
            ++hits;
        }
    ASSERT_GT(hits, 200u);
    const double rmsSmooth = std::sqrt(errSmooth / (3.0 * hits)), rmsFlat = std::sqrt(errFlat / (3.0 * hits));
    std::cout << "lit sphere r = 0.6 on 10^3 cells, " << hits
              << " pixels against the analytic image: RMSE smooth " << rmsSmooth << ", flat " << rmsFlat
              << '\n';
    EXPECT_LT(rmsSmooth, 0.6 * rmsFlat);
}

TEST(KBufferIso, KernelMatchesMirror) {
    // Three transparent layers, shaded and unshaded, orthographic and perspective, k = 2 and 6, full and 40 %
    // level of detail, an 83 x 61 image (partial tiles): the kernel equals its C++ mirror.
    ComputeContext& cc = test::computeContext();
    const mesh::TetMesh m = mesh::marschnerLobbMesh(6);
    const TransferFunction tf = anyTf(m);
    int cases = 0;
    for (bool persp : {false, true})
        for (bool shaded : {true, false}) {
            Scene s = isoScene(m, 83, 61, threeLayers(m));
            if (persp) {
                s.camera =
                    frameBox(meshBounds(m), orbitDirection(-30.0, 20.0), Projection::Perspective, 40.0, 1.0);
                s.lights.push_back({LightKind::Point, {0.3, 1.5, -0.4}, {0.5, 0.5, 0.4}, 1.0});
                s.lights.push_back({LightKind::Head, {0, 0, 0}, {0.3, 0.3, 0.3}, 1.0});
            }
            s.effects.shading = shaded;
            KBufferRenderer r(cc, m, tf, s, 2);
            for (int k : {2, 6})
                for (double lod : {1.0, 0.4}) {
                    r.setK(k);
                    r.setLodFraction(lod);
                    const ImageBuffer dev = r.render();
                    const ImageBuffer ref = mirrorIso(r);
                    double d = 0;
                    for (std::size_t i = 0; i < dev.pixels.size(); ++i)
                        d = std::max(d, double(std::abs(dev.pixels[i] - ref.pixels[i])));
                    EXPECT_LE(d, 1e-4)
                        << "persp " << persp << " shaded " << shaded << " k " << k << " lod " << lod;
                    EXPECT_GT(meanAlpha(dev), 0.05);
                    ++cases;
                }
        }
    EXPECT_EQ(cases, 16);
}

TEST(KBufferIso, MatchesTheCellCasterOnAGeneratedMesh) {
    // The Marschner-Lobb mesh (24^3 cells) and a jitter-free sphere field: three lit transparent layers by the
    // k-buffer at k = 6 within 0.005 RMSE of the cell caster's iso mode (both with smooth normals).
    for (const mesh::TetMesh& m : {mesh::marschnerLobbMesh(24), sphereDistanceMesh(16)}) {
        const TransferFunction tf = anyTf(m);
        for (Projection proj : {Projection::Orthographic, Projection::Perspective}) {
            Scene s = isoScene(m, 96, 96, threeLayers(m));
            s.camera = frameBox(meshBounds(m), orbitDirection(35.0, 25.0), proj, 35.0, 1.0);
            const ImageBuffer cells = renderWith(m, tf, s, MeshMethod::Cells);
            const ImageBuffer kb = renderWith(m, tf, s, MeshMethod::KBuffer, 6);
            const double e = imageRmse(kb, cells);
            std::cout << m.tetCount() << " tets, "
                      << (proj == Projection::Perspective ? "perspective" : "ortho")
                      << ": k-buffer iso vs cells RMSE " << e << ", mean alpha " << meanAlpha(cells) << '\n';
            EXPECT_LE(e, 0.005);
            EXPECT_GT(meanAlpha(cells), 0.05);
        }
    }
}

TEST(KBufferIso, MatchesTheCellCasterOnTheSharedMeshes) {
    // Two sets of three lit layers: at 30, 50 and 70 % of the value range, and at the quartiles of the point
    // values, with the default face order and with the centroid sort. On the blunt fin the quartiles lie in the
    // boundary layer around the fin, whose slivers put fragments of the centroid order more than k places out
    // of order; an iso layer composited from a misordered pair is missed or doubled whole. The default there is
    // the convexified cell order (exact on the fin), which puts every fragment in ray order. On xsmall_turb
    // (overlapping face pairs: tets may overlap) the default is the centroid sort.
    std::filesystem::path data;
    VOLCL_REQUIRE_SHARED_DATA(data);
    const auto dir = data / "unstructured";
    if (!std::filesystem::is_directory(dir)) GTEST_SKIP() << dir << " is absent";
    int done = 0;
    for (const char* file : {"xsmall_turb.vtu", "bluntfinxyz.bin"}) {
        if (!std::filesystem::exists(dir / file)) continue;
        const mesh::TetMesh m = mesh::readMesh(dir / file);
        const TransferFunction tf = anyTf(m);
        const double lo = m.valueMin, hi = m.valueMax;
        const std::vector<IsoLayer> rangeLayers{{lo + 0.3 * (hi - lo), {1.0, 0.7, 0.4, 0.35}},
                                                {lo + 0.5 * (hi - lo), {0.4, 0.9, 0.5, 0.3}},
                                                {lo + 0.7 * (hi - lo), {0.4, 0.6, 1.0, 0.45}}};
        const bool fin = std::string(file) == "bluntfinxyz.bin";
        const std::vector<IsoLayer> layerSets[2] = {rangeLayers, threeLayers(m)};
        ImageBuffer cells[2];
        for (int q = 0; q < 2; ++q) {
            cells[q] = renderWith(m, tf, isoScene(m, 128, 128, layerSets[q]), MeshMethod::Cells);
            EXPECT_GT(meanAlpha(cells[q]), 0.01) << file;
        }
        // One renderer per order for every layer set and k: the cell sort's convexification is built once.
        const RenderInput in = RenderInput::borrowMesh(m);
        for (const bool centroid : {false, true}) {
            Scene s = isoScene(m, 128, 128, layerSets[0]);
            s.meshMethod = MeshMethod::KBuffer;
            if (centroid) s.meshSort = MeshSort::Centroid;
            const auto r = in.makeRenderer(test::computeContext(), tf, s);
            for (int q = 0; q < 2; ++q)
                for (int k : {6, 8}) {
                    s.effects.isosurfaces = layerSets[q];
                    s.kBufferDepth = k;
                    r->setScene(s);
                    const double e = imageRmse(r->render(), cells[q]);
                    const bool quartiles = q == 1;
                    std::cout << file << (quartiles ? " quartile" : " range") << " layers: k-buffer iso (k "
                              << k << ", " << (centroid ? "centroid sort" : "default order")
                              << ") vs cells RMSE " << e << ", mean alpha " << meanAlpha(cells[q]) << '\n';
                    // The goal (0.005) with the default order everywhere; the centroid sort misses it on the
                    // fin's boundary-layer quartiles, bounded there.
                    EXPECT_LE(e, centroid && fin && quartiles ? 0.04 : 0.005)
                        << file << " quartiles " << quartiles << " k " << k << " centroid " << centroid;
                }
        }
        ++done;
    }
    EXPECT_GT(done, 0);
}

TEST(KBufferIso, PlanSaysWhatItDraws) {
    const mesh::TetMesh m = mesh::marschnerLobbMesh(4);
    const TransferFunction tf = anyTf(m);
    Scene s = isoScene(m, 16, 16, threeLayers(m), false);
    s.effects.isosurfaces.push_back({1e9, {1, 1, 1, 1}}); // never crossed
    KBufferRenderer r(test::computeContext(), m, tf, s, 6);
    const EffectPlan p = r.planEffects(s);
    EXPECT_EQ(p.isosurfaces.size(), 3u);
    bool flat = false, outside = false;
    for (const auto& d : p.dropped) {
        flat |= d.find("normals \"flat\"") != std::string::npos;
        outside |= d.find("outside the data range") != std::string::npos;
    }
    EXPECT_TRUE(flat);
    EXPECT_TRUE(outside);
    Scene xray = s;
    xray.mode = RenderMode::Xray;
    EXPECT_THROW(r.planEffects(xray), UsageError);
}
