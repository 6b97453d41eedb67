// The .vcm mesh codec: exact connectivity round trips (as sets of tets), the quantisation bound, hard
// meshes (one tet, components, non-manifold spots, duplicates, slivers, holes), corrupt and forged files.
#include "TestUtil.hpp"

#include "core/Error.hpp"
#include "host/mesh/MeshGenerator.hpp"
#include "host/mesh/MeshIo.hpp"
#include "meshcodec/MeshCodec.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <numeric>
#include <random>

namespace fs = std::filesystem;
using namespace volcl;
using namespace volcl::mesh;
using namespace volcl::meshcodec;

namespace {

std::vector<Tet> sortedTets(std::vector<Tet> tets) {
    for (Tet& t : tets)
        std::sort(t.begin(), t.end());
    std::sort(tets.begin(), tets.end());
    return tets;
}

/// The original's tets mapped through the point renumbering, as a sorted list of sorted tuples.
std::vector<Tet> mappedTets(const TetMesh& m, const std::vector<std::uint32_t>& newIndex) {
    std::vector<Tet> out = m.tets;
    for (Tet& t : out)
        for (std::uint32_t& v : t)
            v = newIndex[v];
    return sortedTets(std::move(out));
}

std::span<const std::uint8_t> bytesOf(const EncodedMesh& e) {
    return e.bytes;
}

/// Encodes, decodes, and checks: same tets (any order), every point within the stated bound (bit-exact
/// when lossless), the decoded renumbering a permutation.
EncodedMesh roundTrip(const TetMesh& m, const VcmOptions& o) {
    EncodedMesh e = encodeMesh(m, o);
    DecodedMesh d = decodeMesh(bytesOf(e), "test.vcm");
    EXPECT_EQ(d.tets.size(), m.tetCount());
    EXPECT_EQ(d.points.size(), m.pointCount());
    std::vector<std::uint32_t> perm = e.newIndex;
    std::sort(perm.begin(), perm.end());
    for (std::size_t i = 0; i < perm.size(); ++i)
        if (perm[i] != i) {
            ADD_FAILURE() << "newIndex is not a permutation";
            break;
        }
    EXPECT_TRUE(mappedTets(m, e.newIndex) == sortedTets(d.tets)) << "connectivity differs";
    double worst[4] = {0, 0, 0, 0};
    for (std::size_t i = 0; i < m.pointCount(); ++i) {
        const std::uint32_t j = e.newIndex[i];
        for (int a = 0; a < 3; ++a) {
            if (o.lossless) {
                EXPECT_EQ(std::bit_cast<std::uint64_t>(d.points[j][a]),
                          std::bit_cast<std::uint64_t>(m.points[i][a]));
            }
            worst[a] = std::max(worst[a], std::abs(d.points[j][a] - m.points[i][a]));
        }
        if (o.lossless) {
            EXPECT_EQ(std::bit_cast<std::uint32_t>(d.scalars[j]), std::bit_cast<std::uint32_t>(m.scalars[i]));
        }
        worst[3] = std::max(worst[3], std::abs(double(d.scalars[j]) - double(m.scalars[i])));
    }
    for (int a = 0; a < 4; ++a) {
        const double bound = quantisationBound(e.header, a);
        // The scalar comes back as a float: its rounding (half an ulp of the largest value) adds to the bound.
        const double slack = a < 3
                                 ? 1e-12 * (std::abs(e.header.boxMax[a]) + std::abs(e.header.boxMin[a]))
                                 : std::max(std::abs(e.header.valueMin), std::abs(e.header.valueMax)) * 6e-8;
        EXPECT_LE(worst[a], bound + slack) << "channel " << a;
    }
    return e;
}

TetMesh build(std::vector<Point3> points, std::vector<Tet> tets) {
    TetSoup s;
    s.scalars.resize(points.size());
    for (std::size_t i = 0; i < points.size(); ++i)
        s.scalars[i] = static_cast<float>(points[i][0] + 2 * points[i][1] - points[i][2]);
    s.points = std::move(points);
    s.tets = std::move(tets);
    return buildTetMesh(std::move(s), "test", "s");
}

/// A mesh with its points and tets shuffled (so the input order says nothing about the traversal).
TetMesh shuffled(const TetMesh& m, unsigned seed) {
    std::mt19937 rng(seed);
    std::vector<std::uint32_t> perm(m.pointCount());
    std::iota(perm.begin(), perm.end(), 0u);
    std::shuffle(perm.begin(), perm.end(), rng);
    std::vector<Point3> pts(m.pointCount());
    for (std::size_t i = 0; i < perm.size(); ++i)
        pts[perm[i]] = m.points[i];
    std::vector<Tet> tets = m.tets;
    for (Tet& t : tets)
        for (auto& v : t)
            v = perm[v];
    std::shuffle(tets.begin(), tets.end(), rng);
    return build(std::move(pts), std::move(tets));
}

TetMesh grid(std::size_t n) {
    return generateHexGridMesh({n, n + 1, n + 2}, {0, 0, 0}, {1, 1.5, 2},
                               [](double x, double y, double z) { return std::sin(3 * x) + y * z; });
}

void bothModes(const TetMesh& m) {
    {
        SCOPED_TRACE("16 bits");
        roundTrip(m, {});
    }
    {
        SCOPED_TRACE("lossless");
        roundTrip(m, {16, true});
    }
    {
        SCOPED_TRACE("5 bits");
        roundTrip(m, {5, false});
    }
}

} // namespace

TEST(MeshCodec, GeneratedGridsRoundTrip) {
    bothModes(grid(4));
    bothModes(shuffled(grid(5), 1));
    bothModes(shuffled(marschnerLobbMesh(6), 2));
}

TEST(MeshCodec, OneTet) {
    bothModes(build({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {{0, 1, 2, 3}}));
}

TEST(MeshCodec, TwoComponents) {
    const TetMesh a = grid(2);
    std::vector<Point3> pts = a.points;
    std::vector<Tet> tets = a.tets;
    for (const Point3& p : a.points)
        pts.push_back({p[0] + 5, p[1], p[2]});
    const auto n = static_cast<std::uint32_t>(a.pointCount());
    for (const Tet& t : a.tets)
        tets.push_back({t[0] + n, t[1] + n, t[2] + n, t[3] + n});
    bothModes(shuffled(build(pts, tets), 3));
}

TEST(MeshCodec, NonManifoldEdgeVertexAndFace) {
    // Two tets sharing only an edge, a third sharing only a vertex with the second, and three tets on one
    // triangle (the mesh builder leaves such a face as boundary on every tet).
    std::vector<Point3> pts = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1},  {1, 1, 1},   {-1, 1, 1},
                               {2, 2, 2}, {3, 2, 2}, {2, 3, 2}, {2, 2, -3}, {2, 2, 3.5}, {0.2, 0.2, -1}};
    std::vector<Tet> tets = {{0, 1, 2, 3},  {1, 2, 4, 5}, {4, 6, 7, 8},
                             {6, 7, 8, 10}, {6, 7, 8, 9}, {0, 1, 2, 11}};
    const TetMesh m = build(pts, tets);
    EXPECT_GT(m.repairs.nonManifoldFaces + m.repairs.overlappingFaces, 0u);
    bothModes(m);
}

TEST(MeshCodec, DuplicateVerticesAndTets) {
    // Duplicate points are merged by the builder; a tet listed twice stays (its copies overlap).
    TetMesh g = grid(2);
    std::vector<Point3> pts = g.points;
    pts.push_back(g.points[0]);
    pts.push_back(g.points[5]);
    std::vector<Tet> tets = g.tets;
    tets.push_back(g.tets[3]);
    const TetMesh m = build(pts, tets);
    EXPECT_EQ(m.repairs.mergedPoints, 2u);
    EXPECT_EQ(m.tetCount(), g.tetCount() + 1);
    bothModes(m);
}

TEST(MeshCodec, SliversAndHoles) {
    // A grid with jittered points (slivers) and a random fifth of the tets removed (holes, cavities,
    // pieces hanging by an edge).
    TetMesh g = grid(6);
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> jitter(-0.02, 0.02);
    for (Point3& p : g.points)
        for (double& c : p)
            c += jitter(rng);
    std::vector<Tet> kept;
    for (const Tet& t : g.tets)
        if (rng() % 5 != 0) kept.push_back(t);
    // A near-flat sliver on top.
    std::vector<Point3> pts = g.points;
    pts.push_back({5, 5, 5});
    pts.push_back({6, 5, 5});
    pts.push_back({5, 6, 5});
    pts.push_back({5.5, 5.5, 5.000001});
    const auto n = static_cast<std::uint32_t>(g.points.size());
    kept.push_back({n, n + 1, n + 2, n + 3});
    const TetMesh m = build(pts, kept);
    bothModes(shuffled(m, 9));
}

TEST(MeshCodec, ReadVcmGivesTheMeshBack) {
    const TetMesh m = shuffled(grid(3), 4);
    const fs::path dir = test::tempDir("mesh_codec_read");
    writeVcm(m, dir / "m.vcm", {16, true});
    EXPECT_TRUE(isVcmFile(dir / "m.vcm"));
    const TetMesh r = readAnyMesh(dir / "m.vcm");
    EXPECT_EQ(r.tetCount(), m.tetCount());
    EXPECT_EQ(r.pointCount(), m.pointCount());
    EXPECT_EQ(r.boundaryFaces.size(), m.boundaryFaces.size());
    EXPECT_DOUBLE_EQ(r.totalVolume(), m.totalVolume());
    EXPECT_EQ(r.scalarName, m.scalarName);
    MeshReadOptions other;
    other.array = "other";
    EXPECT_THROW(readVcm(dir / "m.vcm", other), DataError);
}

TEST(MeshCodec, BadBitsAreAUsageError) {
    EXPECT_THROW(encodeMesh(grid(1), {0, false}), UsageError);
    EXPECT_THROW(encodeMesh(grid(1), {31, false}), UsageError);
}

TEST(MeshCodec, CorruptFilesAreRefused) {
    const EncodedMesh e = encodeMesh(shuffled(grid(2), 5), {});
    const std::vector<std::uint8_t>& good = e.bytes;
    ASSERT_NO_THROW(decodeMesh(good, "x.vcm"));
    // Every single flipped byte.
    for (std::size_t i = 0; i < good.size(); ++i) {
        std::vector<std::uint8_t> bad = good;
        bad[i] ^= 0x41;
        try {
            decodeMesh(bad, "x.vcm");
            ADD_FAILURE() << "flipped byte " << i << " was accepted";
        } catch (const IoError& err) {
            EXPECT_EQ(std::string(err.what()).rfind("x.vcm: ", 0), 0u) << err.what();
        }
    }
    // Every truncation (so every section boundary) and one extra byte.
    for (std::size_t n = 0; n < good.size(); ++n)
        EXPECT_THROW(decodeMesh(std::span(good).first(n), "x.vcm"), IoError) << n;
    std::vector<std::uint8_t> longer = good;
    longer.push_back(0);
    EXPECT_THROW(decodeMesh(longer, "x.vcm"), IoError);
}

TEST(MeshCodec, DamagedSectionsWithValidChecksumsAreRefusedOrBounded) {
    // Sections altered and the checksums recomputed (what the checksums alone would let through): a cut
    // stream is refused; a flipped bit is refused or (raw mantissa bits carry no redundancy) decodes to
    // a mesh of the header's counts with every index in range and every value inside the box.
    const EncodedMesh e = encodeMesh(shuffled(grid(2), 6), {});
    const VcmView v = parseVcm(e.bytes, "x.vcm");
    std::mt19937 rng(11);
    for (std::size_t s = 0; s < kVcmSections; ++s) {
        if (v.sections[s].empty()) continue;
        for (int trial = 0; trial < 40; ++trial) {
            std::array<std::vector<std::uint8_t>, kVcmSections> parts;
            for (std::size_t k = 0; k < kVcmSections; ++k)
                parts[k].assign(v.sections[k].begin(), v.sections[k].end());
            const bool cut = trial % 4 == 3;
            if (cut)
                parts[s].pop_back();
            else
                parts[s][rng() % parts[s].size()] ^= static_cast<std::uint8_t>(1u << (rng() % 8));
            VcmHeader h = v.header;
            for (std::size_t k = 0; k < kVcmSections; ++k)
                h.sectionSize[k] = parts[k].size();
            const auto bytes = assembleVcm(h, {parts[0], parts[1], parts[2], parts[3]});
            if (cut) {
                EXPECT_THROW(decodeMesh(bytes, "x.vcm"), IoError) << "section " << s << " trial " << trial;
                continue;
            }
            try {
                const DecodedMesh d = decodeMesh(bytes, "x.vcm");
                EXPECT_EQ(d.tets.size(), h.tets);
                EXPECT_EQ(d.points.size(), h.points);
                for (const Tet& t : d.tets)
                    for (const std::uint32_t i : t)
                        EXPECT_LT(i, h.points);
                for (const Point3& p : d.points)
                    for (int a = 0; a < 3; ++a) {
                        EXPECT_GE(p[a], h.boxMin[a]);
                        EXPECT_LE(p[a], h.boxMax[a] * (1 + 1e-12));
                    }
            } catch (const IoError&) {
            }
        }
    }
}

TEST(MeshCodec, ForgedCountsAreRefusedBeforeWork) {
    const EncodedMesh e = encodeMesh(grid(2), {});
    const VcmView v = parseVcm(e.bytes, "x.vcm");
    const auto forged = [&](std::uint64_t points, std::uint64_t tets) {
        VcmHeader h = v.header;
        h.points = points;
        h.tets = tets;
        return assembleVcm(h, v.sections);
    };
    EXPECT_THROW(decodeMesh(forged(v.header.points, std::uint64_t(1) << 29), "x.vcm"), IoError);
    EXPECT_THROW(decodeMesh(forged(std::uint64_t(1) << 40, v.header.tets), "x.vcm"), IoError);
    EXPECT_THROW(decodeMesh(forged(3, 1), "x.vcm"), IoError);
    EXPECT_THROW(decodeMesh(forged(v.header.points, 0), "x.vcm"), IoError);
    // Counts within the bounds but not what the streams hold.
    EXPECT_THROW(decodeMesh(forged(v.header.points, v.header.tets + 1), "x.vcm"), IoError);
    EXPECT_THROW(decodeMesh(forged(v.header.points + 1, v.header.tets), "x.vcm"), IoError);
    EXPECT_THROW(decodeMesh(forged(v.header.points, v.header.tets - 1), "x.vcm"), IoError);
}

// The shared meshes: exact connectivity, <= 3 bits per tet of connectivity (the bar).
TEST(MeshCodec, SharedMeshes) {
    fs::path d;
    VOLCL_REQUIRE_SHARED_DATA(d);
    d /= "unstructured";
    for (const char* name : {"xsmall_turb.vtu", "bluntfinxyz.bin", "tetraMesh.vtk"}) {
        SCOPED_TRACE(name);
        const TetMesh m = readMesh(d / name);
        roundTrip(m, {16, true});
        const EncodedMesh e = roundTrip(m, {});
        const double bitsPerTet =
            8.0 * double(e.header.sectionSize[ConnectivityRans] + e.header.sectionSize[ConnectivityRaw]) /
            double(m.tetCount());
        if (std::string(name) != "tetraMesh.vtk") {
            EXPECT_LE(bitsPerTet, 3.0);
        }
    }
}
