// `volcl view --headless` as a user runs it: its PNG equals `volcl render`'s PNG of the same scene within
// 1/255, per-frame statistics, and clear refusals (exit codes, one line, no output left behind).
#include "TestUtil.hpp"

#include "core/Volume.hpp"
#include "host/image/ImageIo.hpp"
#include "host/io/VolumeIo.hpp"

#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

using namespace volcl;

namespace {

struct Outcome {
    int code = -1;
    std::string err;
};

// Runs volcl with `args` in `dir`, without an X display (as on CI), and returns exit code and stderr.
Outcome runVolcl(const std::string& args, const std::filesystem::path& dir) {
    const auto err = dir / "stderr.txt";
    const std::string cmd = "cd '" + dir.string() + "' && env -u DISPLAY -u WAYLAND_DISPLAY " +
                            std::string(VOLCL_EXE) + " " + args + " >/dev/null 2>'" + err.string() +
                            "' </dev/null";
    const int status = std::system(cmd.c_str());
    Outcome o;
    o.code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    std::ifstream in(err);
    std::ostringstream s;
    s << in.rdbuf();
    o.err = s.str();
    return o;
}

std::size_t lines(const std::string& s) {
    return std::size_t(std::count(s.begin(), s.end(), '\n'));
}

// A raw volume named so its dims and type come from the file name, a TF, and a scene using both.
void writeScene(const std::filesystem::path& dir, const std::string& effects) {
    Volume v({30, 26, 22}, ScalarType::UInt8);
    auto a = v.values<std::uint8_t>();
    for (std::size_t k = 0; k < 22; ++k)
        for (std::size_t j = 0; j < 26; ++j)
            for (std::size_t i = 0; i < 30; ++i) {
                const double x = i - 14.5, y = j - 12.5, z = k - 10.5;
                a[v.index(i, j, k)] =
                    std::uint8_t(std::clamp(255.0 * std::exp(-(x * x + y * y + z * z) / 60.0), 0.0, 255.0));
            }
    writeVolumeFile(v, dir / "blob_30x26x22_uint8.raw");
    std::ofstream(dir / "tf.json") << R"({"domain": [0, 255],
        "color": [[0, 0.2, 0.3, 0.9], [128, 1.0, 0.5, 0.2], [255, 1.0, 1.0, 0.9]],
        "extinction": [[0, 0.0], [30, 0.0], [128, 0.2], [255, 0.5]]})";
    // Skipping on: auto measures its choice per run, and the overlay names the effects the frame ran with,
    // so two runs could print different panels.
    std::ofstream(dir / "scene.json") << R"({"volume": "blob_30x26x22_uint8.raw", "tf": "tf.json",
        "camera": {"projection": "orthographic", "eye": [40, 30, -60], "target": [14.5, 12.5, 10.5],
                   "up": [0, 1, 0], "height": 40},
        "image": {"width": 72, "height": 56, "background": [0.1, 0.2, 0.3, 1]},
        "render": {"mode": "dvr", "step": 0.5, "skipping": "on"})"
                                      << effects << "}";
}

double maxDifference255(const ImageBuffer& a, const ImageBuffer& b) {
    EXPECT_EQ(a.width, b.width);
    EXPECT_EQ(a.height, b.height);
    EXPECT_EQ(a.channelCount(), b.channelCount());
    double m = 0.0;
    for (std::size_t i = 0; i < std::min(a.pixels.size(), b.pixels.size()); ++i)
        m = std::max(m, std::abs(double(a.pixels[i]) - double(b.pixels[i])) * 255.0);
    return m;
}

} // namespace

TEST(ViewerCli, HeadlessPngEqualsRenderPng) {
    for (const std::string effects :
         {std::string(), std::string(R"(, "lights": [{"type": "directional", "direction": [-1, 1, -1]}],
              "effects": {"shading": {"ambient": 0.3}, "clip_planes": [{"normal": [1, 0, 0], "offset": -12}]})"),
          // A label map (two shells of the blob) through the same renderer in the viewer.
          std::string(R"(, "labels": {"file": "labels.nrrd", "mode": "replace"})")}) {
        const auto dir = test::tempDir("viewer_cli_equal");
        writeScene(dir, effects);
        Volume labels({30, 26, 22}, ScalarType::UInt8);
        for (std::size_t i = 0; i < labels.voxelCount(); ++i) {
            const std::size_t x = i % 30;
            labels.values<std::uint8_t>()[i] = x < 10 ? 1 : x > 20 ? 2 : 0;
        }
        writeVolumeFile(labels, dir / "labels.nrrd");
        const Outcome r = runVolcl("render --scene scene.json -o render.png", dir);
        ASSERT_EQ(r.code, 0) << r.err;
        const Outcome v = runVolcl("view scene.json --headless --frames 2 -o view.png", dir);
        ASSERT_EQ(v.code, 0) << v.err;
        const ImageBuffer a = readImage(dir / "render.png"), b = readImage(dir / "view.png");
        EXPECT_LE(maxDifference255(a, b), 1.0) << "effects: " << effects;
        EXPECT_EQ(b.width, 72);
        EXPECT_EQ(b.height, 56);
    }
}

// A .vcz with --lod auto: view draws it from its bricks (mapped, read as decoded) as render does, so the
// two images agree within 1/255, as for a grid; with a pool of a few bricks both coarsen the same way.
TEST(ViewerCli, HeadlessLodAutoOfAVczEqualsRender) {
    const auto dir = test::tempDir("viewer_cli_vcz");
    writeScene(dir, "");
    Outcome r = runVolcl("encode blob_30x26x22_uint8.raw --brick 8 --levels 2 -o blob.vcz", dir);
    ASSERT_EQ(r.code, 0) << r.err;
    std::string scene;
    {
        std::ifstream in(dir / "scene.json");
        std::ostringstream s;
        s << in.rdbuf();
        scene = s.str();
    }
    scene.replace(scene.find("blob_30x26x22_uint8.raw"), 23, "blob.vcz");
    std::ofstream(dir / "scene.json") << scene;
    for (const std::string cache : {"64", "0.01"}) {
        const std::string flags = " --lod auto --lod-error 0.02 --cache-mb " + cache;
        r = runVolcl("render --scene scene.json" + flags + " -o render.png", dir);
        ASSERT_EQ(r.code, 0) << r.err;
        // 16 bricks per frame exactly (by default more come while their decode fits the last kernel time,
        // which depends on the machine).
        const Outcome v = runVolcl("view scene.json --headless --frames 2 --refine-bricks 16" + flags +
                                       " --stats frames.csv -o view.png",
                                   dir);
        ASSERT_EQ(v.code, 0) << v.err;
        EXPECT_LE(maxDifference255(readImage(dir / "render.png"), readImage(dir / "view.png")), 1.0)
            << "cache " << cache;
        // With the pool holding them, the 48 bricks arrive 16 per frame on the first frames (the rest drawn
        // coarse first): the view refines over more frames than the 2 asked for, and its last frame is render's.
        // (The 0.01 MB pool coarsens them below 16 to decode.)
        std::ifstream csv(dir / "frames.csv");
        std::string line;
        int rows = -1; // the header
        while (std::getline(csv, line))
            ++rows;
        if (cache == "64") EXPECT_GT(rows, 2);
    }
}

TEST(ViewerCli, OrbitWritesPerFrameStatistics) {
    const auto dir = test::tempDir("viewer_cli_stats");
    writeScene(dir, "");
    const Outcome v = runVolcl("view scene.json --headless --frames 5 --spin 15 --keys 1m --stats frames.csv "
                               "--target-ms 50 -o last.png",
                               dir);
    ASSERT_EQ(v.code, 0) << v.err;
    EXPECT_NE(v.err.find("shading on"), std::string::npos) << v.err;
    EXPECT_NE(v.err.find("mode mip"), std::string::npos) << v.err;
    EXPECT_NE(v.err.find("interactive frames: median"), std::string::npos) << v.err;
    std::ifstream csv(dir / "frames.csv");
    std::string line;
    std::getline(csv, line);
    EXPECT_EQ(line.rfind("frame,interactive,width,height,step", 0), 0u) << line;
    int rows = 0, interactive = 0;
    while (std::getline(csv, line)) {
        ++rows;
        interactive += line.find(",1,") == line.find(',') ? 1 : 0;
        double ms = std::stod(line.substr(line.rfind(',') + 1));
        EXPECT_GT(ms, 0.0);
        EXPECT_TRUE(std::isfinite(ms));
    }
    EXPECT_EQ(rows, 5);
    EXPECT_EQ(interactive, 3); // the first and the last frame are full quality
    EXPECT_TRUE(std::filesystem::exists(dir / "last.png"));
}

TEST(ViewerCli, RefusesBadInputWithOneLineAndNoOutput) {
    const auto dir = test::tempDir("viewer_cli_errors");
    writeScene(dir, "");
    struct Case {
        std::string args;
        int code;
        std::string mentions;
    };
    const Case cases[] = {
        {"view missing.json --headless -o out.png", 1, "missing.json"},
        {"view scene.json --headless --keys z -o out.png", 2, "'z'"},
        {"view scene.json --headless --frames 0 -o out.png", 2, "frames"},
        {"view scene.json --headless --target-ms 0 -o out.png", 2, "target-ms"},
        {"view scene.json --headless --mode fog -o out.png", 2, "fog"},
        {"view scene.json --headless --tf nope.json -o out.png", 1, "nope.json"},
        {"view scene.json --headless -o blob_30x26x22_uint8.raw", 2, "blob_30x26x22_uint8.raw"},
        // No display and no --headless: a clear message instead of a crash.
        {"view scene.json", 1, "--headless"},
    };
    const auto before = std::filesystem::file_size(dir / "blob_30x26x22_uint8.raw");
    for (const Case& c : cases) {
        const Outcome o = runVolcl(c.args, dir);
        EXPECT_EQ(o.code, c.code) << c.args << "\n" << o.err;
        EXPECT_EQ(lines(o.err.substr(o.err.find("volcl:"))), 1u) << c.args << "\n" << o.err;
        EXPECT_NE(o.err.find(c.mentions), std::string::npos) << c.args << "\n" << o.err;
        EXPECT_FALSE(std::filesystem::exists(dir / "out.png")) << c.args;
    }
    EXPECT_EQ(std::filesystem::file_size(dir / "blob_30x26x22_uint8.raw"), before); // input untouched
}

TEST(ViewerCli, TransportIsChosenFromTheDeviceAndShareIsRefusedWithoutIt) {
    const auto dir = test::tempDir("viewer_cli_transport");
    writeScene(dir, "");
    const bool sharing = test::computeContext().device().hasExtension("cl_khr_gl_sharing");
    const Outcome autoRun = runVolcl("view scene.json --headless --transport auto -o auto.png", dir);
    ASSERT_EQ(autoRun.code, 0) << autoRun.err;
    EXPECT_NE(autoRun.err.find(sharing ? "through cl_khr_gl_sharing" : "through pixel buffer object"),
              std::string::npos)
        << autoRun.err;
    const Outcome pbo = runVolcl("view scene.json --headless --transport pbo -o pbo.png", dir);
    ASSERT_EQ(pbo.code, 0) << pbo.err;
    EXPECT_NE(pbo.err.find("through pixel buffer object"), std::string::npos) << pbo.err;
    EXPECT_LE(maxDifference255(readImage(dir / "auto.png"), readImage(dir / "pbo.png")), 1.0);

    const Outcome share = runVolcl("view scene.json --headless --transport share -o share.png", dir);
    if (sharing) {
        EXPECT_EQ(share.code, 0) << share.err;
        EXPECT_LE(maxDifference255(readImage(dir / "share.png"), readImage(dir / "pbo.png")), 1.0);
    } else {
        EXPECT_EQ(share.code, 1) << share.err;
        EXPECT_EQ(lines(share.err.substr(share.err.find("volcl:"))), 1u) << share.err;
        EXPECT_NE(share.err.find("cl_khr_gl_sharing"), std::string::npos) << share.err;
        EXPECT_FALSE(std::filesystem::exists(dir / "share.png"));
    }
    const Outcome bad = runVolcl("view scene.json --headless --transport gl -o bad.png", dir);
    EXPECT_EQ(bad.code, 2) << bad.err;
    EXPECT_NE(bad.err.find("'gl'"), std::string::npos) << bad.err;
    EXPECT_FALSE(std::filesystem::exists(dir / "bad.png"));
}

TEST(ViewerCli, TakesEverySceneFlagOfRender) {
    const auto dir = test::tempDir("viewer_cli_flags");
    writeScene(dir, "");
    // The same overrides on both commands: camera, image, step, effects, lights, clipping, iso, background.
    const std::string flags =
        "--eye 50,-20,-40 --target 14,12,10 --up 0,0,1 --view-height 36 --width 64 --height 50 --step 0.4 "
        "--background 0.3,0.1,0.1,1 --light dir:-1,1,-1@1.2 --shading 0.3,0.7,0.2,16 --clip 1,0,0,-13 "
        "--early-termination 0.97";
    const Outcome r = runVolcl("render --scene scene.json " + flags + " -o render.png", dir);
    ASSERT_EQ(r.code, 0) << r.err;
    const Outcome v = runVolcl("view scene.json --headless " + flags + " -o view.png", dir);
    ASSERT_EQ(v.code, 0) << v.err;
    EXPECT_NE(v.err.find("shading"), std::string::npos) << v.err;
    EXPECT_NE(v.err.find("clipping"), std::string::npos) << v.err;
    const ImageBuffer a = readImage(dir / "render.png"), b = readImage(dir / "view.png");
    EXPECT_EQ(b.width, 64);
    EXPECT_EQ(b.height, 50);
    EXPECT_LE(maxDifference255(a, b), 1.0);
    // The scene given by --scene and the volume given by --volume work like the positional input.
    const Outcome viaFlag = runVolcl("view --scene scene.json --headless " + flags + " -o flag.png", dir);
    ASSERT_EQ(viaFlag.code, 0) << viaFlag.err;
    EXPECT_LE(maxDifference255(a, readImage(dir / "flag.png")), 1.0);
    const Outcome twice = runVolcl("view scene.json --scene scene.json --headless -o twice.png", dir);
    EXPECT_EQ(twice.code, 2) << twice.err;
    const Outcome badLight = runVolcl("view scene.json --headless --light sun -o bad.png", dir);
    EXPECT_EQ(badLight.code, 2) << badLight.err;
    EXPECT_NE(badLight.err.find("sun"), std::string::npos) << badLight.err;
    EXPECT_FALSE(std::filesystem::exists(dir / "bad.png"));
}

TEST(ViewerCli, HeadlessOverlayChangesOnlyTheTopLeftCorner) {
    const auto dir = test::tempDir("viewer_cli_overlay");
    writeScene(dir, "");
    const Outcome plain = runVolcl("view scene.json --headless --width 320 --height 200 -o plain.png", dir);
    ASSERT_EQ(plain.code, 0) << plain.err;
    const Outcome over =
        runVolcl("view scene.json --headless --width 320 --height 200 --overlay -o overlay.png", dir);
    ASSERT_EQ(over.code, 0) << over.err;
    const ImageBuffer a = readImage(dir / "plain.png"), b = readImage(dir / "overlay.png");
    ASSERT_EQ(a.width, b.width);
    ASSERT_EQ(a.height, b.height);
    int changedOutside = 0, white = 0, changedInside = 0;
    for (int y = 0; y < a.height; ++y)
        for (int x = 0; x < a.width; ++x) {
            bool differs = false;
            for (int c = 0; c < 3; ++c)
                differs = differs || a.at(x, y, c) != b.at(x, y, c);
            // The panel is at most 52 characters (320 px) wide and 7 lines (13 px) tall plus its margins.
            const bool corner = y < 7 * 13 + 8;
            if (differs && !corner) ++changedOutside;
            if (differs && corner) ++changedInside;
            white += b.at(x, y, 0) == 1.0f && b.at(x, y, 1) == 1.0f && b.at(x, y, 2) == 1.0f;
        }
    EXPECT_EQ(changedOutside, 0);
    EXPECT_GT(changedInside, 1000);
    EXPECT_GT(white, 200); // glyph pixels
    // The `o` key does the same in headless runs, and twice is off again.
    ASSERT_EQ(runVolcl("view scene.json --headless --width 320 --height 200 --keys o -o key.png", dir).code,
              0);
    EXPECT_EQ(maxDifference255(b, readImage(dir / "key.png")), 0.0);
    ASSERT_EQ(runVolcl("view scene.json --headless --width 320 --height 200 --keys oo -o keys.png", dir).code,
              0);
    EXPECT_EQ(maxDifference255(a, readImage(dir / "keys.png")), 0.0);
}

#if defined(VOLCL_WITH_BENCH) // the `volcl bench` module is built (VOLCL_BUILD_BENCH)
TEST(ViewerCli, BenchViewReportsFrameTimesAgainstTheTarget) {
    const auto dir = test::tempDir("viewer_cli_bench");
    writeScene(dir, "");
    const Outcome o = runVolcl("bench view scene.json --width 64 --height 48 --frames 5 --spin 12 --stills 2 "
                               "--target-ms 80 --csv frames.csv --json summary.json",
                               dir);
    ASSERT_EQ(o.code, 0) << o.err;
    std::ifstream in(dir / "summary.json");
    std::stringstream js;
    js << in.rdbuf();
    const std::string j = js.str();
    for (const char* key :
         {"\"interactive_median_ms\"", "\"interactive_p90_ms\"", "\"fraction_within_target_plus_10pct\"",
          "\"still_median_ms\"", "\"interactive_upload_median_ms\"", "\"still_render_median_ms\"",
          "\"transport\"", "\"target_ms\": 80"})
        EXPECT_NE(j.find(key), std::string::npos) << key << "\n" << j;
    EXPECT_NE(j.find("\"interactive_frames\": 3"), std::string::npos) << j;
    // The orbit's last frame + 2 stills, + 1 more: after preview-tier frames the settled view refines to the ray
    // marcher's frame in ViewerSession::kRefinePasses = 4 still frames, and a headless run finishes it.
    EXPECT_NE(j.find("\"still_frames\": 4"), std::string::npos) << j;
    std::ifstream csv(dir / "frames.csv");
    std::string line;
    std::getline(csv, line);
    EXPECT_NE(line.find("upload_ms"), std::string::npos) << line;
    int rows = 0;
    while (std::getline(csv, line))
        ++rows;
    EXPECT_EQ(rows, 8); // 5 orbit frames + 2 stills + 1 refinement frame
    const Outcome bad = runVolcl("bench view scene.json --frames 2 --csv bad.csv", dir);
    EXPECT_EQ(bad.code, 2) << bad.err;
    EXPECT_FALSE(std::filesystem::exists(dir / "bad.csv"));
}
#endif
