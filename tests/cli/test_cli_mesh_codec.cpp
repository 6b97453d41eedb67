// `volcl encode/decode/info/render/convert` on .vcm meshes through the binary: round trips, reports, usage
// errors, corrupt and truncated files refused with one line naming the file and no output left behind.
#include "../TestUtil.hpp"
#include "CliRun.hpp"

#include "host/image/ImageIo.hpp"
#include "host/mesh/MeshGenerator.hpp"
#include "host/mesh/MeshIo.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>

namespace fs = std::filesystem;
using namespace volcl;
using namespace volcl::test;

namespace {

std::size_t lines(const std::string& s) {
    return static_cast<std::size_t>(std::count(s.begin(), s.end(), '\n'));
}

void expectRefused(const RunResult& r, int code, const std::string& file) {
    EXPECT_EQ(r.exitCode, code) << r.err;
    EXPECT_EQ(lines(r.err), 1u) << r.err;
    EXPECT_NE(r.err.find(file), std::string::npos) << r.err;
}

/// A directory of its own per test (ctest runs them in parallel) holding grid.vtu.
fs::path meshDir() {
    const fs::path dir = tempDir(std::string("cli_mesh_codec_") +
                                 ::testing::UnitTest::GetInstance()->current_test_info()->name());
    const mesh::TetMesh m = mesh::generateHexGridMesh(
        {5, 4, 3}, {0, 0, 0}, {1, 0.8, 0.6}, [](double x, double y, double z) { return x * x + y - z; });
    mesh::writeVtu(m, dir / "grid.vtu");
    return dir;
}

} // namespace

TEST(CliMeshCodec, EncodeInfoDecodeRender) {
    const fs::path dir = meshDir();
    RunResult r = runVolcl("encode grid.vtu -o g.vcm", dir, true);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(has(r.err, "bits/tet")) << r.err;
    r = runVolcl("info g.vcm", dir, true);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(has(r.out, "360  (360 in the file)") || has(r.out, "tets      360")) << r.out;
    EXPECT_TRUE(has(r.out, "bits/tet")) << r.out;
    EXPECT_TRUE(has(r.out, "16 bits per coordinate")) << r.out;
    r = runVolcl("info g.vcm --json", dir, true);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(has(r.out, "\"connectivity_bits_per_tet\"")) << r.out;
    r = runVolcl("decode g.vcm -o back.vtu", dir, true);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const mesh::TetMesh original = mesh::readMesh(dir / "grid.vtu"), back = mesh::readMesh(dir / "back.vtu");
    EXPECT_EQ(back.tetCount(), original.tetCount());
    EXPECT_EQ(back.pointCount(), original.pointCount());
    EXPECT_NEAR(back.totalVolume(), original.totalVolume(), 1e-4);
    r = runVolcl("render --volume g.vcm --width 24 --height 24 -o img.exr", dir, true);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(fs::exists(dir / "img.exr"));
    r = runVolcl("convert g.vcm -o conv.vtu", dir, true);
    ASSERT_EQ(r.exitCode, 0) << r.err;
}

TEST(CliMeshCodec, LosslessRoundTripIsExact) {
    const fs::path dir = meshDir();
    ASSERT_EQ(runVolcl("encode grid.vtu -o l.vcm --lossless", dir, true).exitCode, 0);
    ASSERT_EQ(runVolcl("decode l.vcm -o l.vtu", dir, true).exitCode, 0);
    const mesh::TetMesh a = mesh::readMesh(dir / "grid.vtu"), b = mesh::readMesh(dir / "l.vtu");
    auto sortedPoints = [](const mesh::TetMesh& m) {
        std::vector<std::array<double, 4>> p;
        for (std::size_t i = 0; i < m.pointCount(); ++i)
            p.push_back({m.points[i][0], m.points[i][1], m.points[i][2], m.scalars[i]});
        std::sort(p.begin(), p.end());
        return p;
    };
    EXPECT_TRUE(sortedPoints(a) == sortedPoints(b));
    EXPECT_EQ(a.tetCount(), b.tetCount());
    EXPECT_EQ(a.totalVolume(), b.totalVolume());
}

TEST(CliMeshCodec, UsageErrors) {
    const fs::path dir = meshDir();
    expectRefused(runVolcl("encode grid.vtu -o g.vcm --bits 0", dir, true), 2, "--bits");
    expectRefused(runVolcl("encode grid.vtu -o g.vcm --bits 12 --lossless", dir, true), 2, "--bits");
    expectRefused(runVolcl("encode grid.vtu -o g.vcm --psnr 40", dir, true), 2, "--psnr");
    ASSERT_EQ(runVolcl("encode grid.vtu -o g.vcm", dir, true).exitCode, 0);
    expectRefused(runVolcl("decode g.vcm -o g.nrrd", dir, true), 2, "g.nrrd");
    EXPECT_FALSE(fs::exists(dir / "g.nrrd"));
}

TEST(CliMeshCodec, CorruptAndTruncatedFilesAreRefused) {
    const fs::path dir = meshDir();
    ASSERT_EQ(runVolcl("encode grid.vtu -o g.vcm", dir, true).exitCode, 0);
    const std::string good = test::readFile(dir / "g.vcm");
    const auto write = [&](const std::string& name, const std::string& bytes) {
        std::ofstream(dir / name, std::ios::binary) << bytes;
    };
    std::string flipped = good;
    flipped[good.size() / 2] ^= 0x10;
    write("flip.vcm", flipped);
    write("cut.vcm", good.substr(0, good.size() - 3));
    write("head.vcm", good.substr(0, 40));
    for (const char* f : {"flip.vcm", "cut.vcm", "head.vcm"}) {
        SCOPED_TRACE(f);
        expectRefused(runVolcl(std::string("info ") + f, dir, true), 1, f);
        expectRefused(runVolcl(std::string("decode ") + f + " -o out.vtu", dir, true), 1, f);
        EXPECT_FALSE(fs::exists(dir / "out.vtu"));
        expectRefused(
            runVolcl(std::string("render --volume ") + f + " --width 8 --height 8 -o out.exr", dir, true), 1,
            f);
        EXPECT_FALSE(fs::exists(dir / "out.exr"));
    }
}

// Where compression meets the mesh renderers: a lossless .vcm renders as its source does (the tets come in
// another order, so only summation order may differ), a 16-bit one within the quantisation's effect, by the
// exact cell caster and by the k-buffer.
TEST(CliMeshCodec, RenderersDrawTheDecodedMeshAsTheSource) {
    const fs::path dir = meshDir();
    ASSERT_EQ(runVolcl("encode grid.vtu -o l.vcm --lossless", dir, true).exitCode, 0);
    ASSERT_EQ(runVolcl("encode grid.vtu -o q.vcm", dir, true).exitCode, 0);
    for (const char* method : {"cells", "kbuffer"}) {
        SCOPED_TRACE(method);
        double worst[2] = {0, 0};
        const std::string common =
            std::string(" --tf preset:viridis --width 40 --height 40 --method ") + method;
        ASSERT_EQ(runVolcl("render --volume grid.vtu -o src.exr" + common, dir, true).exitCode, 0);
        const ImageBuffer src = readImage(dir / "src.exr");
        const char* files[2] = {"l.vcm", "q.vcm"};
        for (int f = 0; f < 2; ++f) {
            const RunResult r =
                runVolcl(std::string("render --volume ") + files[f] + " -o out.exr" + common, dir, true);
            ASSERT_EQ(r.exitCode, 0) << r.err;
            const ImageBuffer img = readImage(dir / "out.exr");
            ASSERT_EQ(img.pixels.size(), src.pixels.size());
            for (std::size_t i = 0; i < img.pixels.size(); ++i)
                worst[f] = std::max(worst[f], double(std::abs(img.pixels[i] - src.pixels[i])));
        }
        EXPECT_LE(worst[0], 1e-4) << "lossless";
        EXPECT_LE(worst[1], 2e-3) << "16 bits";
    }
}
