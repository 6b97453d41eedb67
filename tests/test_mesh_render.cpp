// Tetrahedral mesh rendering: the exact double reference against analytic integrals and the grid reference,
// the OpenCL cell ray caster against the reference, and the hard cases (edges, vertices, holes, scales).
#include "TestUtil.hpp"

#include "core/Error.hpp"
#include "host/mesh/MeshGenerator.hpp"
#include "host/mesh/MeshIo.hpp"
#include "render/CameraFraming.hpp"
#include "render/RenderInput.hpp"
#include "render/grid/GridRenderer.hpp"
#include "render/mesh/MeshGeometry.hpp"
#include "render/mesh/MeshReference.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>

using namespace volcl;

namespace {

TransferFunction rampTf(double lo, double hi, double tauMax) {
    TransferFunction tf;
    tf.domain = {lo, hi};
    tf.color = {{lo, {0.1, 0.2, 1.0}}, {0.5 * (lo + hi), {1.0, 0.6, 0.2}}, {hi, {1.0, 1.0, 0.9}}};
    tf.extinction = {{lo, 0.0},
                     {lo + 0.2 * (hi - lo), 0.1 * tauMax},
                     {0.7 * (lo + hi) * 0.5 + 0.3 * hi, tauMax},
                     {hi, 0.3 * tauMax}};
    return tf;
}

TransferFunction constantTf(double tau, std::array<double, 3> rgb) {
    TransferFunction tf;
    tf.domain = {0.0, 1.0};
    tf.color = {{0.0, rgb}};
    tf.extinction = {{0.0, tau}};
    return tf;
}

/// Orthographic scene looking along +z at the box [lo, hi] (slightly wider than the box).
Scene boxScene(mesh::Point3 lo, mesh::Point3 hi, int w, int h) {
    Scene s;
    Camera c;
    c.target = {0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2])};
    c.eye = {c.target[0], c.target[1], lo[2] - 2.0 * (hi[2] - lo[2]) - 1.0};
    c.height = 1.1 * std::max(hi[0] - lo[0], hi[1] - lo[1]);
    s.camera = c;
    s.width = w;
    s.height = h;
    s.earlyTermination = 1.0;
    return s;
}

/// A hex-grid box with the cells of the middle column (in x and y, all z) removed: a square hole along z.
mesh::TetMesh boxWithHole(std::size_t n, double scalar) {
    mesh::TetMesh full = mesh::generateHexGridMesh({n, n, n}, {0, 0, 0}, {1, 1, 1},
                                                   [&](double, double, double) { return scalar; });
    mesh::TetSoup soup;
    soup.points = full.points;
    soup.scalars = full.scalars;
    const double h = 1.0 / double(n);
    for (const auto& t : full.tets) {
        double cx = 0, cy = 0;
        for (auto v : t) {
            cx += 0.25 * full.points[v][0];
            cy += 0.25 * full.points[v][1];
        }
        const bool hole = std::abs(cx - 0.5) < h && std::abs(cy - 0.5) < h;
        if (!hole) soup.tets.push_back(t);
    }
    return mesh::buildTetMesh(std::move(soup), "box with hole", "f");
}

} // namespace

TEST(MeshReference, ConstantBoxMatchesTheAnalyticIntegral) {
    const mesh::TetMesh m = mesh::generateHexGridMesh({3, 3, 3}, {0, 0, 0}, {1, 1, 2},
                                                      [](double, double, double) { return 0.5; });
    const TransferFunction tf = constantTf(0.8, {1.0, 0.5, 0.25});
    Scene s = boxScene({0, 0, 0}, {1, 1, 2}, 16, 16);
    s.camera->height = 0.9; // every ray inside the box
    const ImageBuffer img = meshReferenceRender(m, tf, s);
    const double a = 1.0 - std::exp(-0.8 * 2.0);
    for (int y = 0; y < 16; ++y)
        for (int x = 0; x < 16; ++x) {
            EXPECT_NEAR(img.at(x, y, 3), a, 1e-6) << x << "," << y;
            EXPECT_NEAR(img.at(x, y, 0), a, 1e-6);
            EXPECT_NEAR(img.at(x, y, 1), 0.5 * a, 1e-6);
        }
}

TEST(MeshReference, LinearFieldAgreesWithTheGridReference) {
    // A linear field is reproduced exactly by both the trilinear grid and the tets, so the exact mesh
    // integral and the grid's fine midpoint rule must agree.
    auto f = [](double x, double y, double z) { return 10.0 + 40.0 * x + 25.0 * y + 60.0 * z; };
    const mesh::TetMesh m = mesh::generateHexGridMesh({4, 4, 4}, {0, 0, 0}, {4, 4, 4}, f);
    const Volume v = test::makeFloatVolume({5, 5, 5}, f);
    const TransferFunction tf = rampTf(10.0, 510.0, 0.6);
    Scene s = test::orthoScene({5, 5, 5}, 5.0, 24, 24);
    s.camera->eye = {1.7, 2.2, -30.0}; // off-axis: rays cross tets obliquely
    s.camera->target = {2.0, 2.0, 2.0};
    ReferenceOptions o;
    o.step = 0.002;
    const ImageBuffer grid = referenceRender(v, tf, s, o);
    const ImageBuffer mesh = meshReferenceRender(m, tf, s);
    EXPECT_LT(imageRmse(grid, mesh), 2e-5);
    double sum = 0;
    for (float p : mesh.pixels)
        sum += p;
    EXPECT_GT(sum, 10.0); // not an empty image
}

TEST(MeshReference, NonConvexMeshIntegratesOnlyTheInside) {
    // Hole of 2 x 2 cells of 1/8 in the middle of the unit cube; rays along the edges of the hole.
    const mesh::TetMesh m = boxWithHole(8, 0.5);
    const TransferFunction tf = constantTf(1.5, {1, 1, 1});
    Scene s = boxScene({0, 0, 0}, {1, 1, 1}, 32, 32);
    s.camera->height = 1.0;
    s.camera->up = {0, 1, 0};
    const ImageBuffer img = meshReferenceRender(m, tf, s);
    // Looking along +z: pixels over the hole are empty, the others see length 1.
    const double a = 1.0 - std::exp(-1.5);
    for (int y = 0; y < 32; ++y)
        for (int x = 0; x < 32; ++x) {
            const double wx = (x + 0.5) / 32.0, wy = 1.0 - (y + 0.5) / 32.0;
            // Camera right = cross(f, up) = cross(+z, +y) = -x: image x runs toward -x.
            const double px = 1.0 - wx;
            const bool hole = std::abs(px - 0.5) < 0.125 && std::abs(wy - 0.5) < 0.125;
            EXPECT_NEAR(img.at(x, y, 3), hole ? 0.0 : a, 1e-6) << x << "," << y;
        }
    // Looking along +x through the hole: the ray leaves and re-enters; inside length 1 - 0.25.
    Scene side = s;
    side.camera->eye = {-3.0, 0.5, 0.5};
    side.camera->target = {0.5, 0.5, 0.5};
    side.camera->up = {0, 0, 1};
    side.camera->height = 0.2; // all rays through the hole's square cross-section
    const ImageBuffer si = meshReferenceRender(m, tf, side);
    const double a2 = 1.0 - std::exp(-1.5 * 0.75);
    for (int y = 0; y < 32; ++y)
        for (int x = 0; x < 32; ++x)
            EXPECT_NEAR(si.at(x, y, 3), a2, 1e-6) << x << "," << y;
}

namespace {

/// Renders with the cell ray caster and the reference; returns the RGBA RMSE.
double cellsVsReference(const mesh::TetMesh& m, const TransferFunction& tf, const Scene& s,
                        ImageBuffer* gpuOut = nullptr, ImageBuffer* refOut = nullptr) {
    const RenderInput in = RenderInput::borrowMesh(m);
    auto r = in.makeRenderer(test::computeContext(), tf, s);
    const ImageBuffer gpu = r->render();
    const ImageBuffer ref = in.renderReference(tf, s);
    if (gpuOut) *gpuOut = gpu;
    if (refOut) *refOut = ref;
    return imageRmse(gpu, ref);
}

/// Mean of the alpha channel: guards against comparing two empty images.
double meanAlpha(const ImageBuffer& img) {
    double sum = 0;
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x)
            sum += img.at(x, y, 3);
    return sum / double(img.width * img.height);
}

Scene preintegrated(Scene s) {
    s.preintegration = Preintegration::Table3d;
    s.tableLengths = 32;
    return s;
}

} // namespace

TEST(MeshGeometry, HullFacesAreTheOuterFacesOfANonConvexMesh) {
    // A ray leaving through a hull face is done; the faces around the hole must not say so.
    const mesh::TetMesh m = boxWithHole(8, 0.5);
    const mesh_detail::BoundaryBvh bvh = mesh_detail::buildBoundaryBvh(m);
    const std::vector<std::uint8_t> hull = mesh_detail::hullFaces(m, bvh);
    ASSERT_EQ(hull.size(), bvh.faces.size());
    std::size_t outer = 0, inner = 0;
    for (std::size_t i = 0; i < bvh.faces.size(); ++i) {
        const auto v = m.faceVertices(bvh.faces[i]);
        bool onCube = false;
        for (int a = 0; a < 3; ++a) {
            const double c = m.points[v[0]][a];
            onCube |= (c == 0.0 || c == 1.0) && m.points[v[1]][a] == c && m.points[v[2]][a] == c;
        }
        EXPECT_EQ(hull[i], onCube ? 1 : 0) << "face " << bvh.faces[i];
        (onCube ? outer : inner) += 1;
    }
    EXPECT_EQ(outer, 6u * 8u * 8u * 2u - 2u * 2u * 2u * 2u); // the cube's faces less the hole's two openings
    EXPECT_EQ(inner, 4u * 2u * 8u * 2u);                     // four walls of 2 x 8 quads
}

TEST(MeshCells, LinearFieldMatchesTheReference) {
    auto f = [](double x, double y, double z) { return 10.0 + 40.0 * x + 25.0 * y + 60.0 * z; };
    const mesh::TetMesh m = mesh::generateHexGridMesh({4, 4, 4}, {0, 0, 0}, {4, 4, 4}, f);
    const TransferFunction tf = rampTf(10.0, 510.0, 0.6);
    Scene s = test::orthoScene({5, 5, 5}, 5.0, 32, 32);
    s.camera->eye = {1.7, 2.2, -30.0};
    s.camera->target = {2.0, 2.0, 2.0};
    ImageBuffer gpu, ref;
    const double e = cellsVsReference(m, tf, preintegrated(s), &gpu, &ref);
    EXPECT_LT(e, 0.002);
    double sum = 0;
    for (float p : ref.pixels)
        sum += p;
    EXPECT_GT(sum, 10.0);
}

namespace {

/// Ramp TF over the mesh's value range with extinction scaled so the mesh is about `depth` optical
/// lengths thick across its box diagonal.
TransferFunction meshTf(const mesh::TetMesh& m, double depth) {
    const double lo = m.valueMin, hi = m.valueMax > m.valueMin ? m.valueMax : m.valueMin + 1.0;
    const double diag = norm(sub(m.boundsMax, m.boundsMin));
    return rampTf(lo, hi, depth / diag);
}

/// Default camera (the box framed along +z) at w x h, no early termination.
Scene meshScene(const mesh::TetMesh& m, int w, int h) {
    Scene s;
    s.width = w;
    s.height = h;
    s.camera = defaultCamera(meshBounds(m));
    s.earlyTermination = 1.0;
    return preintegrated(s);
}

} // namespace

TEST(MeshCells, SharedMeshesMatchTheReference) {
    std::filesystem::path data;
    VOLCL_REQUIRE_SHARED_DATA(data);
    const auto dir = data / "unstructured";
    if (!std::filesystem::is_directory(dir)) GTEST_SKIP() << dir << " is absent";
    struct Case {
        std::string file;
        int qVar;
    };
    for (const Case& c : std::vector<Case>{{"tetraMesh.vtk", 0},
                                           {"xsmall_turb.vtu", 0},
                                           {"kiefer/dataset.vtu", 0},
                                           {"bluntfinxyz.bin", 0},
                                           {"combxyz.bin", 0},
                                           {"postxyz.bin", 0},
                                           {"postxyz.bin", 4}}) {
        if (!std::filesystem::exists(dir / c.file)) continue;
        mesh::MeshReadOptions o;
        o.qVariable = c.qVar;
        const mesh::TetMesh m = mesh::readMesh(dir / c.file, o);
        Scene s = meshScene(m, 64, 64);
        // A three-quarter view: rays cross the cells obliquely.
        s.camera = frameBox(meshBounds(m), orbitDirection(35.0, 25.0), Projection::Orthographic, 30.0, 1.0);
        ImageBuffer gpu, ref;
        const double e = cellsVsReference(m, meshTf(m, 4.0), s, &gpu, &ref);
        std::cout << c.file << " q" << c.qVar << ": " << m.tetCount() << " tets, RMSE " << e
                  << ", mean alpha " << meanAlpha(ref) << '\n';
        EXPECT_LE(e, 0.002) << c.file;
        // Density of the LOx post is 1 everywhere: the ramp starting at its only value shows nothing.
        if (m.valueMax > m.valueMin) EXPECT_GT(meanAlpha(ref), 0.003) << c.file;
    }
}

TEST(MeshCells, NonConvexHoleExitsAndReEnters) {
    const mesh::TetMesh m = boxWithHole(8, 0.5);
    mesh::TetMesh lin = boxWithHole(8, 0.0);
    for (std::size_t i = 0; i < lin.points.size(); ++i)
        lin.scalars[i] = float(lin.points[i][0] + 2.0 * lin.points[i][1] + 0.5 * lin.points[i][2]);
    lin.valueMin = *std::min_element(lin.scalars.begin(), lin.scalars.end());
    lin.valueMax = *std::max_element(lin.scalars.begin(), lin.scalars.end());
    Scene side = meshScene(m, 48, 48);
    side.camera->eye = {-3.0, 0.45, 0.55};
    side.camera->target = {0.5, 0.5, 0.5};
    side.camera->up = {0, 0, 1};
    side.camera->height = 1.3;
    ImageBuffer gpu;
    EXPECT_LE(cellsVsReference(m, constantTf(1.5, {1, 1, 1}), side, &gpu), 0.002);
    // Through the hole the ray crosses 0.75 of the box.
    EXPECT_NEAR(gpu.at(24, 24, 3), 1.0 - std::exp(-1.5 * 0.75), 2e-3);
    Scene persp = side;
    persp.camera->projection = Projection::Perspective;
    persp.camera->fovYDeg = 30.0;
    persp.camera->eye = {-2.0, 1.9, 1.7};
    EXPECT_LE(cellsVsReference(lin, meshTf(lin, 3.0), persp), 0.002);
}

TEST(MeshCells, ModesAndEffectsMatchTheReference) {
    auto f = [](double x, double y, double z) {
        return std::sin(2.0 * x) * std::cos(1.5 * y) + 0.5 * z; // smooth, not linear: real cell structure
    };
    const mesh::TetMesh m = mesh::generateHexGridMesh({6, 5, 7}, {0, 0, 0}, {3, 2.5, 3.5}, f);
    const TransferFunction tf = meshTf(m, 5.0);
    Scene base = meshScene(m, 48, 40);
    base.camera =
        frameBox(meshBounds(m), orbitDirection(-30.0, 40.0), Projection::Orthographic, 30.0, 48.0 / 40.0);
    const double mid = 0.5 * (m.valueMin + m.valueMax);
    struct Variant {
        std::string name;
        std::function<void(Scene&)> apply;
        double tol;
    };
    const std::vector<Variant> variants{
        {"dvr 3d", [](Scene&) {}, 0.002},
        {"mip grey", [](Scene& s) { s.mode = RenderMode::Mip; }, 1e-4},
        {"mip tf",
         [](Scene& s) {
             s.mode = RenderMode::Mip;
             s.mipColor = MipColor::Tf;
         },
         1e-4},
        {"xray", [](Scene& s) { s.mode = RenderMode::Xray; }, 1e-4},
        {"iso shaded",
         [&](Scene& s) {
             s.mode = RenderMode::Iso;
             s.effects.isosurfaces = {{mid, {1, 0.8, 0.5, 0.7}}, {mid + 0.3, {0.3, 0.6, 1.0, 0.5}}};
             s.effects.shading = true;
             s.lights = {{LightKind::Directional, {0.3, -0.5, -1}, {1, 1, 1}, 1.0}};
         },
         1e-3},
        {"dvr shaded + iso",
         [&](Scene& s) {
             s.effects.isosurfaces = {{mid, {1, 1, 1, 0.4}}};
             s.effects.shading = true;
             s.lights = {{LightKind::Directional, {0.3, -0.5, -1}, {1, 1, 1}, 1.0}};
         },
         0.002},
        {"dvr clipped",
         [](Scene& s) {
             s.effects.clipPlanes = {{{1, 0.2, 0}, -1.4}, {{0, 0, -1}, 2.9}};
         },
         0.002},
        {"dvr early termination", [](Scene& s) { s.earlyTermination = 0.99; }, 0.01},
        {"dvr point sampled",
         [](Scene& s) {
             s.preintegration = Preintegration::None;
             s.step = 0.01;
         },
         0.003},
    };
    for (const auto& v : variants) {
        Scene s = base;
        v.apply(s);
        ImageBuffer gpu, ref;
        const double e = cellsVsReference(m, tf, s, &gpu, &ref);
        std::cout << v.name << ": RMSE " << e << ", mean alpha " << meanAlpha(ref) << '\n';
        EXPECT_LE(e, v.tol) << v.name;
        EXPECT_GT(meanAlpha(ref), 0.02) << v.name;
    }
}

TEST(MeshCells, RaysThroughVerticesEdgesAndFacesStayExact) {
    // 4^3 hex cells of 1 on [0, 4]^3; 9 x 9 pixels of 1 world unit centred on the box: every ray runs exactly
    // along a grid line, i.e. through vertices and along tet edges, and the outer rays graze the boundary.
    const mesh::TetMesh m = mesh::generateHexGridMesh({4, 4, 4}, {0, 0, 0}, {4, 4, 4},
                                                      [](double, double, double) { return 0.5; });
    const TransferFunction tf = constantTf(0.4, {1, 0.5, 0.2});
    Scene s;
    s.width = s.height = 9;
    s.earlyTermination = 1.0;
    Camera c;
    c.target = {2, 2, 2};
    c.eye = {2, 2, -10};
    c.height = 9.0;
    s.camera = c;
    s.preintegration = Preintegration::Table3d;
    s.tableLengths = 32;
    ImageBuffer gpu, ref;
    const double e = cellsVsReference(m, tf, s, &gpu, &ref);
    EXPECT_LE(e, 0.002);
    const double a = 1.0 - std::exp(-0.4 * 4.0);
    for (int y = 0; y < 9; ++y)
        for (int x = 0; x < 9; ++x) {
            const double wx = x - 2.0, wy = 6.0 - y; // world position of the ray (image x runs toward -x)
            const bool inside = wx >= 0 && wx <= 4 && wy >= 0 && wy <= 4;
            const bool interior = wx > 0 && wx < 4 && wy > 0 && wy < 4;
            for (int ch = 0; ch < 4; ++ch) {
                EXPECT_TRUE(std::isfinite(gpu.at(x, y, ch)));
                EXPECT_LE(gpu.at(x, y, ch), 1.0f + 1e-5f);
            }
            if (interior) EXPECT_NEAR(gpu.at(x, y, 3), a, 2e-3) << x << "," << y;
            if (!inside) EXPECT_EQ(gpu.at(x, y, 3), 0.0f) << x << "," << y;
            // Boundary rays graze a face: anything from empty to the full length is right; never more.
            if (inside && !interior) EXPECT_LE(gpu.at(x, y, 3), a + 2e-3);
        }
    // Diagonal rays through the cube's vertices (the split's diagonals are tet edges).
    s.camera->eye = {-6, -6, -6};
    s.camera->up = {0, 1, 0};
    s.width = s.height = 31;
    EXPECT_LE(cellsVsReference(m, tf, s), 0.002);
}

TEST(MeshCells, SingleTetConstantMeshAndDegenerateTets) {
    mesh::TetSoup soup;
    soup.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0.3, 0.3, 0}, {2, 2, 2}};
    soup.scalars = {0, 1, 2, 3, 1, 1};
    // One good tet, one inverted copy shifted to the side, one flat tet (all four points in z = 0).
    soup.tets = {{0, 1, 2, 3}, {0, 2, 1, 5}, {0, 1, 2, 4}};
    const mesh::TetMesh m = mesh::buildTetMesh(soup, "soup", "s");
    EXPECT_EQ(m.tetCount(), 2u);
    Scene s = meshScene(m, 40, 40);
    s.camera = frameBox(meshBounds(m), orbitDirection(20.0, 30.0), Projection::Orthographic, 30.0, 1.0);
    EXPECT_LE(cellsVsReference(m, meshTf(m, 6.0), s), 0.002);

    // One scalar everywhere: a constant field over a degenerate value range.
    const mesh::TetMesh flat = mesh::generateHexGridMesh({3, 3, 3}, {0, 0, 0}, {1, 1, 1},
                                                         [](double, double, double) { return 7.0; });
    for (RenderMode mode : {RenderMode::Dvr, RenderMode::Mip, RenderMode::Xray}) {
        Scene c = meshScene(flat, 24, 24);
        c.mode = mode;
        ImageBuffer gpu;
        EXPECT_LE(cellsVsReference(flat, meshTf(flat, 2.0), c, &gpu), 0.002) << renderModeName(mode);
        for (float p : gpu.pixels)
            EXPECT_TRUE(std::isfinite(p));
    }
}

TEST(MeshCells, HugeAndTinyCoordinatesRenderAlike) {
    auto f = [](double x, double y, double z) { return x + 2 * y * y + std::sin(3 * z); };
    const mesh::TetMesh unit = mesh::generateHexGridMesh({5, 5, 5}, {-1, -1, -1}, {1, 1, 1}, f);
    const TransferFunction tf = meshTf(unit, 4.0);
    Scene s = meshScene(unit, 32, 32);
    s.camera = frameBox(meshBounds(unit), orbitDirection(25.0, 15.0), Projection::Orthographic, 30.0, 1.0);
    ImageBuffer base;
    EXPECT_LE(cellsVsReference(unit, tf, s, &base), 0.002);
    for (double k : {1e30, 1e-30}) {
        mesh::TetMesh m = unit;
        for (auto& p : m.points)
            for (double& c : p)
                c *= k;
        m.boundsMin = {-k, -k, -k};
        m.boundsMax = {k, k, k};
        m.maxEdgeLength *= k;
        TransferFunction t = tf;
        for (auto& e : t.extinction)
            e.tau /= k; // the same optical depth across the scaled box
        Scene sk = s;
        sk.camera->eye = scale(s.camera->eye, k);
        sk.camera->target = scale(s.camera->target, k);
        sk.camera->height *= k;
        ImageBuffer gpu, ref;
        EXPECT_LE(cellsVsReference(m, t, sk, &gpu, &ref), 0.002) << k;
        EXPECT_LT(imageRmse(gpu, base), 0.002) << k;
    }
}
