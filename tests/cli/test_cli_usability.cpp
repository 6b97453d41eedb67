// The volcl executable for a first-time user: framed cameras, named views, default lights, presets,
// --version, named unknown subcommands, help examples, --frame, compare --level, --replace-nan, MIP
// window, smooth reconstruction filters.
#include "../TestUtil.hpp"
#include "CliRun.hpp"
#include "host/image/ImageIo.hpp"
#include "host/io/VolumeIo.hpp"
#include "host/mesh/MeshGenerator.hpp"
#include "host/mesh/MeshIo.hpp"
#include "render/grid/FilterAccuracy.hpp"

#include <sys/wait.h>

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

/// A 40^3 float blob off-centre along +x and +z, so views from different sides differ.
std::filesystem::path writeBlob(const std::filesystem::path& dir) {
    Volume v = test::makeFloatVolume({40, 40, 40}, [](double x, double y, double z) {
        const double dx = x - 26, dy = y - 19.5, dz = z - 24;
        return 200.0 * std::exp(-(dx * dx + dy * dy + dz * dz) / 60.0);
    });
    const auto p = dir / "blob.nrrd";
    writeVolumeFile(v, p);
    return p;
}

const char* kTf =
    R"({"domain": [0, 200], "color": [[0, 1, 1, 1], [200, 1, 1, 1]], "extinction": [[0, 0], [200, 0.5]]})";

double alphaCoverage(const ImageBuffer& img) {
    std::size_t covered = 0;
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x)
            covered += img.at(x, y, 3) > 0.02f;
    return double(covered) / double(img.width * img.height);
}

} // namespace

TEST(CliUsability, EyeAndTargetWithoutHeightFrameTheBox) {
    // Before: the orthographic height stayed 1 world unit: a featureless close-up of one spot.
    auto dir = test::tempDir("cli_use_frame");
    const auto vol = writeBlob(dir);
    std::ofstream(dir / "tf.json") << kTf;
    RunResult r =
        run("render --volume " + vol.string() + " --tf " + (dir / "tf.json").string() +
                " --eye 400,19.5,19.5 --target 19.5,19.5,19.5 --up 0,0,1 --width 64 --height 64 -o " +
                (dir / "a.exr").string(),
            dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(has(r.err, "fitted to the box")) << r.err;
    const ImageBuffer img = readImage(dir / "a.exr");
    const double c = alphaCoverage(img);
    EXPECT_GT(c, 0.03);
    EXPECT_LT(c, 0.9); // the blob sits inside the frame, with empty space around it
    float lo = 1.0f, hi = 0.0f;
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
            lo = std::min(lo, img.at(x, y, 3));
            hi = std::max(hi, img.at(x, y, 3));
        }
    EXPECT_GT(hi - lo, 0.5f); // structure, not one uniform close-up
    // The image edge is empty: the whole box is in view.
    for (int x = 0; x < img.width; ++x)
        EXPECT_LT(img.at(x, 0, 3), 0.02f);
}

TEST(CliUsability, PartialSceneCamerasAreFramedAsFlagsAre) {
    // Before: a scene camera missing fields took fixed defaults (height 1, eye 0,0,-1, target the origin):
    // a featureless close-up instead of the framed box the same flags give.
    auto dir = test::tempDir("cli_use_partial_camera");
    const auto vol = writeBlob(dir);
    std::ofstream(dir / "tf.json") << kTf;
    auto render = [&](const std::string& args, const std::string& out) {
        RunResult r = run("render --tf " + (dir / "tf.json").string() + " --width 48 --height 48 " + args +
                              " -o " + (dir / out).string(),
                          dir);
        EXPECT_EQ(r.exitCode, 0) << r.err;
        return readImage(dir / out);
    };
    auto maxDiff = [](const ImageBuffer& a, const ImageBuffer& b) {
        double worst = 0.0;
        for (std::size_t i = 0; i < a.pixels.size(); ++i)
            worst = std::max(worst, double(std::abs(a.pixels[i] - b.pixels[i])));
        return worst;
    };
    struct Case {
        const char* camera; // the scene's camera object
        const char* flags;  // the same camera as flags
    };
    for (Case c : {Case{R"({"eye": [400, 19.5, 19.5], "up": [0, 0, 1]})", "--eye 400,19.5,19.5 --up 0,0,1"},
                   Case{R"({"eye": [400, 19.5, 19.5], "target": [19.5, 19.5, 19.5], "up": [0, 0, 1]})",
                        "--eye 400,19.5,19.5 --target 19.5,19.5,19.5 --up 0,0,1"},
                   Case{R"({"projection": "perspective"})", "--projection perspective"},
                   Case{R"({"up": [1, 0, 0]})", "--up 1,0,0"}}) {
        const auto scene = dir / "scene.json";
        std::ofstream(scene) << R"({"volume": ")" << vol.string() << R"(", "camera": )" << c.camera << "}";
        const ImageBuffer fromScene = render("--scene " + scene.string(), "scene.exr");
        const ImageBuffer fromFlags = render("--volume " + vol.string() + " " + c.flags, "flags.exr");
        ASSERT_EQ(fromScene.pixels.size(), fromFlags.pixels.size());
        EXPECT_LT(maxDiff(fromScene, fromFlags), 1e-6) << c.camera;
        const double cover = alphaCoverage(fromScene);
        EXPECT_GT(cover, 0.03) << c.camera; // the blob is in view, not missed or a uniform close-up
        EXPECT_LT(cover, 0.9) << c.camera;
    }
}

TEST(CliUsability, FrontAndBackViewsAreMirrorImages) {
    auto dir = test::tempDir("cli_use_views");
    const auto vol = writeBlob(dir);
    std::ofstream(dir / "tf.json") << kTf;
    auto render = [&](const std::string& view, const std::string& out) {
        RunResult r = run("render --volume " + vol.string() + " --tf " + (dir / "tf.json").string() +
                              " --view " + view + " --width 48 --height 48 -o " + (dir / out).string(),
                          dir);
        EXPECT_EQ(r.exitCode, 0) << r.err;
        return readImage(dir / out);
    };
    const ImageBuffer front = render("front", "front.exr"), back = render("back", "back.exr");
    const ImageBuffer top = render("top", "top.exr");
    // Opacity does not depend on the direction a ray runs: the back view is the front view mirrored left-right.
    double worst = 0.0, frontTopGap = 0.0;
    for (int y = 0; y < 48; ++y)
        for (int x = 0; x < 48; ++x) {
            worst = std::max(worst, double(std::abs(front.at(x, y, 3) - back.at(47 - x, y, 3))));
            frontTopGap = std::max(frontTopGap, double(std::abs(front.at(x, y, 3) - top.at(x, y, 3))));
        }
    EXPECT_LT(worst, 2e-3);
    EXPECT_GT(frontTopGap, 0.05); // a different side of an off-centre blob
    // +z is up in the front view: the blob (above the centre in z) sits in the upper half.
    double upper = 0.0, lower = 0.0;
    for (int y = 0; y < 48; ++y)
        for (int x = 0; x < 48; ++x)
            (y < 24 ? upper : lower) += front.at(x, y, 3);
    EXPECT_GT(upper, lower);
    EXPECT_EQ(run("render --volume " + vol.string() + " --tf " + (dir / "tf.json").string() +
                      " --view sideways -o " + (dir / "x.exr").string(),
                  dir)
                  .exitCode,
              2);
    EXPECT_EQ(run("render --volume " + vol.string() + " --tf " + (dir / "tf.json").string() +
                      " --view front --eye 1,2,3 -o " + (dir / "x.exr").string(),
                  dir)
                  .exitCode,
              2);
    EXPECT_FALSE(std::filesystem::exists(dir / "x.exr"));
}

TEST(CliUsability, ShadingWithoutALightUsesAHeadLight) {
    // Before: --shading without --light rendered flat; only --explain said "dropped shading".
    auto dir = test::tempDir("cli_use_light");
    const auto vol = writeBlob(dir);
    std::ofstream(dir / "tf.json") << kTf;
    const std::string base = "render --volume " + vol.string() + " --tf " + (dir / "tf.json").string() +
                             " --view front --width 32 --height 32 ";
    RunResult r = run(base + "--shading 0.2,0.7,0.3,32 --explain -o " + (dir / "lit.exr").string(), dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(has(r.err, "head light")) << r.err;
    EXPECT_TRUE(has(r.out, "head light")) << r.out;
    EXPECT_TRUE(has(r.out, "-DSHADING")) << r.out;
    EXPECT_FALSE(has(r.out, "rendered unshaded")) << r.out;
    // Iso mode shades unless told not to.
    RunResult iso = run(base + "--mode iso --iso 100 --explain", dir);
    ASSERT_EQ(iso.exitCode, 0) << iso.err;
    EXPECT_TRUE(has(iso.out, "-DSHADING")) << iso.out;
    RunResult flat = run(base + "--mode iso --iso 100 --no-shading --explain", dir);
    ASSERT_EQ(flat.exitCode, 0) << flat.err;
    EXPECT_FALSE(has(flat.out, "-DSHADING")) << flat.out;
}

TEST(CliUsability, PresetsAndNormalisedParaViewMaps) {
    // Before: a colour-only map on [0, 1] kept its range and opacity 1 (tau 1000): an opaque blob.
    auto dir = test::tempDir("cli_use_preset");
    const auto vol = writeBlob(dir);
    std::ofstream(dir / "pv.json") << R"([{"ColorSpace": "Diverging", "Name": "Cool to Warm",
        "RGBPoints": [0, 0.23137254902, 0.298039215686, 0.752941176471, 0.5, 0.865, 0.865, 0.865,
                      1, 0.705882352941, 0.0156862745098, 0.149019607843]}])";
    const std::string base = "render --volume " + vol.string() + " --view front --width 32 --height 32 ";
    RunResult r = run(base + "--tf " + (dir / "pv.json").string() + " -o " + (dir / "pv.exr").string(), dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const ImageBuffer img = readImage(dir / "pv.exr");
    EXPECT_LT(img.at(16, 16, 3), 0.99f); // translucent in the middle of the blob
    EXPECT_GT(img.at(16, 16, 3), 0.05f);
    // The built-in preset, and --tf-range pushing the whole map above the data: nothing visible.
    RunResult p = run(base + "--tf preset:cool-to-warm -o " + (dir / "preset.exr").string(), dir);
    ASSERT_EQ(p.exitCode, 0) << p.err;
    RunResult high =
        run(base + "--tf preset:cool-to-warm --tf-range 1000,2000 -o " + (dir / "high.exr").string(), dir);
    ASSERT_EQ(high.exitCode, 0) << high.err;
    EXPECT_LT(readImage(dir / "high.exr").at(16, 16, 3), 1e-6f);
    RunResult bad = run(base + "--tf preset:nope -o " + (dir / "bad.exr").string(), dir);
    EXPECT_EQ(bad.exitCode, 2);
    EXPECT_TRUE(has(bad.err, "viridis")) << bad.err;
    EXPECT_EQ(run(base + "--tf preset:viridis --tf-range 5,5 -o " + (dir / "bad.exr").string(), dir).exitCode,
              2);
    EXPECT_FALSE(std::filesystem::exists(dir / "bad.exr"));
}

TEST(CliUsability, VersionSubcommandsAndExamples) {
    auto dir = test::tempDir("cli_use_version");
    RunResult v = run("--version", dir);
    EXPECT_EQ(v.exitCode, 0);
    EXPECT_TRUE(has(v.out, "0.")) << v.out;
    RunResult foo = run("foo", dir);
    EXPECT_EQ(foo.exitCode, 2);
    EXPECT_TRUE(has(foo.err, "unknown subcommand 'foo'")) << foo.err;
    EXPECT_EQ(run("bench nothing", dir).exitCode, 2);
    for (const char* cmd : {"", "info", "devices", "convert", "demo", "preint", "encode", "decode", "compare",
                            "render", "view"}) {
        RunResult h = run(std::string(cmd) + " --help", dir);
        EXPECT_EQ(h.exitCode, 0) << cmd;
        EXPECT_TRUE(has(h.out, "Examples:")) << "volcl " << cmd << " --help has no example";
        EXPECT_FALSE(has(h.out, "CONTRACT")) << cmd;
    }
    RunResult rh = run("render --help", dir);
    EXPECT_TRUE(has(rh.out, "--width INT=512")) << rh.out;
    EXPECT_TRUE(has(rh.out, "--step TEXT=0.5vox")) << rh.out; // #37: the default step is in voxels
}

TEST(CliUsability, MeshSortFlagIsCheckedBeforeAnyOutput) {
    auto dir = test::tempDir("cli_use_sort");
    const mesh::TetMesh m = mesh::generateHexGridMesh({2, 2, 2}, {0, 0, 0}, {1, 1, 1},
                                                      [](double x, double, double) { return x; });
    mesh::writeVtu(m, dir / "cube.vtu");
    RunResult bad =
        run("render --volume " + (dir / "cube.vtu").string() +
                " --tf preset:viridis --width 16 --height 16 --sort painter -o " + (dir / "bad.exr").string(),
            dir);
    EXPECT_EQ(bad.exitCode, 2);
    EXPECT_TRUE(has(bad.err, "render.sort 'painter' is unknown")) << bad.err;
    EXPECT_FALSE(std::filesystem::exists(dir / "bad.exr"));
    RunResult help = run("render --help", dir);
    EXPECT_TRUE(has(help.out, "--sort")) << help.out;
}

#if defined(VOLCL_WITH_BENCH) // the `volcl bench` module is built (VOLCL_BUILD_BENCH)
TEST(CliUsability, BenchSubcommandsHaveExamples) {
    auto dir = test::tempDir("cli_use_bench_help");
    for (const char* cmd :
         {"bench", "bench codec", "bench preint", "bench render", "bench view", "bench mesh"}) {
        RunResult h = run(std::string(cmd) + " --help", dir);
        EXPECT_EQ(h.exitCode, 0) << cmd;
        EXPECT_TRUE(has(h.out, "Examples:")) << "volcl " << cmd << " --help has no example";
        EXPECT_FALSE(has(h.out, "CONTRACT")) << cmd;
    }
}
#endif

TEST(CliUsability, RenderFrameOfASeries) {
    std::filesystem::path data;
    VOLCL_REQUIRE_SHARED_DATA(data);
    auto dir = test::tempDir("cli_use_frame_k");
    const auto series = data / "timevarying" / "functional.nii.gz";
    const std::string base =
        "render --volume " + series.string() + " --tf preset:grayscale --width 16 --height 16 ";
    RunResult r0 = run(base + "-o " + (dir / "f0.exr").string(), dir);
    ASSERT_EQ(r0.exitCode, 0) << r0.err;
    EXPECT_TRUE(has(r0.err, "frame 0 of 20")) << r0.err;
    RunResult r5 = run(base + "--frame 5 -o " + (dir / "f5.exr").string(), dir);
    ASSERT_EQ(r5.exitCode, 0) << r5.err;
    EXPECT_FALSE(has(r5.err, "frame 0 of")) << r5.err;
    RunResult bad = run(base + "--frame 20 -o " + (dir / "bad.exr").string(), dir);
    EXPECT_EQ(bad.exitCode, 2);
    EXPECT_TRUE(has(bad.err, "--frame 20")) << bad.err;
    EXPECT_FALSE(std::filesystem::exists(dir / "bad.exr"));
}

TEST(CliUsability, CompareAtALevelAndOverARegion) {
    // Before: compare refused different dims, so a level decode could not be compared with its source.
    auto dir = test::tempDir("cli_use_compare");
    Volume v({64, 64, 64}, ScalarType::UInt8);
    auto vals = v.values<std::uint8_t>();
    for (std::size_t i = 0; i < vals.size(); ++i)
        vals[i] = std::uint8_t((i * 7919u) % 251u);
    writeVolumeFile(v, dir / "v.nrrd");
    ASSERT_EQ(run("encode " + (dir / "v.nrrd").string() + " --lossless -o " + (dir / "l.vcz").string(), dir)
                  .exitCode,
              0);
    RunResult lossy =
        run("encode " + (dir / "v.nrrd").string() + " --psnr 30 -o " + (dir / "p.vcz").string(), dir);
    ASSERT_EQ(lossy.exitCode, 0) << lossy.err;
    EXPECT_FALSE(has(lossy.err, "stored exactly")) << lossy.err; // only --max-error stores voxels exactly
    RunResult maxe =
        run("encode " + (dir / "v.nrrd").string() + " --max-error 2 -o " + (dir / "m.vcz").string(), dir);
    ASSERT_EQ(maxe.exitCode, 0) << maxe.err;
    EXPECT_TRUE(has(maxe.err, "stored exactly")) << maxe.err;

    RunResult level = run(
        "compare " + (dir / "v.nrrd").string() + " " + (dir / "l.vcz").string() + " --level 1 --json", dir);
    ASSERT_EQ(level.exitCode, 0) << level.err;
    EXPECT_TRUE(has(level.out, "\"max_abs_error\": 0.0")) << level.out;
    RunResult lossyLevel = run(
        "compare " + (dir / "v.nrrd").string() + " " + (dir / "p.vcz").string() + " --level 1 --json", dir);
    ASSERT_EQ(lossyLevel.exitCode, 0) << lossyLevel.err;
    EXPECT_TRUE(has(lossyLevel.out, "psnr_db")) << lossyLevel.out;
    RunResult region = run("compare " + (dir / "v.nrrd").string() + " " + (dir / "l.vcz").string() +
                               " --region 8,8,8:40,40,40 --json",
                           dir);
    ASSERT_EQ(region.exitCode, 0) << region.err;
    EXPECT_TRUE(has(region.out, "\"max_abs_error\": 0.0")) << region.out;
    // Without --level, different dims are refused with a hint.
    ASSERT_EQ(run("decode " + (dir / "l.vcz").string() + " --level 1 -o " + (dir / "half.nrrd").string(), dir)
                  .exitCode,
              0);
    RunResult dims = run("compare " + (dir / "v.nrrd").string() + " " + (dir / "half.nrrd").string(), dir);
    EXPECT_EQ(dims.exitCode, 2);
    EXPECT_TRUE(has(dims.err, "--level")) << dims.err;
    // Following the hint compares the level decode with its source's low band (before: both sides were
    // coarsened, and the sizes differed again).
    RunResult hinted =
        run("compare " + (dir / "v.nrrd").string() + " " + (dir / "half.nrrd").string() + " --level 1 --json",
            dir);
    ASSERT_EQ(hinted.exitCode, 0) << hinted.err;
    EXPECT_TRUE(has(hinted.out, "\"max_abs_error\": 0.0")) << hinted.out;
}

TEST(CliUsability, ConvertReplacesNans) {
    auto dir = test::tempDir("cli_use_nan");
    Volume v = test::makeFloatVolume({8, 8, 8}, [](double x, double, double) { return x; });
    v.values<float>()[v.index(3, 3, 3)] = NAN;
    writeVolumeFile(v, dir / "nan.nrrd");
    RunResult r = run(
        "convert " + (dir / "nan.nrrd").string() + " --replace-nan -1 -o " + (dir / "ok.nrrd").string(), dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(has(r.err, "replaced 1 NaN")) << r.err;
    const Volume out = readVolume(dir / "ok.nrrd");
    EXPECT_EQ(out.values<float>()[out.index(3, 3, 3)], -1.0f);
    EXPECT_EQ(out.stats().nanCount, 0u);
    EXPECT_EQ(
        run("convert " + (dir / "nan.nrrd").string() + " --replace-nan nan -o " + (dir / "x.nrrd").string(),
            dir)
            .exitCode,
        2);
}

TEST(CliUsability, MipWindowGivesGreyscale) {
    // Before: MIP went through the DVR TF's opacity (1 - exp(-tau)) and came out dull grey.
    auto dir = test::tempDir("cli_use_mip");
    const auto vol = writeBlob(dir);
    std::ofstream(dir / "tf.json") << kTf;
    const std::string base = "render --volume " + vol.string() + " --tf " + (dir / "tf.json").string() +
                             " --view front --width 32 --height 32 --mode mip ";
    RunResult r = run(base + "--window 100,200 --explain -o " + (dir / "mip.exr").string(), dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(has(r.out, "MIP colour grey: window centre 100, width 200")) << r.out;
    const ImageBuffer img = readImage(dir / "mip.exr");
    // The blob's peak (about 200) is the window's top: the brightest pixel is white, grey = alpha.
    float peak = 0.0f;
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
            peak = std::max(peak, img.at(x, y, 0));
            EXPECT_FLOAT_EQ(img.at(x, y, 0), img.at(x, y, 3));
        }
    EXPECT_GT(peak, 0.95f);
    RunResult old = run(base + "--mip-color tf-opacity --explain", dir);
    ASSERT_EQ(old.exitCode, 0) << old.err;
    EXPECT_TRUE(has(old.out, "-DMIP_COLOR=2")) << old.out;
    RunResult bad = run(base + "--window 100,0 -o " + (dir / "bad.exr").string(), dir);
    EXPECT_EQ(bad.exitCode, 2);
    EXPECT_TRUE(has(bad.err, "render.window")) << bad.err;
    EXPECT_FALSE(std::filesystem::exists(dir / "bad.exr"));
    RunResult color = run(base + "--mip-color pink --explain", dir);
    EXPECT_EQ(color.exitCode, 2);
    EXPECT_TRUE(has(color.err, "grey, tf, tf-opacity")) << color.err;
}

TEST(CliUsability, SmoothFilterOnEightBitIsoSurfaces) {
    // Before: no reconstruction but trilinear; 8-bit iso-surfaces showed contour-line terraces.
    auto dir = test::tempDir("cli_use_filter");
    const Vec3 c{19.3, 20.2, 19.6};
    writeVolumeFile(quantisedSphere({40, 40, 40}, c, 13.0, 1.0), dir / "sphere.nrrd");
    std::ofstream(dir / "tf.json")
        << R"({"domain": [0, 255], "color": [[0, 1, 1, 1]], "extinction": [[0, 0]]})";
    const std::string base = "render --volume " + (dir / "sphere.nrrd").string() + " --tf " +
                             (dir / "tf.json").string() + " --width 96 --height 96 --mode iso --iso 128.5 ";
    auto roughness = [&](const std::string& flags, const std::string& name) {
        RunResult r = run(base + flags + " -o " + (dir / name).string(), dir);
        EXPECT_EQ(r.exitCode, 0) << r.err;
        return shadingRoughness(readImage(dir / name));
    };
    const double linear = roughness("", "linear.exr");
    const double smooth = roughness("--filter bspline --smoothing 1", "smooth.exr");
    EXPECT_LT(smooth, 0.4 * linear) << "linear " << linear << ", bspline s1 " << smooth;
    RunResult ex = run(base + "--filter bspline --smoothing 1 --sobel --explain", dir);
    ASSERT_EQ(ex.exitCode, 0) << ex.err;
    EXPECT_TRUE(has(ex.out, "-DFILTER_BSPLINE")) << ex.out;
    EXPECT_TRUE(has(ex.out, "smoothed by a Gaussian of sigma 1 voxel")) << ex.out;
    EXPECT_TRUE(has(ex.out, "dropped gradient sobel")) << ex.out;
    RunResult bad = run(base + "--filter quintic --explain", dir);
    EXPECT_EQ(bad.exitCode, 2);
    EXPECT_TRUE(has(bad.err, "linear, cubic, bspline")) << bad.err;
    RunResult far = run(base + "--filter bspline --smoothing 20 --explain", dir);
    EXPECT_EQ(far.exitCode, 2);
    EXPECT_TRUE(has(far.err, "render.smoothing")) << far.err;
}
