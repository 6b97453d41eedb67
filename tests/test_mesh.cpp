// Tetrahedral meshes: model repairs, adjacency closure, splitting, readers on real meshes, .vtu round trips,
// refusals.
#include "TestUtil.hpp"

#include "core/Error.hpp"
#include "host/mesh/CellSplit.hpp"
#include "host/mesh/MeshGenerator.hpp"
#include "host/mesh/MeshIo.hpp"

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <set>

namespace fs = std::filesystem;
using namespace volcl;
using namespace volcl::mesh;

namespace {

// Every internal face has exactly one neighbour, the neighbour points back, and both sides name the
// same three points in opposite winding; boundary faces are exactly the faces without a neighbour.
void expectAdjacencyCloses(const TetMesh& m) {
    ASSERT_EQ(m.neighbors.size(), 4 * m.tets.size());
    std::size_t boundary = 0;
    for (FaceId f = 0; f < m.neighbors.size(); ++f) {
        const FaceId g = m.neighbors[f];
        if (g == kNoFace) {
            ++boundary;
            continue;
        }
        ASSERT_EQ(m.neighbors[g], f);
        auto a = m.faceVertices(f), b = m.faceVertices(g);
        std::set<std::uint32_t> sa(a.begin(), a.end()), sb(b.begin(), b.end());
        ASSERT_EQ(sa, sb);
        ASSERT_NE(faceTet(f), faceTet(g));
    }
    EXPECT_EQ(boundary, m.boundaryFaces.size());
    for (std::size_t t = 0; t < m.tets.size(); ++t)
        ASSERT_GT(m.volume(t), 0.0) << "tet " << t;
}

TetSoup unitTet() {
    TetSoup s;
    s.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    s.scalars = {0, 1, 2, 3};
    s.tets = {{0, 1, 2, 3}};
    return s;
}

void writeText(const fs::path& p, const std::string& s) {
    std::ofstream(p, std::ios::binary) << s;
}

std::string readText(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), {}};
}

std::string errorOf(const std::function<void()>& f) {
    try {
        f();
    } catch (const Error& e) {
        return e.what();
    }
    return "";
}

const char* kLegacyTet = "# vtk DataFile Version 2.0\nt\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 float\n"
                         "0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\nPOINT_DATA 4\n"
                         "SCALARS s float 1\nLOOKUP_TABLE default\n0 1 2 3\n";

} // namespace

TEST(TetMesh, SingleTet) {
    TetMesh m = buildTetMesh(unitTet(), "t", "s");
    EXPECT_EQ(m.tetCount(), 1u);
    EXPECT_EQ(m.boundaryFaces.size(), 4u);
    EXPECT_EQ(m.internalFaceCount(), 0u);
    EXPECT_DOUBLE_EQ(m.totalVolume(), 1.0 / 6.0);
    EXPECT_EQ(m.valueMin, 0.0f);
    EXPECT_EQ(m.valueMax, 3.0f);
    EXPECT_DOUBLE_EQ(m.maxEdgeLength, std::sqrt(2.0));
    expectAdjacencyCloses(m);
    // Outward winding: every face normal points away from the opposite vertex.
    for (unsigned f = 0; f < 4; ++f) {
        const auto v = m.faceVertices(faceId(0, f));
        const auto &a = m.points[v[0]], &b = m.points[v[1]], &c = m.points[v[2]], &o = m.points[m.tets[0][f]];
        const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]},
                     w[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        const double n[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]};
        EXPECT_LT(n[0] * (o[0] - a[0]) + n[1] * (o[1] - a[1]) + n[2] * (o[2] - a[2]), 0.0) << "face " << f;
    }
}

TEST(TetMesh, InvertedAndZeroVolumeTets) {
    TetSoup s = unitTet();
    s.points.push_back({1, 1, 0}); // 4: coplanar with 0,1,2
    s.scalars.push_back(4);
    s.tets = {{0, 2, 1, 3},  // inverted
              {0, 1, 2, 4},  // flat: zero volume
              {0, 1, 1, 3}}; // repeated vertex
    TetMesh m = buildTetMesh(std::move(s), "t", "s");
    EXPECT_EQ(m.tetCount(), 1u);
    EXPECT_EQ(m.repairs.invertedTets, 1u);
    EXPECT_EQ(m.repairs.zeroVolumeTets, 2u);
    EXPECT_EQ(m.repairs.unusedPoints, 1u);
    EXPECT_EQ(m.pointCount(), 4u);
    EXPECT_GT(m.volume(0), 0.0);
    TetSoup all = unitTet();
    all.tets = {{0, 1, 2, 2}};
    EXPECT_THROW(buildTetMesh(std::move(all), "t", "s"), DataError);
}

TEST(TetMesh, DuplicatePointsAreMergedSoAdjacencyCrossesThem) {
    // Two tets sharing face (1,2,3), the second one written with its own copies of the face's points.
    TetSoup s;
    s.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}, {1, 0, 0}, {0, 1, 0}, {-0.0, 0, 1}};
    s.scalars = {0, 1, 2, 3, 4, 3, 2, 5};
    s.tets = {{0, 1, 2, 3}, {4, 5, 7, 6}};
    TetMesh m = buildTetMesh(std::move(s), "t", "s");
    EXPECT_EQ(m.repairs.mergedPoints, 3u);
    EXPECT_EQ(m.repairs.mergedScalarConflicts, 2u); // (1 vs 3) and (3 vs 5)
    EXPECT_EQ(m.pointCount(), 5u);
    EXPECT_EQ(m.internalFaceCount(), 1u);
    EXPECT_EQ(m.boundaryFaces.size(), 6u);
    EXPECT_FLOAT_EQ(m.scalars[1], 2.0f); // mean of 1 and 3
    expectAdjacencyCloses(m);
}

TEST(TetMesh, NonManifoldFaceIsBoundary) {
    // Three tets on the triangle (0,1,2): two above it, one below.
    TetSoup s;
    s.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0.2, 0.2, 1}, {0, 0, -1}};
    s.scalars.assign(6, 1.0f);
    s.tets = {{0, 1, 2, 3}, {0, 1, 2, 4}, {0, 2, 1, 5}};
    TetMesh m = buildTetMesh(std::move(s), "t", "s");
    EXPECT_EQ(m.repairs.nonManifoldFaces, 1u);
    EXPECT_EQ(m.internalFaceCount(), 0u); // the other faces are all distinct
    EXPECT_EQ(m.boundaryFaces.size(), 12u);
    expectAdjacencyCloses(m);
}

TEST(TetMesh, HugeAndTinyCoordinates) {
    for (double scale : {1e30, 1e-30}) {
        TetSoup s = unitTet();
        for (auto& p : s.points)
            for (double& c : p)
                c *= scale;
        TetMesh m = buildTetMesh(std::move(s), "t", "s");
        EXPECT_EQ(m.tetCount(), 1u) << scale;
        EXPECT_NEAR(m.totalVolume() / (scale * scale * scale), 1.0 / 6.0, 1e-12) << scale;
        EXPECT_EQ(m.repairs.zeroVolumeTets, 0u);
        EXPECT_TRUE(std::isfinite(m.maxEdgeLength));
    }
}

TEST(TetMesh, NanScalarKeptOutsideTheValueRangeNanCoordinateRefused) {
    TetSoup s = unitTet();
    const std::vector<float> finite = s.scalars;
    s.scalars[2] = NAN; // its tets render with the NaN colour
    TetMesh m = buildTetMesh(s, "m.vtk", "s");
    EXPECT_TRUE(std::isnan(m.scalars[2]));
    std::vector<float> rest = finite;
    rest.erase(rest.begin() + 2);
    EXPECT_EQ(m.valueMin, *std::min_element(rest.begin(), rest.end()));
    EXPECT_EQ(m.valueMax, *std::max_element(rest.begin(), rest.end()));
    s.points[1][0] = NAN;
    const std::string e = errorOf([&] { buildTetMesh(std::move(s), "m.vtk", "s"); });
    EXPECT_NE(e.find("m.vtk: point 1 has a non-finite coordinate"), std::string::npos) << e;
}

TEST(CellSplit, HexGridClosesAndFillsTheBox) {
    TetMesh m = generateHexGridMesh({5, 4, 3}, {-1, 0, 2}, {2, 1, 3.5},
                                    [](double x, double y, double z) { return x + 2 * y - z; });
    EXPECT_EQ(m.tetCount(), 6u * 5 * 4 * 3);
    EXPECT_EQ(m.repairs.invertedTets, 0u);
    EXPECT_EQ(m.repairs.zeroVolumeTets, 0u);
    EXPECT_NEAR(m.totalVolume(), 3.0 * 1.0 * 1.5, 1e-12);
    // Boundary: 2 triangles per boundary quad.
    EXPECT_EQ(m.boundaryFaces.size(), 2u * 2 * (5 * 4 + 4 * 3 + 5 * 3));
    expectAdjacencyCloses(m);
}

TEST(CellSplit, WedgePyramidAndVoxelAreConformingAndPositive) {
    // A unit cube as two wedges, as six pyramids around the centre, and as one voxel: each must
    // close and fill the cube exactly with positive tets.
    const std::vector<Point3> cube = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},      {0, 0, 1},
                                      {1, 0, 1}, {1, 1, 1}, {0, 1, 1}, {0.5, 0.5, 0.5}};
    auto build = [&](const std::vector<std::pair<VtkCellType, std::vector<std::uint32_t>>>& cells) {
        TetSoup s;
        s.points = cube;
        s.scalars.assign(cube.size(), 0.0f);
        for (const auto& [type, ids] : cells)
            splitCell(type, ids, s.tets);
        return buildTetMesh(std::move(s), "cube", "s");
    };
    // VTK pyramid: the base (0,1,2,3) is wound so its normal points to the apex.
    // VTK wedge: (0,1,2) and (3,4,5) triangles; (0,1,2) wound so its normal points away from (3,4,5).
    TetMesh wedges =
        build({{VtkCellType::Wedge, {0, 2, 1, 4, 6, 5}}, {VtkCellType::Wedge, {0, 3, 2, 4, 7, 6}}});
    TetMesh pyramids = build({{VtkCellType::Pyramid, {0, 1, 2, 3, 8}},
                              {VtkCellType::Pyramid, {4, 7, 6, 5, 8}},
                              {VtkCellType::Pyramid, {0, 4, 5, 1, 8}},
                              {VtkCellType::Pyramid, {1, 5, 6, 2, 8}},
                              {VtkCellType::Pyramid, {2, 6, 7, 3, 8}},
                              {VtkCellType::Pyramid, {3, 7, 4, 0, 8}}});
    TetMesh voxel = build({{VtkCellType::Voxel, {0, 1, 3, 2, 4, 5, 7, 6}}});
    for (const TetMesh* m : {&wedges, &pyramids, &voxel}) {
        EXPECT_EQ(m->repairs.invertedTets, 0u);
        EXPECT_NEAR(m->totalVolume(), 1.0, 1e-12);
        EXPECT_EQ(m->boundaryFaces.size(), 12u);
        expectAdjacencyCloses(*m);
    }
    EXPECT_EQ(wedges.tetCount(), 6u);
    EXPECT_EQ(pyramids.tetCount(), 12u);
    EXPECT_EQ(voxel.tetCount(), 6u);
}

TEST(MeshIo, LegacyAsciiAndBinaryAndRefusals) {
    const fs::path dir = test::tempDir("mesh_legacy");
    writeText(dir / "t.vtk", kLegacyTet);
    TetMesh a = readMesh(dir / "t.vtk");
    EXPECT_EQ(a.tetCount(), 1u);
    EXPECT_EQ(a.scalarName, "s");
    // The same file in BINARY (big-endian), version 5.1 layout.
    std::string bin = "# vtk DataFile Version 5.1\nt\nBINARY\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 float\n";
    auto be32 = [&](std::uint32_t v) {
        for (int s = 24; s >= 0; s -= 8)
            bin += static_cast<char>((v >> s) & 0xff);
    };
    auto beF = [&](float f) {
        std::uint32_t u;
        std::memcpy(&u, &f, 4);
        be32(u);
    };
    for (float c : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f})
        beF(c);
    bin += "\nCELLS 2 4\nOFFSETS vtktypeint32\n";
    be32(0);
    be32(4);
    bin += "\nCONNECTIVITY vtktypeint32\n";
    for (std::uint32_t i : {0u, 2u, 1u, 3u})
        be32(i);
    bin += "\nCELL_TYPES 1\n";
    be32(10);
    bin += "\nPOINT_DATA 4\nSCALARS s float 1\nLOOKUP_TABLE default\n";
    for (float v : {0.f, 1.f, 2.f, 3.f})
        beF(v);
    bin += "\n";
    writeText(dir / "b.vtk", bin);
    TetMesh b = readMesh(dir / "b.vtk");
    EXPECT_EQ(b.tetCount(), 1u);
    EXPECT_EQ(b.repairs.invertedTets, 1u);
    EXPECT_EQ(b.scalars, a.scalars);

    // Truncated binary, forged index, disagreeing counts, unsupported cell; a NaN scalar is read as NaN.
    writeText(dir / "cut.vtk", bin.substr(0, 150));
    EXPECT_NE(errorOf([&] { readMesh(dir / "cut.vtk"); }).find("truncated"), std::string::npos);
    std::string forged = kLegacyTet;
    forged.replace(forged.find("4 0 1 2 3"), 9, "4 0 1 2 9");
    writeText(dir / "forged.vtk", forged);
    EXPECT_NE(errorOf([&] { readMesh(dir / "forged.vtk"); }).find("cell 0: point id 9 is out of range"),
              std::string::npos);
    std::string counts = kLegacyTet;
    counts.replace(counts.find("CELL_TYPES 1"), 12, "CELL_TYPES 2");
    writeText(dir / "counts.vtk", counts);
    EXPECT_NE(errorOf([&] { readMesh(dir / "counts.vtk"); }).find("disagrees"), std::string::npos);
    std::string tri = kLegacyTet;
    tri.replace(tri.find("CELL_TYPES 1\n10"), 15, "CELL_TYPES 1\n5 ");
    writeText(dir / "tri.vtk", tri);
    EXPECT_NE(errorOf([&] { readMesh(dir / "tri.vtk"); }).find("cell 0 is a triangle"), std::string::npos);
    std::string nan = kLegacyTet;
    nan.replace(nan.rfind("0 1 2 3"), 7, "0 1 nan 3");
    writeText(dir / "nan.vtk", nan);
    EXPECT_TRUE(std::isnan(readMesh(dir / "nan.vtk").scalars[2]));
    std::string huge = kLegacyTet;
    huge.replace(huge.find("POINTS 4"), 8, "POINTS 4000000000000");
    writeText(dir / "huge.vtk", huge);
    EXPECT_NE(errorOf([&] { readMesh(dir / "huge.vtk"); }).find("truncated"), std::string::npos);
}

TEST(MeshIo, VtuRoundTripEveryEncoding) {
    const fs::path dir = test::tempDir("mesh_vtu");
    TetMesh m = generateHexGridMesh({4, 3, 2}, {0, 0, 0}, {1, 0.3, 0.7},
                                    [](double x, double y, double z) { return std::sin(3 * x) + y * z; });
    for (VtuEncoding enc : {VtuEncoding::Appended, VtuEncoding::Base64})
        for (bool zlib : {false, true}) {
            const fs::path p = dir / ("m" + std::to_string(int(enc)) + std::to_string(zlib) + ".vtu");
            writeVtu(m, p, {enc, zlib});
            TetMesh r = readMesh(p);
            EXPECT_EQ(r.points, m.points);
            EXPECT_EQ(r.tets, m.tets);
            EXPECT_EQ(r.scalars, m.scalars);
            EXPECT_EQ(r.neighbors, m.neighbors);
            EXPECT_EQ(r.scalarName, "f");
        }
    // Truncated and forged files are refused, naming the file.
    const std::string good = readText(dir / "m00.vtu");
    writeText(dir / "cut.vtu", good.substr(0, good.size() / 2));
    EXPECT_NE(errorOf([&] { readMesh(dir / "cut.vtu"); }).find("cut.vtu"), std::string::npos);
    std::string forged = good;
    forged.replace(forged.find("NumberOfPoints=\""), 16, "NumberOfPoints=\"9");
    writeText(dir / "forged.vtu", forged);
    EXPECT_THROW(readMesh(dir / "forged.vtu"), IoError);
}

TEST(MeshIo, VtkReadsOurVtu) {
    if (std::system("/usr/bin/python3 -c 'import vtk' >/dev/null 2>&1") != 0)
        GTEST_SKIP() << "python3-vtk9 is not installed";
    const fs::path dir = test::tempDir("mesh_vtk_peer");
    TetMesh m =
        generateHexGridMesh({3, 3, 3}, {0, 0, 0}, {1, 1, 1}, [](double x, double, double) { return x; });
    writeVtu(m, dir / "a.vtu", {VtuEncoding::Appended, true});
    writeVtu(m, dir / "b.vtu", {VtuEncoding::Base64, false});
    const std::string script =
        "import vtk,sys\nfor f in sys.argv[1:]:\n "
        "r=vtk.vtkXMLUnstructuredGridReader();r.SetFileName(f);r.Update()\n"
        " g=r.GetOutput();a=g.GetPointData().GetArray('f')\n"
        " assert g.GetNumberOfPoints()==64 and g.GetNumberOfCells()==162 and a.GetRange()==(0.0,1.0)\n";
    writeText(dir / "check.py", script);
    EXPECT_EQ(std::system(("/usr/bin/python3 " + (dir / "check.py").string() + " " +
                           (dir / "a.vtu").string() + " " + (dir / "b.vtu").string())
                              .c_str()),
              0);
}

// The meshes of ../shared/data/unstructured, with the counts their README states.
TEST(MeshIo, SharedDataMeshes) {
    fs::path d;
    VOLCL_REQUIRE_SHARED_DATA(d);
    d /= "unstructured";
    TetMesh tm = readMesh(d / "tetraMesh.vtk");
    EXPECT_EQ(tm.repairs.inputPoints, 55u);
    EXPECT_EQ(tm.repairs.inputCells, 160u);
    EXPECT_EQ(tm.tetCount(), 160u);
    expectAdjacencyCloses(tm);

    TetMesh turb = readMesh(d / "xsmall_turb.vtu");
    EXPECT_EQ(turb.repairs.inputPoints, 21813u);
    EXPECT_EQ(turb.repairs.inputCells, 60672u);
    EXPECT_EQ(turb.pointCount(), 17344u);
    EXPECT_EQ(turb.repairs.zeroVolumeTets, 9632u);
    EXPECT_EQ(turb.tetCount(), 51040u);
    EXPECT_NEAR(turb.valueMin, 1.87e-6, 0.01e-6);
    EXPECT_NEAR(turb.valueMax, 1.04e-4, 0.01e-4);
    expectAdjacencyCloses(turb);

    TetMesh kiefer = readMesh(d / "kiefer" / "dataset.vtu");
    EXPECT_EQ(kiefer.repairs.inputPoints, 102578u);
    EXPECT_EQ(kiefer.repairs.quadraticTets, 56786u);
    EXPECT_EQ(kiefer.tetCount(), 56786u);
    EXPECT_TRUE(kiefer.repairs.scalarFromCells);
    EXPECT_GE(kiefer.valueMin, 0.014f);
    EXPECT_LE(kiefer.valueMax, 23.27f);
    expectAdjacencyCloses(kiefer);

    struct Grid {
        const char* name;
        std::size_t ni, nj, nk;
        bool iblank;
    };
    for (const Grid g : {Grid{"bluntfinxyz.bin", 40, 32, 32, false}, Grid{"combxyz.bin", 57, 33, 25, false},
                         Grid{"postxyz.bin", 38, 76, 38, true}}) {
        TetMesh m = readMesh(d / g.name);
        EXPECT_EQ(m.repairs.inputPoints, g.ni * g.nj * g.nk) << g.name;
        EXPECT_EQ(m.repairs.inputCells, (g.ni - 1) * (g.nj - 1) * (g.nk - 1)) << g.name;
        EXPECT_EQ(m.repairs.candidateTets, 6 * (m.repairs.inputCells - m.repairs.blankedCells)) << g.name;
        EXPECT_EQ(m.format.find("iblank") != std::string::npos, g.iblank) << g.name;
        EXPECT_EQ(m.repairs.invertedTets, 0u) << g.name;
        expectAdjacencyCloses(m);
    }
    TetMesh fin = readMesh(d / "bluntfinxyz.bin");
    EXPECT_NEAR(fin.valueMin, 0.193, 0.001);
    EXPECT_NEAR(fin.valueMax, 4.98, 0.01);
    TetMesh energy = readMesh(d / "postxyz.bin", {std::nullopt, 4, std::nullopt});
    EXPECT_GT(energy.valueMax, energy.valueMin);
    EXPECT_THROW(readMesh(d / "bluntfinxyz.bin", {std::nullopt, 5, std::nullopt}), UsageError);
    // Round trip of a real mesh through the writer.
    const fs::path out = test::tempDir("mesh_shared") / "turb.vtu";
    writeVtu(turb, out, {VtuEncoding::Appended, true});
    TetMesh back = readMesh(out);
    EXPECT_EQ(back.tets, turb.tets);
    EXPECT_EQ(back.scalars, turb.scalars);
}

TEST(MeshIo, DetectionLeavesVolumesAlone) {
    const fs::path dir = test::tempDir("mesh_detect");
    writeText(dir / "v.vtk", "# vtk DataFile Version 2.0\nv\nASCII\nDATASET STRUCTURED_POINTS\n");
    EXPECT_FALSE(detectMeshFormat(dir / "v.vtk"));
    writeText(dir / "junk_4x4x4_uint8.bin", std::string(64, 'a'));
    EXPECT_FALSE(detectMeshFormat(dir / "junk_4x4x4_uint8.bin"));
    writeText(dir / "m.vtk", kLegacyTet);
    EXPECT_EQ(detectMeshFormat(dir / "m.vtk"), MeshFormat::VtkLegacy);
}
