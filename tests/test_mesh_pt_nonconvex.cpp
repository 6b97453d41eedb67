// Projected tetrahedra on non-convex meshes whose convexified visibility graph has cycles (a U, a tunnel, a block
// nested in a shell, bumpy-walled variants), against the exact cell caster: the convexified sort matches it, plain
// MPVO is shown to fail where a view looks through a concavity, the centroid sort's error is printed.
#include "MeshTestMeshes.hpp"
#include "MeshTestUtil.hpp"
#include "TestUtil.hpp"

#include "render/Reference.hpp"
#include "render/mesh/PtRenderer.hpp"

#include <gtest/gtest.h>

#include <functional>
#include <iostream>
#include <string>
#include <vector>

using namespace volcl;

namespace {

/// A view of a case: orbit angles, projection, and whether plain MPVO must fail there (the view looks through a
/// concavity at parts MPVO's face graph does not order).
struct CaseView {
    double az, el;
    Projection projection;
    bool mpvoFails;
};

struct NonConvexCase {
    const char* name;
    mesh::TetMesh mesh;
    std::vector<CaseView> views;
};

constexpr double kPtBound = 0.002; ///< RMSE of pt (convexified) against the cell caster
constexpr double kDenseAlpha =
    0.3; ///< mean alpha of the cell caster's image: dense enough that order matters

/// A TF dense enough that most rays through the mesh are more than half absorbed: the ramp of the mesh suites
/// with 16 optical lengths across the box diagonal at its peak and 60 % of that at the lowest value.
TransferFunction denseTf(const mesh::TetMesh& m) {
    return test::meshTf(m, 16.0, 0.6);
}

const char* projectionName(Projection p) {
    return p == Projection::Perspective ? "perspective" : "orthographic";
}

/// The four non-convex meshes. The U, the tunnel and the nested block have flat outer faces and walls jittered by
/// 0.2 cells; the bumpy variants jitter every point, outer faces included, by 0.25 cells (short of the 0.3 where
/// tets start to fold over). Azimuth 90 looks along x (through the U's prongs and notch, across the tunnel);
/// elevation 90 looks down the U's notch and the tunnel.
std::vector<NonConvexCase> cases() {
    const auto bumpy = [](std::size_t n, const std::function<bool(double, double, double)>& removed,
                          std::uint64_t seed) {
        return mesh::buildTetMesh(
            test::jitteredSoup({n, n, n}, {0, 0, 0}, {1, 1, 1}, 0.25, true, removed, seed), "bumpy", "f");
    };
    const Projection O = Projection::Orthographic, P = Projection::Perspective;
    std::vector<NonConvexCase> out;
    out.push_back({"U (notch)",
                   test::cubeMesh(6, test::uNotch),
                   {{90, 12, O, true}, {75, 20, P, true}, {-90, -15, O, false}, {20, 35, P, false}}});
    out.push_back({"tunnel",
                   test::cubeMesh(7, test::tunnelAlongZ),
                   {{90, 8, O, true}, {0, -10, P, true}, {40, 30, O, false}, {10, 80, P, false}}});
    out.push_back({"nested block",
                   test::cubeMesh(7, test::nestedBlockGap),
                   {{90, 10, O, true}, {30, 25, P, true}, {-135, -30, O, false}}});
    out.push_back({"bumpy U", bumpy(6, test::uNotch, 5), {{90, 12, O, true}, {-80, 15, P, false}}});
    out.push_back({"bumpy tunnel", bumpy(7, test::tunnelAlongZ, 9), {{90, 5, O, true}, {-85, 10, P, false}}});
    return out;
}

} // namespace

TEST(MeshPtNonConvex, ConvexifiedMatchesTheCellCasterAndMpvoFails) {
    const int size = 64;
    for (NonConvexCase& c : cases()) {
        const mesh::TetMesh& m = c.mesh;
        ASSERT_FALSE(meshIsConvex(m)) << c.name;
        EXPECT_EQ(defaultMeshSort(m), MeshSort::Convexified) << c.name;
        const TransferFunction tf = denseTf(m);
        Scene base =
            test::framedMeshScene(m, size, size, c.views[0].az, c.views[0].el, c.views[0].projection);
        base.meshMethod = MeshMethod::ProjectedTetrahedra;
        std::unique_ptr<PtRenderer> pt[3];
        const MeshSort sorts[3] = {MeshSort::Convexified, MeshSort::Mpvo, MeshSort::Centroid};
        for (int k = 0; k < 3; ++k) {
            Scene s = base;
            s.meshSort = sorts[k];
            pt[k] = std::make_unique<PtRenderer>(test::computeContext(), m, tf, s);
        }
        std::size_t cycles = 0;
        bool mpvoFailedSomewhere = false;
        for (const CaseView& v : c.views) {
            const Scene s = test::framedMeshScene(m, size, size, v.az, v.el, v.projection);
            const ImageBuffer cells = test::cellCasterImage(m, tf, s);
            const double alpha = test::meanAlpha(cells);
            double err[3];
            for (int k = 0; k < 3; ++k) {
                pt[k]->setView(*s.camera, s.width, s.height, s.step);
                const ImageBuffer img = pt[k]->render();
                EXPECT_TRUE(test::finiteInUnitRange(img)) << c.name << ' ' << meshSortName(sorts[k]);
                err[k] = imageRmse(img, cells);
            }
            const std::size_t viewCycles = pt[0]->lastOrder().cyclesBroken;
            cycles += viewCycles;
            std::cout << c.name << ", " << projectionName(v.projection) << " az " << v.az << " el " << v.el
                      << ": mean alpha " << alpha << ", RMSE against cells: convexified " << err[0] << " ("
                      << viewCycles << " cycles broken), mpvo " << err[1] << ", centroid " << err[2] << '\n';
            const std::string where = std::string(c.name) + ", az " + std::to_string(v.az) + " el " +
                                      std::to_string(v.el) + ' ' + projectionName(v.projection);
            EXPECT_GE(alpha, kDenseAlpha) << where;
            EXPECT_LE(err[0], kPtBound) << where;
            if (v.mpvoFails) {
                EXPECT_GT(err[1], kPtBound) << where << ": plain MPVO was expected to misorder this view";
                mpvoFailedSomewhere = true;
            }
        }
        // The convexified graphs of these meshes have cycles (auxiliary cells poking through the jittered walls),
        // and breaking them keeps the image exact.
        EXPECT_GT(cycles, 0u) << c.name;
        EXPECT_TRUE(mpvoFailedSomewhere) << c.name;
    }
}

TEST(MeshPtNonConvex, EyeInsideTheConcavityAndClipPlanes) {
    // A perspective eye outside the mesh but inside its hull (in the U's notch, in the tunnel) looking at a wall,
    // and a clip plane across the far prong / the tunnel's side: the convexified order still matches the cell caster.
    struct EyeCase {
        const char* name;
        mesh::TetMesh mesh;
        Vec3 eye, target;
        ClipPlane clip;
    };
    const EyeCase eyeCases[] = {
        {"U, eye in the notch",
         test::cubeMesh(6, test::uNotch),
         {0.5, 0.8, 0.45},
         {0.0, 0.4, 0.55},
         ClipPlane{{0.2, 1, 0.1}, -0.55}},
        {"tunnel, eye in the tunnel",
         test::cubeMesh(7, test::tunnelAlongZ),
         {0.5, 0.45, 0.5},
         {1.0, 0.6, 0.7},
         ClipPlane{{0.1, -1, 0.3}, 0.5}},
    };
    for (const EyeCase& c : eyeCases) {
        const TransferFunction tf = denseTf(c.mesh);
        Scene s = test::framedMeshScene(c.mesh, 48, 48, 0, 0, Projection::Perspective);
        s.camera->eye = c.eye;
        s.camera->target = c.target;
        s.camera->up = {0, 0, 1};
        s.camera->fovYDeg = 70.0;
        for (const bool clipped : {false, true}) {
            s.effects.clipPlanes.clear();
            if (clipped) s.effects.clipPlanes = {c.clip};
            const ImageBuffer cells = test::cellCasterImage(c.mesh, tf, s);
            double err[3];
            std::size_t cycles = 0;
            const MeshSort sorts[3] = {MeshSort::Convexified, MeshSort::Mpvo, MeshSort::Centroid};
            for (int k = 0; k < 3; ++k) {
                Scene ps = s;
                ps.meshSort = sorts[k];
                PtRenderer r(test::computeContext(), c.mesh, tf, ps);
                const ImageBuffer img = r.render();
                EXPECT_TRUE(test::finiteInUnitRange(img)) << c.name;
                err[k] = imageRmse(img, cells);
                if (k == 0) cycles = r.lastOrder().cyclesBroken;
            }
            std::cout << c.name << (clipped ? ", clipped" : "") << ": mean alpha " << test::meanAlpha(cells)
                      << ", RMSE against cells: convexified " << err[0] << " (" << cycles
                      << " cycles broken), mpvo " << err[1] << ", centroid " << err[2] << '\n';
            EXPECT_GE(test::meanAlpha(cells), kDenseAlpha) << c.name;
            EXPECT_LE(err[0], kPtBound) << c.name << (clipped ? ", clipped" : "");
        }
    }
}
