// Multi-channel volumes through the volcl binary: info per channel, --channel K, a "channels" scene rendered to
// EXR equal to the channel renderer in process, and the one-line refusals with their exit codes.
#include "../TestUtil.hpp"
#include "CliRun.hpp"
#include "host/image/ImageIo.hpp"
#include "host/io/VolumeIo.hpp"
#include "render/grid/ChannelRenderer.hpp"

#include <algorithm>
#include <fstream>

using namespace volcl;

namespace {

using test::has;
using test::RunResult;
using test::runVolcl;

/// Two uint8 channels on 20 x 18 x 16 (a ball and a slab), one NRRD with a vector axis.
std::filesystem::path writeTwoChannels(const std::filesystem::path& dir) {
    ChannelVolume cv;
    for (int c = 0; c < 2; ++c) {
        Volume v({20, 18, 16}, ScalarType::UInt8);
        for (std::size_t k = 0; k < 16; ++k)
            for (std::size_t j = 0; j < 18; ++j)
                for (std::size_t i = 0; i < 20; ++i) {
                    const double dx = double(i) - 9.5, dy = double(j) - 8.5, dz = double(k) - 7.5;
                    const bool on = c == 0 ? dx * dx + dy * dy + dz * dz < 36.0 : (k >= 6 && k <= 8);
                    v.values<std::uint8_t>()[v.index(i, j, k)] = on ? 200 : 10;
                }
        cv.channels.push_back(std::move(v));
    }
    const auto p = dir / "two.nrrd";
    writeChannelsFile(cv, p);
    return p;
}

void writeText(const std::filesystem::path& p, const std::string& text) {
    std::ofstream(p) << text;
}

} // namespace

TEST(CliChannels, InfoAndChannelSelection) {
    const auto dir = test::tempDir("cli_channels_info");
    const auto in = writeTwoChannels(dir);
    RunResult r = runVolcl("info " + in.string(), dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(has(r.out, "2 channels")) << r.out;
    EXPECT_TRUE(has(r.out, "channel 1:")) << r.out;
    r = runVolcl("info --json " + in.string(), dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(has(r.out, "\"channels\"")) << r.out;
    r = runVolcl("info --channel 1 " + in.string(), dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_FALSE(has(r.out, "2 channels") || has(r.out, "channel 0:")) << r.out;
    // A scalar command without --channel: one line naming the file and the count, exit 1, no output.
    r = runVolcl("convert " + in.string() + " -o " + (dir / "out.nii").string(), dir);
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_TRUE(has(r.err, in.string()) && has(r.err, "has 2 channels") && has(r.err, "--channel")) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir / "out.nii"));
    r = runVolcl("convert " + in.string() + " --channel 1 -o " + (dir / "one.nii").string(), dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const Volume one = readVolume(dir / "one.nii");
    EXPECT_EQ(one.values<std::uint8_t>()[one.index(0, 0, 7)], 200);
    r = runVolcl("info --channel 2 " + in.string(), dir);
    EXPECT_EQ(r.exitCode, 2) << r.err;
    // The codec keeps one scalar volume per file: each channel encodes on its own, losslessly exact.
    for (int c = 0; c < 2; ++c) {
        const std::string k = std::to_string(c);
        r = runVolcl(
            "encode " + in.string() + " --channel " + k + " -o " + (dir / ("c" + k + ".vcz")).string(), dir);
        ASSERT_EQ(r.exitCode, 0) << r.err;
        r = runVolcl("decode " + (dir / ("c" + k + ".vcz")).string() + " -o " +
                         (dir / ("d" + k + ".nrrd")).string(),
                     dir);
        ASSERT_EQ(r.exitCode, 0) << r.err;
        ReadOptions o;
        o.channel = std::size_t(c);
        EXPECT_TRUE(readVolume(dir / ("d" + k + ".nrrd")) == readVolume(in, o)) << "channel " << c;
    }
    r = runVolcl("encode " + in.string() + " -o " + (dir / "all.vcz").string(), dir);
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_FALSE(std::filesystem::exists(dir / "all.vcz"));
}

TEST(CliChannels, SceneRendersAsTheChannelRendererAndRefusesWhatItDoesNotDraw) {
    const auto dir = test::tempDir("cli_channels_render");
    const auto in = writeTwoChannels(dir);
    writeText(dir / "a.json",
              R"({"color": [[0, 1, 0.3, 0.1], [255, 1, 0.3, 0.1]], "extinction": [[0, 0], [255, 0.3]]})");
    writeText(dir / "b.json",
              R"({"color": [[0, 0.1, 0.4, 1], [255, 0.1, 0.4, 1]], "extinction": [[0, 0], [255, 0.2]]})");
    writeText(dir / "scene.json", R"({"volume": "two.nrrd", "channels": [{"tf": "a.json"}, {"tf": "b.json"}],
                                      "camera": {"eye": [9.5, 8.5, -40], "target": [9.5, 8.5, 7.5], "height": 20},
                                      "image": {"width": 24, "height": 20}})");
    RunResult r = runVolcl(
        "render --scene " + (dir / "scene.json").string() + " -o " + (dir / "out.exr").string(), dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(has(r.err, "2 channels, additive")) << r.err;
    const ImageBuffer cli = readImage(dir / "out.exr");

    Scene s = Scene::fromFile(dir / "scene.json");
    const ChannelVolume cv = readSceneChannels(s, {});
    s.step = 0.5; // the default step: half a voxel of spacing 1
    ChannelStyle style;
    for (const char* tf : {"a.json", "b.json"})
        style.layers.push_back({TransferFunction::forRender(dir / tf, {10, 200}, 1.0), true});
    ChannelRenderer renderer(test::computeContext(), cv, style, s);
    const ImageBuffer mine = renderer.render();
    double sum = 0;
    for (float v : mine.pixels)
        sum += v;
    EXPECT_GT(sum, 1.0);
    // The same data, TFs, camera and step: float noise only.
    ASSERT_EQ(cli.width, mine.width);
    double worst = 0;
    for (std::size_t i = 0; i < mine.pixels.size(); ++i)
        worst = std::max(worst, std::abs(double(cli.pixels[i]) - double(mine.pixels[i])));
    EXPECT_LT(worst, 1e-5);

    // Shading is refused in one line naming the scene file, exit 2, no output.
    writeText(dir / "lit.json", R"({"volume": "two.nrrd", "channels": [{"tf": "a.json"}, {"tf": "b.json"}],
                                    "effects": {"shading": {}}})");
    r = runVolcl("render --scene " + (dir / "lit.json").string() + " -o " + (dir / "lit.png").string(), dir);
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_TRUE(has(r.err, "shading")) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir / "lit.png"));
    // Rendering the file as one scalar volume without --channel: refused in one line, exit 1.
    r = runVolcl("render --volume " + in.string() + " -o " + (dir / "plain.png").string(), dir);
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_TRUE(has(r.err, "has 2 channels")) << r.err;
}
