// Visibility sorting of tet meshes (centroid, MPVO, convexified MPVO) against a ray oracle that never uses MPVO:
// the tets each ray crosses, found by clipping the ray with every tet, must appear back to front in the order.
#include "MeshTestMeshes.hpp"
#include "TestUtil.hpp"

#include "host/mesh/MeshIo.hpp"
#include "render/mesh/VisibilitySort.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <numeric>

using namespace volcl;

namespace {

/// What the oracle counted: pairs of tets one ray crosses one after the other, and those the order puts the
/// wrong way round (the nearer one before the farther one).
struct OracleCount {
    std::size_t rays = 0, pairs = 0, violations = 0;
};

/// Every tet exactly once.
bool isPermutation(const std::vector<std::uint32_t>& order, std::size_t n) {
    if (order.size() != n) return false;
    std::vector<std::uint8_t> seen(n, 0);
    for (const std::uint32_t t : order) {
        if (t >= n || seen[t]) return false;
        seen[t] = 1;
    }
    return true;
}

/// Rays of the view: orthographic, a raysPerAxis^2 grid across the mesh's bounds along the direction; perspective,
/// raysPerAxis^2 directions spread over the sphere from the eye (only t >= 0 counts). Each ray is clipped with
/// every tet (tetInterval); of two tets whose intervals follow one another (the first ends where or before the
/// second starts), the second must come first in the back-to-front order.
OracleCount rayOracle(const mesh::TetMesh& m, const std::vector<std::uint32_t>& order, const SortView& view,
                      int raysPerAxis = 40) {
    std::vector<std::size_t> position(m.tetCount());
    for (std::size_t i = 0; i < order.size(); ++i)
        position[order[i]] = i;
    const Vec3 lo = m.boundsMin, hi = m.boundsMax;
    const Vec3 centre = scale(add(lo, hi), 0.5);
    const double radius = 0.5 * norm(sub(hi, lo));
    const double tol = 1e-9 * radius;
    OracleCount count;
    struct Hit {
        double t0, t1;
        std::uint32_t tet;
    };
    std::vector<Hit> hits;
    const int n = raysPerAxis;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            Vec3 o, d;
            if (view.perspective) {
                // Fibonacci sphere: every direction from the eye.
                const double k = double(i * n + j) + 0.5, total = double(n * n);
                const double z = 1.0 - 2.0 * k / total, r = std::sqrt(std::max(0.0, 1.0 - z * z));
                const double phi = k * 2.399963229728653;
                o = view.eye;
                d = {r * std::cos(phi), r * std::sin(phi), z};
            } else {
                d = normalized(view.direction);
                const Vec3 u = normalized(std::abs(d[0]) < 0.9 ? cross(d, Vec3{1, 0, 0}) : cross(d, Vec3{0, 1, 0}));
                const Vec3 w = cross(d, u);
                const double a = radius * (2.0 * (i + 0.5) / n - 1.0), b = radius * (2.0 * (j + 0.5) / n - 1.0);
                o = add(sub(centre, scale(d, 2.0 * radius)), add(scale(u, a), scale(w, b)));
            }
            hits.clear();
            for (std::size_t t = 0; t < m.tetCount(); ++t) {
                double t0 = 0, t1 = 0;
                if (!test::tetInterval(m, t, o, d, t0, t1)) continue;
                if (view.perspective) t0 = std::max(t0, 0.0);
                if (t1 - t0 > tol) hits.push_back({t0, t1, static_cast<std::uint32_t>(t)});
            }
            ++count.rays;
            std::sort(hits.begin(), hits.end(), [](const Hit& a, const Hit& b) { return a.t0 < b.t0; });
            for (std::size_t a = 0; a < hits.size(); ++a)
                for (std::size_t b = a + 1; b < hits.size(); ++b) {
                    if (hits[a].t1 > hits[b].t0 + tol) continue; // they overlap along the ray: no order needed
                    ++count.pairs;
                    if (position[hits[b].tet] > position[hits[a].tet]) ++count.violations;
                }
        }
    return count;
}

SortView ortho(Vec3 d) {
    SortView v;
    v.direction = normalized(d);
    return v;
}

SortView perspective(Vec3 eye) {
    SortView v;
    v.perspective = true;
    v.eye = eye;
    return v;
}

/// Orthographic views from many sides, and perspective eyes around the unit cube.
std::vector<SortView> views() {
    std::vector<SortView> out;
    for (int i = 0; i < 8; ++i) {
        const double az = 0.7 + 0.785 * i, el = 0.9 * test::hashUnit(std::uint64_t(i), 3);
        out.push_back(ortho({std::cos(az) * std::cos(el), std::sin(az) * std::cos(el), std::sin(el)}));
    }
    out.push_back(ortho({1, 0.05, 0.02}));
    out.push_back(ortho({0.03, 1, -0.04}));
    out.push_back(perspective({2.5, 0.4, 0.6}));
    out.push_back(perspective({-1.2, 2.2, 1.7}));
    return out;
}

struct MethodCounts {
    std::size_t violations = 0, pairs = 0, cycles = 0;
};

/// Sorts with `method` from every view; checks the order is a permutation each time; sums the oracle's counts.
MethodCounts sortAndCheck(const mesh::TetMesh& m, VisibilitySorter& sorter, MeshSort method,
                          const std::vector<SortView>& vs, int raysPerAxis = 32) {
    MethodCounts c;
    for (const SortView& v : vs) {
        const VisibilityOrder o = sorter.sort(v, method);
        EXPECT_TRUE(isPermutation(o.tets, m.tetCount())) << meshSortName(method);
        const OracleCount oc = rayOracle(m, o.tets, v, raysPerAxis);
        c.violations += oc.violations;
        c.pairs += oc.pairs;
        c.cycles += o.cyclesBroken;
    }
    return c;
}

/// The unit cube's n^3 grid, points inside jittered by 0.2 cells (its faces stay flat), minus `removed` cells.
mesh::TetMesh cubeMesh(std::size_t n, const std::function<bool(double, double, double)>& removed) {
    return test::jitteredMesh(n, 0.2, false, removed);
}

} // namespace

TEST(MeshSort, NamesParseAndRefuseUnknown) {
    for (const MeshSort s : {MeshSort::Centroid, MeshSort::Mpvo, MeshSort::Convexified})
        EXPECT_EQ(parseMeshSort(meshSortName(s)), s);
    EXPECT_THROW(parseMeshSort("bsp"), UsageError);
}

TEST(MeshSort, ConvexMeshMpvoAndConvexifiedAreExact) {
    const mesh::TetMesh m = cubeMesh(6, [](double, double, double) { return false; });
    ASSERT_TRUE(meshIsConvex(m));
    EXPECT_EQ(defaultMeshSort(m), MeshSort::Mpvo);
    VisibilitySorter sorter(m);
    const std::vector<SortView> vs = views();
    const MethodCounts mpvo = sortAndCheck(m, sorter, MeshSort::Mpvo, vs);
    const MethodCounts convex = sortAndCheck(m, sorter, MeshSort::Convexified, vs);
    const MethodCounts centroid = sortAndCheck(m, sorter, MeshSort::Centroid, vs);
    std::cout << "convex cube: pairs " << mpvo.pairs << ", violations mpvo " << mpvo.violations << ", convexified "
              << convex.violations << ", centroid " << centroid.violations << '\n';
    EXPECT_GT(mpvo.pairs, 10000u);
    EXPECT_EQ(mpvo.violations, 0u);
    EXPECT_EQ(convex.violations, 0u);
    EXPECT_EQ(sorter.convexification().auxiliaryCells, 0u); // nothing to fill
}

TEST(MeshSort, ConcavityInFrontOfAPartBreaksMpvoNotConvexified) {
    // A U: the notch 0.33 < x < 0.67, y > 0.3 runs through z; views along x look through one prong, the notch,
    // then the other prong.
    const mesh::TetMesh m =
        cubeMesh(6, [](double x, double y, double) { return x > 0.33 && x < 0.67 && y > 0.3; });
    ASSERT_FALSE(meshIsConvex(m));
    EXPECT_EQ(defaultMeshSort(m), MeshSort::Convexified);
    VisibilitySorter sorter(m);
    const std::vector<SortView> vs = views();
    const MethodCounts mpvo = sortAndCheck(m, sorter, MeshSort::Mpvo, vs);
    const MethodCounts convex = sortAndCheck(m, sorter, MeshSort::Convexified, vs);
    const ConvexificationStats& st = sorter.convexification();
    std::cout << "U mesh: pairs " << mpvo.pairs << ", violations mpvo " << mpvo.violations << ", convexified "
              << convex.violations << " (" << st.auxiliaryCells << " auxiliary cells, " << st.exactLinks
              << " exact + " << st.geometricLinks << " geometric links, " << st.openBoundaryFaces
              << " open faces, cycles " << convex.cycles << ")\n";
    EXPECT_GT(mpvo.violations, 0u);
    EXPECT_EQ(convex.violations, 0u);
    EXPECT_GT(st.auxiliaryCells, 0u);
    EXPECT_EQ(st.openBoundaryFaces, 0u);
}
