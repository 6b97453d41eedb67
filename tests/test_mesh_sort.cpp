// Visibility sorting of tet meshes (centroid, MPVO, convexified MPVO) against a ray oracle that never uses MPVO:
// the tets each ray crosses, found by clipping the ray with every tet, must appear back to front in the order.
#include "MeshTestMeshes.hpp"
#include "TestUtil.hpp"

#include "host/mesh/MeshIo.hpp"
#include "render/Scene.hpp"
#include "render/mesh/VisibilityOracle.hpp"
#include "render/mesh/VisibilitySort.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <numeric>

using namespace volcl;

namespace {

using OracleCount = OrderCheck;

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

OracleCount rayOracle(const mesh::TetMesh& m, const std::vector<std::uint32_t>& order, const SortView& view,
                      int raysPerAxis = 40) {
    return checkOrderAlongRays(m, order, view, raysPerAxis);
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
                          const std::vector<SortView>& vs, int raysPerAxis = 24) {
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

using test::cubeMesh;

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
    std::cout << "convex cube: pairs " << mpvo.pairs << ", violations mpvo " << mpvo.violations
              << ", convexified " << convex.violations << ", centroid " << centroid.violations << '\n';
    EXPECT_GT(mpvo.pairs, 10000u);
    EXPECT_EQ(mpvo.violations, 0u);
    EXPECT_EQ(convex.violations, 0u);
    EXPECT_EQ(sorter.convexification().auxiliaryCells, 0u); // nothing to fill
}

TEST(MeshSort, ConcavityInFrontOfAPartBreaksMpvoNotConvexified) {
    const mesh::TetMesh m = cubeMesh(6, test::uNotch); // views along x: a prong, the notch, the other prong
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

namespace {

/// Three long thin tets over a triangle, each passing over the next where they cross (the classic visibility
/// cycle seen from above): no order of the three is right for every ray.
mesh::TetMesh threeSticks() {
    mesh::TetSoup soup;
    const double pi = 3.141592653589793;
    for (int i = 0; i < 3; ++i) {
        const double a0 = 2.0 * pi * i / 3.0, a1 = 2.0 * pi * (i + 1) / 3.0;
        const Vec3 v0{std::cos(a0), std::sin(a0), 0}, v1{std::cos(a1), std::sin(a1), 0};
        const Vec3 e = sub(v1, v0);
        const Vec3 p = sub(v0, scale(e, 0.3)), q = add(v1, scale(e, 0.3));
        const Vec3 across = scale(normalized(Vec3{-e[1], e[0], 0}), 0.12);
        // Low (z = -0.5) at its start, high (z = +0.5) at its end: over the next stick's start.
        const std::uint32_t base = static_cast<std::uint32_t>(soup.points.size());
        soup.points.push_back({p[0], p[1], -0.5});
        soup.points.push_back({p[0] + across[0], p[1] + across[1], -0.5});
        soup.points.push_back({q[0], q[1], 0.5});
        soup.points.push_back({q[0], q[1], 0.62});
        soup.tets.push_back({base, base + 1, base + 2, base + 3});
    }
    soup.scalars.assign(soup.points.size(), 1.0f);
    return mesh::buildTetMesh(soup, "sticks", "f");
}

} // namespace

TEST(MeshSort, VisibilityCycleIsBrokenAndEveryTetListedOnce) {
    const mesh::TetMesh m = threeSticks();
    ASSERT_EQ(m.tetCount(), 3u);
    VisibilitySorter sorter(m);
    const SortView top = ortho({0, 0, -1});
    const VisibilityOrder o = sorter.sort(top, MeshSort::Convexified);
    EXPECT_TRUE(isPermutation(o.tets, 3));
    EXPECT_GT(o.cyclesBroken, 0u);
    // No order is right from above: the oracle finds a violation whatever was chosen.
    EXPECT_GT(rayOracle(m, o.tets, top, 64).violations, 0u);
    // Plain MPVO sees three unconnected tets (no shared face): no cycle, still a permutation.
    const VisibilityOrder mpvo = sorter.sort(top, MeshSort::Mpvo);
    EXPECT_TRUE(isPermutation(mpvo.tets, 3));
    EXPECT_EQ(mpvo.cyclesBroken, 0u);
    std::cout << "three sticks: " << sorter.convexification().auxiliaryCells << " auxiliary cells, "
              << o.cyclesBroken << " cycles broken\n";
}

TEST(MeshSort, OneTet) {
    mesh::TetSoup soup;
    soup.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    soup.scalars = {0, 1, 2, 3};
    soup.tets = {{0, 1, 2, 3}};
    const mesh::TetMesh m = mesh::buildTetMesh(soup, "one", "f");
    EXPECT_TRUE(meshIsConvex(m));
    VisibilitySorter sorter(m);
    for (const MeshSort s : {MeshSort::Centroid, MeshSort::Mpvo, MeshSort::Convexified})
        for (const SortView& v : {ortho({1, 2, 3}), perspective({0.1, 0.1, 0.1}), perspective({5, 5, 5})}) {
            const VisibilityOrder o = sorter.sort(v, s);
            EXPECT_EQ(o.tets, std::vector<std::uint32_t>{0});
            EXPECT_EQ(o.cyclesBroken, 0u);
        }
}

TEST(MeshSort, HolesDisconnectedAndNestedPartsConvexifiedExact) {
    struct Case {
        const char* name;
        std::function<bool(double, double, double)> removed;
    };
    const Case cases[] = {
        // A tunnel through the cube along z, and a closed cavity in its middle.
        {"tunnel", test::tunnelAlongZ},
        {"cavity", [](double x, double y,
                      double z) { return x > 0.3 && x < 0.7 && y > 0.3 && y < 0.7 && z > 0.3 && z < 0.7; }},
        // Two slabs with a gap between them.
        {"disconnected", [](double x, double, double) { return x > 0.4 && x < 0.6; }},
        // A hollow shell with a block floating inside it (a gap all round).
        {"nested", test::nestedBlockGap},
    };
    for (const Case& c : cases) {
        const mesh::TetMesh m = test::jitteredMesh(7, 0.2, false, c.removed);
        EXPECT_FALSE(meshIsConvex(m)) << c.name;
        VisibilitySorter sorter(m);
        const MethodCounts convex = sortAndCheck(m, sorter, MeshSort::Convexified, views(), 24);
        const MethodCounts mpvo = sortAndCheck(m, sorter, MeshSort::Mpvo, views(), 24);
        const ConvexificationStats& st = sorter.convexification();
        std::cout << c.name << ": pairs " << convex.pairs << ", violations mpvo " << mpvo.violations
                  << ", convexified " << convex.violations << " (" << st.auxiliaryCells
                  << " auxiliary cells, " << st.openBoundaryFaces << " open faces, cycles " << convex.cycles
                  << ")\n";
        EXPECT_EQ(convex.violations, 0u) << c.name;
        EXPECT_LE(st.openBoundaryFaces, 2u) << c.name; // a Delaunay tet crossing a bumpy wall may leave one
    }
}

TEST(MeshSort, DuplicateVerticesAndSliversStayExact) {
    // Two cubes' grids written with separate copies of their shared points (the builder merges them), and a
    // sliver tet standing on a boundary face of the top, its apex 1e-6 above the face's centroid (it makes the
    // mesh barely non-convex: the Delaunay tets around it are slivers too).
    mesh::TetMesh cube = test::jitteredMesh(3, 0.2, false, [](double, double, double) { return false; });
    mesh::TetSoup soup;
    for (int copy = 0; copy < 2; ++copy) {
        const std::uint32_t base = static_cast<std::uint32_t>(soup.points.size());
        for (const auto& p : cube.points)
            soup.points.push_back({p[0] + copy, p[1], p[2]});
        for (const float s : cube.scalars)
            soup.scalars.push_back(s);
        for (auto t : cube.tets)
            soup.tets.push_back({t[0] + base, t[1] + base, t[2] + base, t[3] + base});
    }
    mesh::FaceId top = mesh::kNoFace;
    for (const mesh::FaceId f : cube.boundaryFaces) {
        const auto v = cube.faceVertices(f);
        if (cube.points[v[0]][2] == 1.0 && cube.points[v[1]][2] == 1.0 && cube.points[v[2]][2] == 1.0)
            top = f;
    }
    ASSERT_NE(top, mesh::kNoFace);
    const auto v = cube.faceVertices(top);
    Vec3 apex{0, 0, 0};
    for (const std::uint32_t p : v)
        apex = add(apex, scale(cube.points[p], 1.0 / 3.0));
    apex[2] += 1e-6;
    soup.points.push_back(apex);
    soup.scalars.push_back(0.5f);
    soup.tets.push_back({v[0], v[1], v[2], static_cast<std::uint32_t>(soup.points.size() - 1)});
    const mesh::TetMesh m = mesh::buildTetMesh(soup, "duplicates", "f");
    EXPECT_GT(m.repairs.mergedPoints, 0u);
    EXPECT_EQ(m.tetCount(), 2 * cube.tetCount() + 1);
    EXPECT_FALSE(meshIsConvex(m));
    VisibilitySorter sorter(m);
    const MethodCounts convex = sortAndCheck(m, sorter, MeshSort::Convexified, views(), 24);
    std::cout << "duplicates + sliver: pairs " << convex.pairs << ", violations " << convex.violations
              << ", cycles " << convex.cycles << '\n';
    EXPECT_EQ(convex.violations, 0u);
}

TEST(MeshSort, PerspectiveEyeInsideTheMesh) {
    const mesh::TetMesh m = cubeMesh(6, test::uNotch);
    VisibilitySorter sorter(m);
    // Inside the U's base, and inside the notch (outside the mesh, inside its hull).
    for (const Vec3 eye : {Vec3{0.52, 0.13, 0.47}, Vec3{0.5, 0.8, 0.5}}) {
        const SortView v = perspective(eye);
        for (const MeshSort s : {MeshSort::Centroid, MeshSort::Mpvo, MeshSort::Convexified}) {
            const VisibilityOrder o = sorter.sort(v, s);
            EXPECT_TRUE(isPermutation(o.tets, m.tetCount())) << meshSortName(s);
            const OracleCount oc = rayOracle(m, o.tets, v, 32);
            std::cout << "eye (" << eye[0] << ", " << eye[1] << ", " << eye[2] << ") " << meshSortName(s)
                      << ": pairs " << oc.pairs << ", violations " << oc.violations << ", cycles "
                      << o.cyclesBroken << '\n';
            if (s == MeshSort::Convexified) EXPECT_EQ(oc.violations, 0u);
        }
    }
}

TEST(MeshSort, SharedMeshesSortCompletely) {
    std::filesystem::path data;
    VOLCL_REQUIRE_SHARED_DATA(data);
    for (const char* name : {"bluntfinxyz.bin", "combxyz.bin", "xsmall_turb.vtu"}) {
        const mesh::TetMesh m = mesh::readMesh(data / "unstructured" / name);
        VisibilitySorter sorter(m);
        const ConvexificationStats& st = sorter.convexification();
        std::cout << name << ": " << m.tetCount() << " tets, convex " << meshIsConvex(m) << ", "
                  << st.delaunayTets << " Delaunay tets, " << st.auxiliaryCells << " auxiliary cells, "
                  << st.exactLinks << " exact + " << st.geometricLinks << " geometric links, "
                  << st.openBoundaryFaces << " open boundary faces, built in " << st.seconds << " s\n";
        for (const SortView& v : {ortho({0.3, -0.8, 0.5}), perspective(add(m.boundsMax, Vec3{1, 2, 3}))})
            for (const MeshSort s : {MeshSort::Centroid, MeshSort::Mpvo, MeshSort::Convexified}) {
                const VisibilityOrder o = sorter.sort(v, s);
                EXPECT_TRUE(isPermutation(o.tets, m.tetCount())) << name << ' ' << meshSortName(s);
                const OracleCount oc = rayOracle(m, o.tets, v, 12);
                std::cout << "  " << meshSortName(s) << (v.perspective ? " perspective" : " orthographic")
                          << ": " << o.seconds * 1e3 << " ms, cycles broken " << o.cyclesBroken
                          << ", violations " << oc.violations << " of " << oc.pairs << " pairs\n";
            }
    }
}

TEST(MeshSort, SceneKeyRenderSort) {
    const Scene unset = Scene::fromJson(R"({"volume": "m.vtu"})");
    EXPECT_FALSE(unset.meshSort.has_value());
    const Scene s =
        Scene::fromJson(R"({"volume": "m.vtu", "render": {"method": "cells", "sort": "centroid"}})");
    ASSERT_TRUE(s.meshSort.has_value());
    EXPECT_EQ(*s.meshSort, MeshSort::Centroid);
    const Scene back = Scene::fromJson(s.toJson());
    ASSERT_TRUE(back.meshSort.has_value());
    EXPECT_EQ(*back.meshSort, MeshSort::Centroid);
    EXPECT_THROW(Scene::fromJson(R"({"volume": "m.vtu", "render": {"sort": "painter"}})"), UsageError);
}

TEST(MeshSort, ThinLShapedSlabIsConvexified) {
    // An L-shaped slab 1e-10 thick (its tets pass the builder's volume test): Qhull still tetrahedralises its
    // nearly coplanar points (Qbb), and the missing corner is filled; every tet is listed once from any side.
    const mesh::TetMesh full = mesh::generateHexGridMesh({2, 2, 1}, {0, 0, 0}, {1, 1, 1e-10},
                                                         [](double x, double, double) { return x; });
    mesh::TetSoup soup;
    soup.points = full.points;
    soup.scalars = full.scalars;
    for (const auto& t : full.tets) {
        double cx = 0, cy = 0;
        for (const std::uint32_t v : t) {
            cx += 0.25 * full.points[v][0];
            cy += 0.25 * full.points[v][1];
        }
        if (!(cx > 0.5 && cy > 0.5)) soup.tets.push_back(t);
    }
    const mesh::TetMesh m = mesh::buildTetMesh(soup, "slab", "f");
    ASSERT_EQ(m.tetCount(), 18u);
    ASSERT_FALSE(meshIsConvex(m));
    VisibilitySorter sorter(m);
    const ConvexificationStats& st = sorter.convexification();
    EXPECT_TRUE(st.delaunayError.empty()) << st.delaunayError;
    EXPECT_GT(st.auxiliaryCells, 0u);
    for (const SortView& v : views()) {
        const VisibilityOrder o = sorter.sort(v, MeshSort::Convexified);
        EXPECT_TRUE(isPermutation(o.tets, m.tetCount()));
    }
}
