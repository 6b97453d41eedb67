// Tetrahedral mesh rendering: the exact double reference against analytic integrals and the grid reference,
// the OpenCL cell ray caster against the reference, and the hard cases (edges, vertices, holes, scales).
#include "TestUtil.hpp"

#include "host/Error.hpp"
#include "host/mesh/MeshGenerator.hpp"
#include "host/mesh/MeshIo.hpp"
#include "host/render/RenderInput.hpp"
#include "host/render/grid/GridRenderer.hpp"
#include "host/render/mesh/MeshReference.hpp"

#include <gtest/gtest.h>

#include <cmath>

using namespace volcl;

namespace {

TransferFunction rampTf(double lo, double hi, double tauMax) {
    TransferFunction tf;
    tf.domain = {lo, hi};
    tf.color = {{lo, {0.1, 0.2, 1.0}}, {0.5 * (lo + hi), {1.0, 0.6, 0.2}}, {hi, {1.0, 1.0, 0.9}}};
    tf.extinction = {{lo, 0.0}, {lo + 0.2 * (hi - lo), 0.1 * tauMax}, {0.7 * (lo + hi) * 0.5 + 0.3 * hi, tauMax},
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
