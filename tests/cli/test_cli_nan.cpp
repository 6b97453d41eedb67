// The volcl executable on volumes and meshes with NaN/Inf values: render (grid, .vcz bricks, mesh cells and
// k-buffer), --nan-color, lossy encode, and the errors that remain naming the file and the way out.
#include "../TestUtil.hpp"
#include "CliRun.hpp"
#include "host/image/ImageIo.hpp"
#include "host/io/VolumeIo.hpp"
#include "host/mesh/MeshGenerator.hpp"
#include "host/mesh/MeshIo.hpp"

#include <sys/wait.h>

#include <bit>
#include <cmath>
#include <fstream>
#include <sstream>

using namespace volcl;

namespace {

using test::has;
using test::RunResult;

RunResult run(const std::string& args, const std::filesystem::path& dir) {
    return test::runVolcl(args, dir);
}

/// A 24^3 float ball (200 at the centre, falling off) with a 6^3 block of NaN in its middle and a line of
/// +Inf: the issue's "a float volume with NaN renders".
std::filesystem::path writeHoledBall(const std::filesystem::path& dir) {
    Volume v = test::makeFloatVolume({24, 24, 24}, [](double x, double y, double z) {
        const double dx = x - 11.5, dy = y - 11.5, dz = z - 11.5;
        return 200.0 * std::exp(-(dx * dx + dy * dy + dz * dz) / 50.0);
    });
    for (std::size_t z = 9; z < 15; ++z)
        for (std::size_t y = 9; y < 15; ++y)
            for (std::size_t x = 9; x < 15; ++x)
                v.values<float>()[v.index(x, y, z)] = NAN;
    for (std::size_t x = 3; x < 20; ++x)
        v.values<float>()[v.index(x, 4, 6)] = INFINITY;
    const auto p = dir / "nan.vti"; // framed along +z both as a grid and as a .vcz
    writeVolumeFile(v, p);
    return p;
}

const char* kTf =
    R"({"domain": [0, 200], "color": [[0, 1, 1, 1], [200, 1, 1, 1]], "extinction": [[0, 0], [200, 0.1]]})";

double maxDiff(const ImageBuffer& a, const ImageBuffer& b) {
    double m = 0;
    for (int y = 0; y < a.height; ++y)
        for (int x = 0; x < a.width; ++x)
            for (int c = 0; c < 4; ++c)
                m = std::max(m, std::abs(double(a.at(x, y, c)) - double(b.at(x, y, c))));
    return m;
}

} // namespace

TEST(CliNan, RendersNanVolumesWithTheNanColour) {
    auto dir = test::tempDir("cli_nan_render");
    const auto vol = writeHoledBall(dir);
    std::ofstream(dir / "tf.json") << kTf;
    const std::string base =
        "render --volume " + vol.string() + " --tf " + (dir / "tf.json").string() + " --width 32 --height 32";
    RunResult plain = run(base + " -o " + (dir / "plain.exr").string(), dir);
    ASSERT_EQ(plain.exitCode, 0) << plain.err;
    RunResult red = run(base + " --nan-color 1,0,0,1 --explain -o " + (dir / "red.exr").string(), dir);
    ASSERT_EQ(red.exitCode, 0) << red.err;
    EXPECT_TRUE(has(red.out, "nan colour")) << red.out;
    const ImageBuffer a = readImage(dir / "plain.exr"), b = readImage(dir / "red.exr");
    // The centre sees the NaN block: a white ball with a transparent hole by default (rgb = alpha for the
    // white TF), an opaque red core with the colour.
    const float* c0 = &a.pixels[(16 * std::size_t(a.width) + 16) * 4];
    const float* c1 = &b.pixels[(16 * std::size_t(b.width) + 16) * 4];
    EXPECT_GT(c0[3], 0.05f);
    EXPECT_LT(c0[3], 0.9f);
    EXPECT_NEAR(c0[0], c0[3], 1e-5);
    EXPECT_NEAR(c0[1], c0[3], 1e-5);
    EXPECT_GT(c1[3], 0.99f);
    EXPECT_GT(c1[0], c1[1] + 0.5f) << "red core";
    for (float p : a.pixels)
        ASSERT_TRUE(std::isfinite(p));
    // The cubic filters cannot take NaN: one line naming the file and the fix, exit 1.
    RunResult cubic = run(base + " --filter cubic -o " + (dir / "c.exr").string(), dir);
    EXPECT_EQ(cubic.exitCode, 1);
    EXPECT_TRUE(has(cubic.err, vol.string()) && has(cubic.err, "--filter linear")) << cubic.err;
    EXPECT_FALSE(std::filesystem::exists(dir / "c.exr"));
}

TEST(CliNan, LossyVczKeepsNanAndRendersLikeTheGrid) {
    auto dir = test::tempDir("cli_nan_vcz");
    const auto vol = writeHoledBall(dir);
    std::ofstream(dir / "tf.json") << kTf;
    const auto vcz = dir / "nan.vcz";
    RunResult enc =
        run("encode " + vol.string() + " --max-error 0.01 --brick 8 --levels 2 -o " + vcz.string(), dir);
    ASSERT_EQ(enc.exitCode, 0) << enc.err;
    ASSERT_EQ(run("decode " + vcz.string() + " -o " + (dir / "back.nrrd").string(), dir).exitCode, 0);
    const Volume in = readVolume(vol), back = readVolume(dir / "back.nrrd");
    for (std::size_t i = 0; i < in.voxelCount(); ++i) {
        const float a = in.values<float>()[i], b = back.values<float>()[i];
        if (std::isfinite(a))
            ASSERT_LE(std::abs(double(b) - double(a)), 0.01) << i;
        else
            ASSERT_EQ(std::bit_cast<std::uint32_t>(b), std::bit_cast<std::uint32_t>(a)) << i;
    }
    // The bricks render with the NaN colour too, as the grid does (the coding error alone differs).
    for (const char* colour : {"0,0,0,0", "1,0,0,1"}) {
        const std::string tail =
            " --tf " + (dir / "tf.json").string() + " --width 32 --height 32 --nan-color " + colour + " -o ";
        ASSERT_EQ(run("render --volume " + vol.string() + tail + (dir / "g.exr").string(), dir).exitCode, 0);
        RunResult br = run("render --volume " + vcz.string() + tail + (dir / "b.exr").string(), dir);
        ASSERT_EQ(br.exitCode, 0) << br.err;
        EXPECT_LT(maxDiff(readImage(dir / "g.exr"), readImage(dir / "b.exr")), 2e-3) << colour;
    }
}

TEST(CliNan, MeshWithNanPointsRendersWithTheNanColour) {
    auto dir = test::tempDir("cli_nan_mesh");
    mesh::TetMesh m = mesh::generateHexGridMesh({4, 4, 4}, {0, 0, 0}, {1, 1, 1},
                                                [](double x, double, double) { return 200.0 * x; });
    for (std::size_t i = 0; i < m.points.size(); ++i) // the centre point and its six neighbours
        if (norm(sub(m.points[i], Vec3{0.5, 0.5, 0.5})) < 0.3) m.scalars[i] = NAN;
    const auto vtu = dir / "nan.vtu";
    mesh::writeVtu(m, vtu);
    std::ofstream(dir / "tf.json") << kTf;
    for (const char* method : {"cells", "kbuffer"}) {
        const std::string base =
            "render --volume " + vtu.string() + " --tf " + (dir / "tf.json").string() +
            " --width 32 --height 32 --preintegration 3d --table-size 64 --table-lengths 8 --method " +
            method;
        RunResult plain = run(base + " -o " + (dir / "plain.exr").string(), dir);
        ASSERT_EQ(plain.exitCode, 0) << method << ": " << plain.err;
        RunResult red = run(base + " --nan-color 1,0,0,1 -o " + (dir / "red.exr").string(), dir);
        ASSERT_EQ(red.exitCode, 0) << method << ": " << red.err;
        const ImageBuffer a = readImage(dir / "plain.exr"), b = readImage(dir / "red.exr");
        // The centre ray crosses the NaN cells: faint white around a transparent core by default, an opaque
        // red core with the colour.
        const float* c0 = &a.pixels[(16 * std::size_t(a.width) + 16) * 4];
        const float* c1 = &b.pixels[(16 * std::size_t(b.width) + 16) * 4];
        EXPECT_LT(c0[3], 0.2f) << method;
        EXPECT_GT(c1[3], 0.99f) << method;
        EXPECT_GT(c1[0], c1[1] + 0.5f) << method << ": red core";
        for (float p : a.pixels)
            ASSERT_TRUE(std::isfinite(p)) << method;
    }
}
