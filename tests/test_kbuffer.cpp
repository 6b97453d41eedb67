// k-buffer mesh renderer: radix sort against its C++ reference, unique faces, kernels against the C++ mirror
// fragment for fragment, analytic chords (constant scalar, a gap between two boxes), hard cases.
#include "MeshTestMeshes.hpp"
#include "MeshTestUtil.hpp"
#include "TestUtil.hpp"

#include "core/Error.hpp"
#include "host/mesh/MeshGenerator.hpp"
#include "host/mesh/MeshIo.hpp"
#include "host/tf/TransferFunction.hpp"
#include "preintegration/PreintegrationTable.hpp"
#include "render/CameraFraming.hpp"
#include "render/RenderInput.hpp"
#include "render/VecMath.hpp"
#include "render/mesh/KBufferReference.hpp"
#include "render/mesh/KBufferRenderer.hpp"
#include "render/mesh/MeshReference.hpp"
#include "render/mesh/RadixSort.hpp"

#include <algorithm>
#include <cmath>
#include <iostream>
#include <limits>
#include <numeric>
#include <random>
#include <set>

using namespace volcl;

namespace {

ComputeContext& context() {
    return test::computeContext();
}

/// Smooth colours and a moderate extinction over [0, 1].
TransferFunction rampTf(double extinctionScale = 2.0) {
    return TransferFunction::fromJson(R"({"domain": [0, 1],
      "color": [[0, 0.1, 0.2, 0.9], [0.5, 1.0, 0.6, 0.2], [1, 1.0, 1.0, 1.0]],
      "extinction": [[0, )" + std::to_string(0.2 * extinctionScale) +
                                      R"(], [0.6, )" + std::to_string(1.0 * extinctionScale) + R"(], [1, )" +
                                      std::to_string(0.4 * extinctionScale) + "]]}");
}

Scene orthoScene(const mesh::TetMesh& m, int w, int h, Vec3 dir = {0.3, -0.2, 1.0}) {
    Scene s;
    Camera c;
    for (int i = 0; i < 3; ++i)
        c.target[i] = 0.5 * (m.boundsMin[i] + m.boundsMax[i]);
    const Vec3 d = normalized(dir);
    double r = 0;
    for (int i = 0; i < 3; ++i)
        r += (m.boundsMax[i] - m.boundsMin[i]) * (m.boundsMax[i] - m.boundsMin[i]);
    r = std::sqrt(r) * 0.5;
    for (int i = 0; i < 3; ++i)
        c.eye[i] = c.target[i] - 3.0 * r * d[i];
    c.up = {0, 1, 0};
    c.height = 2.2 * r;
    s.camera = c;
    s.width = w;
    s.height = h;
    s.earlyTermination = 1.0;
    s.preintegration = Preintegration::Table3d;
    s.tableSize = 64;
    s.tableLengths = 8;
    return s;
}

Scene perspectiveScene(const mesh::TetMesh& m, int w, int h) {
    Scene s = orthoScene(m, w, h, {-0.4, 0.5, 1.0});
    s.camera->projection = Projection::Perspective;
    s.camera->fovYDeg = 40.0;
    return s;
}

using test::maxAbsDiff;
using test::meanAlpha;
using test::meshTf;

ImageBuffer mirrorOf(KBufferRenderer& r, const mesh::TetMesh& m, KBufferMirrorStats* stats = nullptr) {
    return kbufferMirrorRender(test::kbufferMirrorInputOf(r), stats);
}

/// Two boxes [0,1]^2 x [0,1] and [0,1]^2 x [2,3] in one mesh: rays along z leave and re-enter.
mesh::TetMesh twoBoxes(float value) {
    auto a = mesh::generateHexGridMesh({3, 3, 3}, {0, 0, 0}, {1, 1, 1},
                                       [&](double, double, double) { return value; });
    auto b = mesh::generateHexGridMesh({3, 3, 3}, {0, 0, 2}, {1, 1, 3},
                                       [&](double, double, double) { return value; });
    mesh::TetSoup soup;
    soup.points = a.points;
    soup.scalars = a.scalars;
    soup.tets = a.tets;
    const auto off = std::uint32_t(a.points.size());
    soup.points.insert(soup.points.end(), b.points.begin(), b.points.end());
    soup.scalars.insert(soup.scalars.end(), b.scalars.begin(), b.scalars.end());
    for (auto t : b.tets)
        soup.tets.push_back({t[0] + off, t[1] + off, t[2] + off, t[3] + off});
    return mesh::buildTetMesh(std::move(soup), "two boxes", "v");
}

/// A grid graded along every axis (cells from 0.005 to 0.42 of the edge): faces of very different sizes,
/// which splitLongFaces cuts. The scalar is linear, 0.1 x + y - z.
mesh::TetMesh gradedGrid() {
    auto m = mesh::generateHexGridMesh({6, 6, 6}, {0, 0, 0}, {1, 1, 1},
                                       [](double, double, double) { return 0.0; });
    for (std::size_t i = 0; i < m.points.size(); ++i) {
        auto& p = m.points[i];
        for (double& c : p)
            c = c * c * c;
        m.scalars[i] = float(0.1 * p[0] + p[1] - p[2]);
    }
    m.valueMin = *std::min_element(m.scalars.begin(), m.scalars.end());
    m.valueMax = *std::max_element(m.scalars.begin(), m.scalars.end());
    m.maxEdgeLength = 0;
    for (const auto& t : m.tets)
        for (int a = 0; a < 4; ++a)
            for (int b = a + 1; b < 4; ++b)
                m.maxEdgeLength = std::max(m.maxEdgeLength, norm(sub(m.points[t[a]], m.points[t[b]])));
    return m;
}

} // namespace

TEST(RadixSort, FloatKeysOrderAsTheFloats) {
    const float inf = std::numeric_limits<float>::infinity();
    const std::vector<float> v{-inf, -1e30f, -1.0f, -1e-40f, -0.0f, 0.0f, 1e-40f, 1e-30f, 1.0f, 3e38f, inf};
    for (std::size_t i = 1; i < v.size(); ++i)
        EXPECT_LT(floatSortKey(v[i - 1]), floatSortKey(v[i])) << v[i - 1] << " vs " << v[i];
}

TEST(RadixSort, ReferenceIsAStableSort) {
    std::mt19937 rng(7);
    std::vector<std::uint32_t> keys(5000), vals(5000);
    for (auto& k : keys)
        k = floatSortKey(float(int(rng() % 200) - 100) * 0.25f); // many duplicates, negatives
    std::iota(vals.begin(), vals.end(), 0u);
    std::vector<std::size_t> expect(keys.size());
    std::iota(expect.begin(), expect.end(), 0u);
    std::stable_sort(expect.begin(), expect.end(),
                     [&](std::size_t a, std::size_t b) { return keys[a] < keys[b]; });
    auto k2 = keys;
    radixSortReference(k2, vals);
    for (std::size_t i = 0; i < expect.size(); ++i) {
        ASSERT_EQ(vals[i], expect[i]) << i;
        ASSERT_EQ(k2[i], keys[expect[i]]);
    }
}

TEST(RadixSort, DeviceMatchesReference) {
    ComputeContext& cc = context();
    DeviceRadixSort sorter(cc);
    std::mt19937 rng(11);
    for (std::size_t n : {std::size_t(0), std::size_t(1), std::size_t(2), std::size_t(127), std::size_t(1000),
                          std::size_t(100003)}) {
        std::vector<std::uint32_t> keys(n), vals(n);
        for (auto& k : keys)
            k = (rng() % 3 == 0) ? floatSortKey(float(rng() % 50)) : rng();
        std::iota(vals.begin(), vals.end(), 0u);
        auto dk = cc.upload(keys), dv = cc.upload(vals);
        sorter.sort(dk, dv, n);
        radixSortReference(keys, vals);
        EXPECT_EQ(cc.download(dk), keys) << n;
        EXPECT_EQ(cc.download(dv), vals) << n;
    }
}

TEST(MeshFaces, InternalFacesOnceBoundaryFirst) {
    const auto m = mesh::generateHexGridMesh({3, 2, 2}, {0, 0, 0}, {3, 2, 2},
                                             [](double x, double, double) { return x; });
    const MeshFaces f = buildMeshFaces(m);
    EXPECT_EQ(f.boundaryCount, m.boundaryFaces.size());
    EXPECT_EQ(f.internalCount(), m.internalFaceCount());
    EXPECT_EQ(f.faces.size() * 2, 4 * m.tetCount() + m.boundaryFaces.size());
    std::set<std::array<std::uint32_t, 3>> seen;
    for (std::size_t i = 0; i < f.faces.size(); ++i) {
        auto v = f.faces[i].v;
        std::sort(v.begin(), v.end());
        EXPECT_TRUE(seen.insert(v).second) << "face " << i << " appears twice";
        EXPECT_EQ(f.faces[i].boundary, i < f.boundaryCount);
    }
    EXPECT_EQ(f.prefixForFraction(0.0), f.boundaryCount);
    EXPECT_EQ(f.prefixForFraction(1.0), f.faces.size());
    EXPECT_EQ(f.prefixForFraction(0.5), f.boundaryCount + (f.internalCount() + 1) / 2);
    const auto single =
        mesh::generateHexGridMesh({1, 1, 1}, {0, 0, 0}, {1, 1, 1}, [](double, double, double) { return 0; });
    EXPECT_EQ(buildMeshFaces(single).boundaryCount, 12u);
}

TEST(MeshFaces, SplitLongFacesCoversTheFaceWithItsWinding) {
    // A graded grid: its long faces are cut; the pieces keep area, normal direction and scalar.
    const auto m = gradedGrid();
    const MeshFaces plain = buildMeshFaces(m);
    MeshFaces cut = plain;
    const std::size_t added = splitLongFaces(cut, m, 1.5, 3.0);
    ASSERT_GT(added, 0u);
    EXPECT_EQ(cut.faces.size(), plain.faces.size() + added);
    EXPECT_LE(double(added), 3.0 * double(plain.faces.size()));
    EXPECT_GT(cut.boundaryCount, plain.boundaryCount);
    auto P = [&](std::uint32_t i) {
        return i < m.points.size() ? m.points[i] : cut.extraPoints[i - m.points.size()];
    };
    auto S = [&](std::uint32_t i) {
        return i < m.points.size() ? m.scalars[i] : cut.extraScalars[i - m.points.size()];
    };
    auto areaVector = [&](const MeshFace& f) {
        return scale(cross(sub(P(f.v[1]), P(f.v[0])), sub(P(f.v[2]), P(f.v[0]))), 0.5);
    };
    Vec3 sumPlain{0, 0, 0}, sumCut{0, 0, 0};
    double absPlain = 0, absCut = 0;
    for (const auto& f : plain.faces) {
        sumPlain = add(sumPlain, areaVector(f));
        absPlain += norm(areaVector(f));
    }
    for (std::size_t i = 0; i < cut.faces.size(); ++i) {
        const auto& f = cut.faces[i];
        EXPECT_EQ(f.boundary, i < cut.boundaryCount);
        sumCut = add(sumCut, areaVector(f));
        absCut += norm(areaVector(f));
        for (std::uint32_t v : f.v) // the field is linear: every point keeps its value
            EXPECT_NEAR(S(v), 0.1 * P(v)[0] + P(v)[1] - P(v)[2], 1e-5);
    }
    EXPECT_NEAR(absCut, absPlain, 1e-9 * absPlain); // pieces tile their faces exactly, none flipped
    for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(sumCut[c], sumPlain[c], 1e-9 * absPlain);
}

TEST(KBuffer, KernelMatchesMirror) {
    ComputeContext& cc = context();
    const auto ml = mesh::marschnerLobbMesh(6);
    const auto grid =
        mesh::generateHexGridMesh({5, 4, 3}, {-1, 0, 2}, {2, 1.5, 3}, [](double x, double y, double z) {
            return (x + 1) / 3 * 0.7 + 0.1 * y * z;
        });
    const TransferFunction tf = rampTf(2.0);
    int cases = 0;
    const auto graded = gradedGrid(); // its long faces are cut: the mirror draws the same pieces
    for (const mesh::TetMesh* m : {&ml, &grid, &graded}) {
        const TransferFunction mtf = tf.rescaled({m->valueMin, m->valueMax});
        for (bool persp : {false, true}) {
            Scene s = persp ? perspectiveScene(*m, 83, 61) : orthoScene(*m, 83, 61);
            // The device radix sort on two meshes (the graded one with its long faces cut), the host's MPVO
            // face order (the default for a convex mesh; no faces cut) on the third.
            if (m != &grid) s.meshSort = MeshSort::Centroid;
            KBufferRenderer r(cc, *m, mtf, s, 2);
            EXPECT_EQ(r.sortMethod(), m == &grid ? MeshSort::Mpvo : MeshSort::Centroid);
            if (m == &graded) EXPECT_GT(r.geometry().points.size(), m->points.size());
            for (int k : {2, 6, 8}) {
                r.setK(k);
                for (double lod : {1.0, 0.3}) {
                    r.setLodFraction(lod);
                    const ImageBuffer dev = r.render();
                    KBufferMirrorStats st;
                    const ImageBuffer ref = mirrorOf(r, *m, &st);
                    EXPECT_LE(maxAbsDiff(dev, ref), 2e-5)
                        << "persp " << persp << " k " << k << " lod " << lod;
                    double alpha = 0;
                    for (std::size_t i = 3; i < dev.pixels.size(); i += 4)
                        alpha += dev.pixels[i];
                    EXPECT_GT(alpha, 1.0) << "the image must not be empty";
                    EXPECT_GT(st.fragments, 100u);
                    KBufferMirrorInput in{&r.geometry(),   &r.geometry().scalars, &r.faces(),
                                          r.frameParams(), &r.tableValues(),      k};
                    if (r.hostOrder()) { // the device drew the host's order: every drawn face once
                        EXPECT_EQ(r.lastOrder(), *r.hostOrder());
                        std::vector<cl_uint> sorted = r.lastOrder();
                        std::sort(sorted.begin(), sorted.end());
                        for (std::size_t i = 0; i < sorted.size(); ++i)
                            ASSERT_EQ(sorted[i], i) << "persp " << persp << " lod " << lod;
                        EXPECT_EQ(sorted.size(), r.facesDrawn());
                    } else {
                        EXPECT_EQ(r.lastOrder(), kbufferMirrorOrder(in));
                    }
                    ++cases;
                }
            }
        }
    }
    EXPECT_EQ(cases, 36);
}

TEST(KBufferOrder, ExactCellOrderBringsFragmentsInRayOrder) {
    // The faces placed by an exact cell order (MPVO on the convex grids, the convexified sort on two boxes with
    // a gap) reach every pixel in ray order: the C++ mirror at k = 2 (one fragment held back) never pops a
    // fragment nearer than the pixel's previous pop. The mirror compares the fragments' own distances, so this
    // checks the placement against the geometry, not against the sort's algorithm. The centroid sort of the
    // graded grid (slivers 20:1) does pop out of order at k = 2: the check can fail.
    ComputeContext& cc = context();
    const auto ml = mesh::marschnerLobbMesh(6);
    const auto graded = gradedGrid();
    const auto boxes = twoBoxes(0.4f);
    const TransferFunction tf = rampTf(2.0);
    for (const mesh::TetMesh* m : {&ml, &graded, &boxes})
        for (bool persp : {false, true}) {
            const TransferFunction mtf = tf.rescaled({m->valueMin, m->valueMax + 1e-3});
            Scene s = persp ? perspectiveScene(*m, 83, 61) : orthoScene(*m, 83, 61);
            KBufferRenderer r(cc, *m, mtf, s, 2);
            EXPECT_EQ(r.sortMethod(), m == &boxes ? MeshSort::Convexified : MeshSort::Mpvo);
            r.render();
            ASSERT_NE(r.hostOrder(), nullptr);
            EXPECT_EQ(r.lastCyclesBroken(), 0u);
            const std::vector<std::uint32_t> full = *r.hostOrder();
            KBufferMirrorStats st;
            kbufferMirrorRender(test::kbufferMirrorInputOf(r), &st);
            EXPECT_GT(st.fragments, 1000u);
            EXPECT_EQ(st.misorderedPops, 0u) << m->tetCount() << " tets, persp " << persp;
            // A level-of-detail frame draws a subsequence of the same order.
            r.setLodFraction(0.3);
            r.render();
            std::vector<std::uint32_t> prefix;
            for (std::uint32_t f : full)
                if (f < r.facesDrawn()) prefix.push_back(f);
            EXPECT_EQ(*r.hostOrder(), prefix);
            if (m == &graded) {
                Scene c = s;
                c.meshSort = MeshSort::Centroid;
                KBufferRenderer rc(cc, *m, mtf, c, 2);
                rc.render();
                EXPECT_EQ(rc.hostOrder(), nullptr);
                KBufferMirrorStats sc;
                kbufferMirrorRender(test::kbufferMirrorInputOf(rc), &sc);
                std::cout << "graded grid, persp " << persp << ": out-of-order pops at k = 2, centroid "
                          << sc.misorderedPops << ", visibility order " << st.misorderedPops << '\n';
                EXPECT_GT(sc.misorderedPops, 0u);
            }
        }
}

TEST(KBufferOrder, SceneSwitchesTheOrderAndItsFacesAndThePlanSaysWhich) {
    // render.sort on a live renderer: the centroid sort cuts the graded grid's long faces, MPVO draws them uncut,
    // and each frame equals a fresh renderer's of the same scene; --explain's line names the order.
    ComputeContext& cc = context();
    const auto m = gradedGrid();
    const TransferFunction tf = rampTf(2.0).rescaled({m.valueMin, m.valueMax});
    Scene s = orthoScene(m, 40, 32);
    s.meshSort = MeshSort::Centroid;
    KBufferRenderer r(cc, m, tf, s, 6);
    const std::size_t uncut = buildMeshFaces(m).faces.size();
    EXPECT_GT(r.faces().faces.size(), uncut);
    auto planLine = [&](const KBufferRenderer& kr) {
        for (const std::string& c : kr.plan().compiled)
            if (c.find("k-buffer (HAVS)") != std::string::npos) return c;
        return std::string();
    };
    EXPECT_NE(planLine(r).find("sorted by centroid"), std::string::npos) << planLine(r);
    for (MeshSort sort : {MeshSort::Mpvo, MeshSort::Centroid}) {
        s.meshSort = sort;
        r.setScene(s);
        EXPECT_EQ(r.sortMethod(), sort);
        EXPECT_EQ(r.faces().faces.size() == uncut, sort == MeshSort::Mpvo);
        KBufferRenderer fresh(cc, m, tf, s, 6);
        EXPECT_LE(maxAbsDiff(r.render(), fresh.render()), 0.0) << meshSortName(sort);
        if (sort == MeshSort::Mpvo)
            EXPECT_NE(planLine(r).find("mpvo visibility order of the cells"), std::string::npos)
                << planLine(r);
    }
    s.meshSort.reset(); // unset: the mesh is convex and its tets do not overlap
    r.setScene(s);
    EXPECT_EQ(r.sortMethod(), MeshSort::Mpvo);
    EXPECT_EQ(defaultKBufferSort(twoBoxes(0.5f)), MeshSort::Convexified);
    // Folded tets (jitter 0.45 cells: overlapping face pairs) have no cell order: the centroid sort stays.
    const mesh::TetMesh folded =
        test::jitteredMesh(6, 0.45, false, [](double, double, double) { return false; });
    ASSERT_GT(folded.repairs.overlappingFaces + folded.repairs.nonManifoldFaces, 0u);
    EXPECT_EQ(defaultKBufferSort(folded), MeshSort::Centroid);
}

TEST(KBuffer, NanCellsMatchTheMirror) {
    // NaN and Inf points on the graded grid (its long faces cut: split points between a NaN vertex and another
    // are NaN too): segments with a non-finite end are constant NaN-colour segments on both sides.
    ComputeContext& cc = context();
    mesh::TetMesh m = gradedGrid();
    for (std::size_t i = 0; i < m.points.size(); ++i)
        if (std::abs(m.points[i][0] - 0.3) < 0.1 && m.points[i][1] > 0.2) m.scalars[i] = NAN;
    m.scalars[m.points.size() / 2] = INFINITY;
    const TransferFunction tf = rampTf(2.0).rescaled({m.valueMin, m.valueMax});
    for (bool persp : {false, true})
        for (MeshSort sort :
             {MeshSort::Centroid, MeshSort::Mpvo}) { // cut faces; the exact order's uncut ones
            Scene s = persp ? perspectiveScene(m, 83, 61) : orthoScene(m, 83, 61);
            s.nanColor = {0.0, 1.0, 0.0, 0.8};
            s.meshSort = sort;
            KBufferRenderer r(cc, m, tf, s, 6);
            EXPECT_NE(r.plan().defines.toOptions().find("-DNAN_COLOR"), std::string::npos);
            for (double lod : {1.0, 0.3}) {
                r.setLodFraction(lod);
                const ImageBuffer dev = r.render();
                KBufferMirrorInput in = test::kbufferMirrorInputOf(r);
                in.nanColor = {0.0f, 1.0f, 0.0f, float(-std::log1p(-0.8))};
                const ImageBuffer ref = kbufferMirrorRender(in);
                EXPECT_LE(maxAbsDiff(dev, ref), 2e-5)
                    << "persp " << persp << " sort " << meshSortName(sort) << " lod " << lod;
                int green = 0; // pixels the NaN colour dominates: the TF's colours are never mostly green
                for (std::size_t i = 0; i < dev.pixels.size(); i += 4)
                    green += dev.pixels[i + 1] > dev.pixels[i] + 0.2f &&
                             dev.pixels[i + 1] > dev.pixels[i + 2] + 0.2f;
                EXPECT_GT(green, 20) << "the NaN cells must show";
            }
        }
}

TEST(KBuffer, ConstantScalarGivesTheChordIntegral) {
    // One value everywhere: every pixel is the segment integral over its chord through the box.
    ComputeContext& cc = context();
    const auto m = mesh::generateHexGridMesh({4, 4, 4}, {0, 0, 0}, {1, 1, 1},
                                             [](double, double, double) { return 0.55; });
    const TransferFunction tf = rampTf(1.5);
    Scene s = orthoScene(m, 32, 32, {0, 0, 1});
    s.camera->height = 2.0;
    s.tableSize = 128;
    s.tableLengths = 32;
    for (int k : {2, 6}) {
        KBufferRenderer r(cc, m, tf, s, k);
        const ImageBuffer img = r.render();
        const auto exact = referenceSegment(tf, 0.55, 0.55, 1.0);
        int inside = 0;
        for (int y = 0; y < 32; ++y)
            for (int x = 0; x < 32; ++x) {
                const auto ray = cameraRay(*s.camera, 32, 32, x + 0.5, y + 0.5);
                const bool in = ray.origin[0] > 1e-9 && ray.origin[0] < 1 - 1e-9 && ray.origin[1] > 1e-9 &&
                                ray.origin[1] < 1 - 1e-9;
                if (!in) {
                    if (std::abs(ray.origin[0] - 0.5) > 0.55 || std::abs(ray.origin[1] - 0.5) > 0.55)
                        EXPECT_EQ(img.at(x, y, 3), 0.0f) << x << "," << y;
                    continue;
                }
                ++inside;
                for (int c = 0; c < 4; ++c)
                    EXPECT_NEAR(img.at(x, y, c), exact[c], 2e-3)
                        << "k " << k << " pixel " << x << "," << y << " c " << c;
            }
        EXPECT_GT(inside, 200);
    }
}

TEST(KBuffer, GapBetweenBoxesStaysEmpty) {
    // A ray leaves the first box and re-enters the second: the gap between them adds nothing.
    ComputeContext& cc = context();
    const auto m = twoBoxes(0.3f);
    const TransferFunction tf = rampTf(1.0);
    Scene s = orthoScene(m, 24, 24, {0, 0, 1});
    s.camera->height = 1.6;
    s.tableSize = 128;
    s.tableLengths = 32;
    KBufferRenderer r(cc, m, tf, s, 6);
    const ImageBuffer img = r.render();
    const auto one = referenceSegment(tf, 0.3, 0.3, 1.0);
    const double alpha = 1.0 - (1.0 - one[3]) * (1.0 - one[3]);
    const double red = one[0] + (1.0 - one[3]) * one[0];
    EXPECT_NEAR(img.at(12, 12, 3), alpha, 2e-3);
    EXPECT_NEAR(img.at(12, 12, 0), red, 2e-3);
    // Gap counted as inside would give the chord of length 3.
    const auto three = referenceSegment(tf, 0.3, 0.3, 3.0);
    EXPECT_GT(std::abs(img.at(12, 12, 3) - three[3]), 0.05);
}

TEST(KBuffer, EarlyTerminationStopsAtTheThreshold) {
    ComputeContext& cc = context();
    const auto m = mesh::generateHexGridMesh({4, 4, 4}, {0, 0, 0}, {1, 1, 1},
                                             [](double x, double, double) { return x; });
    const TransferFunction tf = rampTf(20.0);
    Scene s = orthoScene(m, 32, 32);
    KBufferRenderer full(cc, m, tf, s, 6);
    const ImageBuffer a = full.render();
    s.earlyTermination = 0.9;
    KBufferRenderer et(cc, m, tf, s, 6);
    const ImageBuffer b = et.render();
    EXPECT_LE(maxAbsDiff(b, mirrorOf(et, m)), 2e-5);
    int stopped = 0;
    for (std::size_t i = 3; i < a.pixels.size(); i += 4) {
        if (b.pixels[i] >= 0.9f) ++stopped;
        EXPECT_LE(b.pixels[i], a.pixels[i] + 1e-5f);
        EXPECT_LE(a.pixels[i] - b.pixels[i], 0.1f + 1e-5f);
    }
    EXPECT_GT(stopped, 50);
}

TEST(KBuffer, HugeAndTinyCoordinatesAreFiniteAndMatchTheMirror) {
    ComputeContext& cc = context();
    for (double scale : {1e-30, 1e30}) {
        const auto m = mesh::generateHexGridMesh({2, 2, 2}, {0, 0, 0}, {scale, scale, scale},
                                                 [&](double x, double, double) { return x / scale; });
        const TransferFunction tf = TransferFunction::fromJson(R"({"domain": [0, 1],
          "color": [[0, 1, 0, 0], [1, 0, 0, 1]], "extinction": [[0, 0], [1, 0]]})");
        Scene s = orthoScene(m, 20, 20);
        KBufferRenderer r(cc, m, tf, s, 6);
        const ImageBuffer img = r.render();
        for (float v : img.pixels) {
            ASSERT_TRUE(std::isfinite(v));
            ASSERT_GE(v, 0.0f);
            ASSERT_LE(v, 1.0f);
        }
        EXPECT_LE(maxAbsDiff(img, mirrorOf(r, m)), 2e-5) << scale;
    }
}

TEST(KBuffer, SingleTetAndRefusals) {
    ComputeContext& cc = context();
    mesh::TetSoup soup;
    soup.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    soup.scalars = {0, 1, 0.5f, 0.25f};
    soup.tets = {{0, 1, 2, 3}};
    const auto m = mesh::buildTetMesh(std::move(soup), "tet", "v");
    const TransferFunction tf = rampTf(3.0);
    Scene s = orthoScene(m, 40, 40);
    KBufferRenderer r(cc, m, tf, s, 2);
    const ImageBuffer img = r.render();
    EXPECT_LE(maxAbsDiff(img, mirrorOf(r, m)), 2e-5);
    double alpha = 0;
    for (std::size_t i = 3; i < img.pixels.size(); i += 4)
        alpha += img.pixels[i];
    EXPECT_GT(alpha, 1.0);
    EXPECT_THROW(KBufferRenderer(cc, m, tf, s, 1), UsageError);
    EXPECT_THROW(KBufferRenderer(cc, m, tf, s, 9), UsageError);
    Scene mip = s;
    mip.mode = RenderMode::Mip;
    EXPECT_THROW(KBufferRenderer(cc, m, tf, mip, 6), UsageError);
    EXPECT_THROW(r.setLodFraction(1.5), UsageError);
    Scene shaded = s;
    shaded.effects.shading = true;
    const EffectPlan p = r.planEffects(shaded);
    ASSERT_FALSE(p.dropped.empty());
}

namespace {

/// The three-quarter orthographic view of the mesh's box at w x h, 3D table, no early termination.
Scene quarterView(const mesh::TetMesh& m, int w, int h) {
    Scene s;
    s.width = w;
    s.height = h;
    s.camera = frameBox(meshBounds(m), orbitDirection(35.0, 25.0), Projection::Orthographic, 30.0, 1.0);
    s.earlyTermination = 1.0;
    s.preintegration = Preintegration::Table3d;
    s.tableLengths = 32;
    return s;
}

/// k-buffer through RenderInput (render.method "kbuffer", render.k) against the exact reference: RGBA RMSE.
double kbufferVsReference(const mesh::TetMesh& m, const TransferFunction& tf, Scene s, int k,
                          ImageBuffer* refOut = nullptr) {
    s.meshMethod = MeshMethod::KBuffer;
    s.kBufferDepth = k;
    const RenderInput in = RenderInput::borrowMesh(m);
    auto r = in.makeRenderer(context(), tf, s);
    const ImageBuffer img = r->render();
    const ImageBuffer ref = in.renderReference(tf, s);
    if (refOut) *refOut = ref;
    return imageRmse(img, ref);
}

} // namespace

TEST(KBufferAccuracy, SharedMeshesAtK6MatchTheReference) {
    std::filesystem::path data;
    VOLCL_REQUIRE_SHARED_DATA(data);
    const auto dir = data / "unstructured";
    if (!std::filesystem::is_directory(dir)) GTEST_SKIP() << dir << " is absent";
    struct Case {
        std::string file;
        int qVar;
    };
    int done = 0;
    for (const Case& c : std::vector<Case>{{"tetraMesh.vtk", 0},
                                           {"xsmall_turb.vtu", 0},
                                           {"kiefer/dataset.vtu", 0},
                                           {"bluntfinxyz.bin", 0},
                                           {"combxyz.bin", 0},
                                           {"postxyz.bin", 4}}) {
        if (!std::filesystem::exists(dir / c.file)) continue;
        mesh::MeshReadOptions o;
        o.qVariable = c.qVar;
        const mesh::TetMesh m = mesh::readMesh(dir / c.file, o);
        ImageBuffer ref;
        const double e = kbufferVsReference(m, meshTf(m, 4.0), quarterView(m, 64, 64), 6, &ref);
        std::cout << c.file << " q" << c.qVar << ": " << m.tetCount() << " tets, k 6 RMSE " << e
                  << ", mean alpha " << meanAlpha(ref) << '\n';
        EXPECT_LE(e, 0.01) << c.file;
        EXPECT_GT(meanAlpha(ref), 0.003) << c.file;
        ++done;
    }
    EXPECT_GT(done, 0);
}

TEST(KBufferAccuracy, NonConvexMeshAndPerspective) {
    // Two boxes with a linear field: rays leave the first and re-enter the second.
    mesh::TetMesh m = twoBoxes(0.0f);
    for (std::size_t i = 0; i < m.points.size(); ++i)
        m.scalars[i] = float(m.points[i][0] + 2.0 * m.points[i][1] + 0.5 * m.points[i][2]);
    m.valueMin = *std::min_element(m.scalars.begin(), m.scalars.end());
    m.valueMax = *std::max_element(m.scalars.begin(), m.scalars.end());
    const TransferFunction tf = meshTf(m, 3.0);
    Scene s = quarterView(m, 48, 48);
    s.camera = frameBox(meshBounds(m), orbitDirection(20.0, 10.0), Projection::Orthographic, 30.0, 1.0);
    ImageBuffer ref;
    const double e = kbufferVsReference(m, tf, s, 6, &ref);
    EXPECT_LE(e, 0.01);
    EXPECT_GT(meanAlpha(ref), 0.02);
    Scene p = s;
    p.camera = frameBox(meshBounds(m), orbitDirection(-30.0, 20.0), Projection::Perspective, 35.0, 1.0);
    EXPECT_LE(kbufferVsReference(m, tf, p, 6), 0.01);
    // Along the gap's axis: the gap of length 1 between the boxes must not count.
    Scene axis = s;
    axis.camera->eye = {0.5, 0.5, -5.0};
    axis.camera->target = {0.5, 0.5, 1.5};
    axis.camera->up = {0, 1, 0};
    axis.camera->height = 1.4;
    EXPECT_LE(kbufferVsReference(m, tf, axis, 2), 0.01);
}

TEST(KBufferAccuracy, ErrorFallsWithK) {
    // Slivers: a grid stretched 20:1 puts many fragments out of centroid order; a larger k repairs them.
    const auto m =
        mesh::generateHexGridMesh({6, 6, 6}, {0, 0, 0}, {20, 1, 1},
                                  [](double x, double y, double z) { return std::sin(x * 0.4) + y * z; });
    const TransferFunction tf = meshTf(m, 3.0);
    Scene s = quarterView(m, 64, 64);
    const double e2 = kbufferVsReference(m, tf, s, 2), e8 = kbufferVsReference(m, tf, s, 8);
    std::cout << "stretched grid: RMSE k 2 " << e2 << ", k 8 " << e8 << '\n';
    EXPECT_LE(e8, e2 + 1e-6);
    EXPECT_LE(e8, 0.01);
}
