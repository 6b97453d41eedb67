// Defaults that fit the data (issue #37): renders without a transfer function or a step, presets on any
// data range, the automatic opacity unit distance, and the CLI's smaller items (--shading, early -o checks,
// iso values outside the data, view --spin/--orbit, info of a .vcz).
#include "../TestUtil.hpp"
#include "CliRun.hpp"
#include "host/image/ImageIo.hpp"
#include "host/io/VolumeIo.hpp"
#include "render/RenderInput.hpp"
#include "render/Scene.hpp"

#include <sys/wait.h>

#include <cmath>
#include <fstream>
#include <iostream>
#include <regex>
#include <sstream>

using namespace volcl;

namespace {

using test::has;
using test::RunResult;

RunResult run(const std::string& args, const std::filesystem::path& dir) {
    return test::runVolcl(args, dir, true);
}

/// A 48^3 "head": a shell of skin (100) around a brighter core (160) on a dark background (2), spacing 1 mm,
/// so iso 80 finds the skin and a MIP window of 110,40 (90..130) lights it.
Volume headLike() {
    Volume v = test::makeFloatVolume({48, 48, 48}, [](double x, double y, double z) {
        const double r =
            std::sqrt((x - 23.5) * (x - 23.5) + (y - 23.5) * (y - 23.5) + (z - 23.5) * (z - 23.5));
        return r < 12 ? 160.0 : r < 20 ? 100.0 : 2.0;
    });
    return v;
}

/// Fraction of pixels whose luminance (linear, composited over black) exceeds `threshold`.
double litFraction(const ImageBuffer& img, double threshold) {
    std::size_t lit = 0;
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
            const double l = 0.2126 * img.at(x, y, 0) + 0.7152 * img.at(x, y, 1) + 0.0722 * img.at(x, y, 2);
            lit += l > threshold;
        }
    return double(lit) / double(img.width * img.height);
}

double meanLuminance(const ImageBuffer& img) {
    double sum = 0.0;
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x)
            sum += 0.2126 * img.at(x, y, 0) + 0.7152 * img.at(x, y, 1) + 0.0722 * img.at(x, y, 2);
    return sum / double(img.width * img.height);
}

/// sqrt(mean((a - b)^2)) / sqrt(mean(b^2)) over the RGB channels: b is the reference.
double relativeRmse(const ImageBuffer& a, const ImageBuffer& b) {
    EXPECT_EQ(a.width, b.width);
    EXPECT_EQ(a.height, b.height);
    double err = 0.0, ref = 0.0;
    for (int y = 0; y < b.height; ++y)
        for (int x = 0; x < b.width; ++x)
            for (int c = 0; c < 3; ++c) {
                const double d = double(a.at(x, y, c)) - double(b.at(x, y, c));
                err += d * d;
                ref += double(b.at(x, y, c)) * double(b.at(x, y, c));
            }
    return std::sqrt(err / std::max(ref, 1e-300));
}

const std::filesystem::path kCh2 = "/usr/share/mricron/templates/ch2.nii.gz";

} // namespace

TEST(CliDefaults, EveryRenderHelpExampleRunsAsWritten) {
    // Before: 3 of the 5 examples (iso, iso with smoothing, MIP) exited 2 "no transfer function".
    auto dir = test::tempDir("cli_defaults_help");
    writeVolumeFile(headLike(), dir / "head.nii.gz");
    test::writeFile(dir / "pv.json", R"([{"ColorSpace": "RGB", "RGBPoints": [0, 0, 0, 1, 1, 1, 0.5, 0],
        "Points": [0, 0, 0.5, 0, 1, 0.6, 0.5, 0]}])");
    const RunResult help = run("render --help", dir);
    ASSERT_EQ(help.exitCode, 0) << help.err;
    std::istringstream lines(help.out);
    std::string line;
    int examples = 0;
    while (std::getline(lines, line)) {
        std::smatch example;
        if (!std::regex_match(line, example, std::regex("\\s+volcl render (--.*)"))) continue;
        const std::string args = example[1].str();
        ++examples;
        const RunResult r = run("render " + args + " --width 48 --height 48", dir);
        ASSERT_EQ(r.exitCode, 0) << args << ": " << r.err;
        // The output named by the example exists and shows the head (oracle: the skin's disc, radius 20 of
        // the 47-voxel box, covers about a fifth of the framed image: at least a tenth is lit in every mode).
        std::smatch m;
        ASSERT_TRUE(std::regex_search(args, m, std::regex("-o (\\S+)"))) << args;
        const ImageBuffer img = readImage(dir / m[1].str());
        EXPECT_GT(litFraction(img, 0.02), 0.1) << args;
    }
    EXPECT_GE(examples, 5) << help.out;
}

TEST(CliDefaults, WithoutFlagsEveryModeRendersSomething) {
    // Before: every mode without --tf exited 2, iso and grey MIP included, which use no transfer function.
    auto dir = test::tempDir("cli_defaults_modes");
    writeVolumeFile(headLike(), dir / "head.nrrd");
    for (const std::string mode : {"dvr", "mip", "xray", "iso --iso 80"}) {
        const RunResult r =
            run("render --volume head.nrrd --width 48 --height 48 -o m.exr --mode " + mode, dir);
        ASSERT_EQ(r.exitCode, 0) << mode << ": " << r.err;
        EXPECT_GT(litFraction(readImage(dir / "m.exr"), 0.02), 0.1) << mode; // the disc: about a fifth
    }
    // The defaults applied are stated: the transfer function, the step and the unit distance.
    const RunResult e = run("render --volume head.nrrd --explain", dir);
    ASSERT_EQ(e.exitCode, 0) << e.err;
    EXPECT_TRUE(has(e.out, "default: transfer function: ParaView's default")) << e.out;
    EXPECT_TRUE(has(e.out, "default: step: 0.5 voxel")) << e.out;
    EXPECT_TRUE(has(e.out, "default: opacity unit distance")) << e.out;
}

TEST(CliDefaults, NoFlagRenderOfRealMriAndCfdIsVisible) {
    // Before: exit 2 (no transfer function). Visible: at least 10 % of the pixels above 2 % luminance and a
    // mean luminance above 0.01 (linear), on a black background.
    auto dir = test::tempDir("cli_defaults_real");
    std::vector<std::filesystem::path> inputs;
    if (std::filesystem::exists(kCh2)) inputs.push_back(kCh2);
    const auto shared = test::sharedData();
    if (!shared.empty()) {
        inputs.push_back(shared / "regular/HeadMRVolume.mhd");
        inputs.push_back(shared / "regular/headsq/quarter.nhdr"); // CT
        inputs.push_back(shared / "unstructured/bluntfinxyz.bin");
    }
    if (inputs.empty()) GTEST_SKIP() << "neither mricron-data's ch2.nii.gz nor the shared data is installed";
    for (const auto& in : inputs) {
        const RunResult r = run("render --volume " + in.string() + " --width 64 --height 64 -o a.exr", dir);
        ASSERT_EQ(r.exitCode, 0) << in << ": " << r.err;
        const ImageBuffer img = readImage(dir / "a.exr");
        std::cout << in.filename().string() << " without flags: lit fraction " << litFraction(img, 0.02)
                  << ", mean luminance " << meanLuminance(img) << '\n';
        EXPECT_GT(litFraction(img, 0.02), 0.1) << in;
        EXPECT_GT(meanLuminance(img), 0.01) << in;
    }
}

TEST(CliDefaults, DefaultStepOnFineGridMatchesQuarterVoxelReference) {
    // walnut.vvd has spacing 0.015625: before, the default step was 0.5 world units (32 voxels) and the
    // image nearly black (with --tf preset:grayscale: relative RMSE 0.32, 2.5 % of the pixels lit). The
    // reference samples every quarter voxel, given in world units.
    const auto shared = test::sharedData();
    if (shared.empty()) GTEST_SKIP() << "shared data absent";
    auto dir = test::tempDir("cli_defaults_walnut");
    const std::string walnut = (shared / "regular/walnut.vvd").string();
    const std::string size = " --width 64 --height 64"; // every other setting a default
    const RunResult d = run("render --volume " + walnut + size + " -o d.exr", dir);
    ASSERT_EQ(d.exitCode, 0) << d.err;
    const RunResult q = run("render --volume " + walnut + size + " --step 0.00390625 -o q.exr", dir);
    ASSERT_EQ(q.exitCode, 0) << q.err;
    const ImageBuffer def = readImage(dir / "d.exr"), ref = readImage(dir / "q.exr");
    const double rmse = relativeRmse(def, ref), lit = litFraction(def, 0.02);
    std::cout << "walnut: relative RMSE of the default step against a quarter voxel " << rmse
              << ", lit fraction " << lit << ", mean luminance " << meanLuminance(def) << '\n';
    EXPECT_LT(rmse, 0.05);
    EXPECT_GT(lit, 0.1);
    // `--step Nvox` is the same step as its world-unit value.
    const RunResult v = run("render --volume " + walnut + size + " --step 0.25vox -o v.exr", dir);
    ASSERT_EQ(v.exitCode, 0) << v.err;
    EXPECT_EQ(relativeRmse(readImage(dir / "v.exr"), ref), 0.0);
}

TEST(CliDefaults, PresetsAreSpreadOverSmallDataRanges) {
    // Data in 1e-6..1e-4 lies inside [0, 1]: before, preset:viridis stayed on [0, 1] and the image was black.
    auto dir = test::tempDir("cli_defaults_small");
    Volume v = test::makeFloatVolume({32, 32, 32}, [](double x, double y, double z) {
        const double r2 = (x - 15.5) * (x - 15.5) + (y - 15.5) * (y - 15.5) + (z - 15.5) * (z - 15.5);
        return 2e-6 + 1e-4 * std::exp(-r2 / 80.0);
    });
    writeVolumeFile(v, dir / "small.nrrd");
    const RunResult r =
        run("render --volume small.nrrd --tf preset:viridis --width 48 --height 48 -o s.exr", dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_GT(litFraction(readImage(dir / "s.exr"), 0.01), 0.1);
    const auto shared = test::sharedData();
    if (shared.empty()) GTEST_SKIP() << "shared data absent (xsmall_turb.vtu, kiefer)";
    for (const std::string mesh : {"unstructured/xsmall_turb.vtu", "unstructured/kiefer/dataset.vtu"}) {
        const RunResult m = run("render --volume " + (shared / mesh).string() +
                                    " --tf preset:viridis --width 48 --height 48 -o m.exr",
                                dir);
        ASSERT_EQ(m.exitCode, 0) << mesh << ": " << m.err;
        const ImageBuffer img = readImage(dir / "m.exr");
        std::cout << mesh << " with preset:viridis: lit fraction " << litFraction(img, 0.01)
                  << ", mean luminance " << meanLuminance(img) << '\n';
        EXPECT_GT(litFraction(img, 0.01), 0.2) << mesh; // before: 0 and 0.024
    }
}

TEST(CliDefaults, ShadingIsASwitchWithAnOptionalValue) {
    // Before: `--shading --width 64` failed "The following argument was not expected: 64".
    auto dir = test::tempDir("cli_defaults_shading");
    writeVolumeFile(headLike(), dir / "head.nrrd");
    const RunResult bare = run("render --volume head.nrrd --shading --width 40 --height 30 -o a.exr", dir);
    ASSERT_EQ(bare.exitCode, 0) << bare.err;
    const ImageBuffer img = readImage(dir / "a.exr");
    EXPECT_EQ(img.width, 40);
    EXPECT_EQ(img.height, 30);
    const RunResult valued =
        run("render --volume head.nrrd --shading=0.1,0.8,0.2,16 --explain --width 40 --height 30", dir);
    ASSERT_EQ(valued.exitCode, 0) << valued.err;
    EXPECT_TRUE(has(valued.out, "SHADING")) << valued.out;
    EXPECT_EQ(run("render --volume head.nrrd --shading=1,2 -o b.exr", dir).exitCode, 2);
}

TEST(CliDefaults, BadOutputIsRefusedBeforeTheInputIsRead) {
    // Before: the volume was read (and rendered) first; a damaged volume hid the bad output directory.
    auto dir = test::tempDir("cli_defaults_output");
    test::writeFile(dir / "broken.nrrd", "NRRD0004\ntype: float\ndimension: 3\nsizes: 900 900 900\n"
                                         "encoding: raw\n\nshort");
    const RunResult r = run("render --volume broken.nrrd --tf preset:viridis -o missing/dir/x.png", dir);
    EXPECT_EQ(r.exitCode, 1) << r.err;
    EXPECT_TRUE(has(r.err, "missing/dir/x.png: output directory")) << r.err;
    EXPECT_FALSE(has(r.err, "broken.nrrd")) << r.err;
}

TEST(CliDefaults, IsoValueOutsideTheDataRangeIsNoted) {
    // Before: exit 0, an empty image and nothing said.
    auto dir = test::tempDir("cli_defaults_iso");
    writeVolumeFile(headLike(), dir / "head.nrrd");
    const RunResult r =
        run("render --volume head.nrrd --mode iso --iso 5000 --width 32 --height 32 -o i.exr", dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(has(r.err, "iso value 5000 is outside the data range [2, 160]")) << r.err;
    const RunResult in =
        run("render --volume head.nrrd --mode iso --iso 80 --width 32 --height 32 -o j.exr", dir);
    ASSERT_EQ(in.exitCode, 0) << in.err;
    EXPECT_FALSE(has(in.err, "outside the data range")) << in.err;
}

TEST(CliDefaults, OrbitMeansTheCameraPositionInRenderAndView) {
    // Before: view's --orbit was degrees per frame and its camera position was --start-orbit.
    auto dir = test::tempDir("cli_defaults_orbit");
    const RunResult view = run("view --help", dir);
    const RunResult render = run("render --help", dir);
    ASSERT_EQ(view.exitCode, 0) << view.err;
    auto orbitLine = [](const std::string& help) {
        std::smatch m;
        std::regex_search(help, m, std::regex("--orbit[^\\n]*\\n[^\\n]*"));
        return m.str();
    };
    EXPECT_TRUE(has(orbitLine(view.out), "Azimuth,elevation")) << view.out;
    EXPECT_EQ(orbitLine(view.out), orbitLine(render.out));
    EXPECT_TRUE(has(view.out, "--spin")) << view.out;
    EXPECT_FALSE(has(view.out, "--start-orbit")) << view.out;
}

TEST(CliDefaults, VczInfoIsASummaryWithSpacingAndOrigin) {
    // Before: one line per brick by default (150+ for a head) and no spacing or origin.
    auto dir = test::tempDir("cli_defaults_info");
    Volume v = headLike();
    v.spacing = {0.5, 0.75, 2.0};
    v.origin = {-3.0, 4.0, 10.0};
    writeVolumeFile(v, dir / "head.nrrd");
    ASSERT_EQ(run("encode head.nrrd --brick 16 -o head.vcz", dir).exitCode, 0);
    const RunResult r = run("info head.vcz", dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(has(r.out, "spacing  0.5 x 0.75 x 2")) << r.out;
    EXPECT_TRUE(has(r.out, "origin   -3, 4, 10")) << r.out;
    EXPECT_FALSE(has(r.out, ": brick  origin")) << r.out;
    const RunResult all = run("info head.vcz --bricks", dir);
    ASSERT_EQ(all.exitCode, 0) << all.err;
    EXPECT_TRUE(has(all.out, "frame 0: brick  origin")) << all.out;
    EXPECT_GT(std::count(all.out.begin(), all.out.end(), '\n'),
              std::count(r.out.begin(), r.out.end(), '\n') + 20);
}

TEST(SceneStep, WorldUnitsOrVoxelsAndHalfAVoxelByDefault) {
    // A number is world units; "Nvox" counts voxels of the finest spacing; a scene without a step takes 0.5vox.
    EXPECT_FALSE(Scene::fromJson(R"({"render": {"step": 0.02}})").stepVoxels);
    EXPECT_EQ(Scene::fromJson(R"({"render": {"step": 0.02}})").step, 0.02);
    EXPECT_EQ(Scene::fromJson(R"({"render": {"step": "0.25vox"}})").stepVoxels, 0.25);
    EXPECT_EQ(Scene::fromJson(R"({"render": {}})").stepVoxels, kDefaultStepVoxels);
    for (const char* bad : {R"("0.5vx")", R"("vox")", R"("-1vox")", R"("0.5 vox")", R"("nanvox")"})
        EXPECT_THROW(Scene::fromJson(std::string(R"({"render": {"step": )") + bad + "}}"), UsageError) << bad;
    const Scene s = Scene::fromJson(R"({"render": {"step": "0.1vox"}})");
    EXPECT_EQ(Scene::fromJson(s.toJson()).stepVoxels, s.stepVoxels); // the JSON form round-trips exactly
    // Resolved against the finest spacing (independent arithmetic: 0.1 of min(0.5, 0.25, 2)).
    Volume v({4, 4, 4}, ScalarType::Float32);
    v.spacing = {0.5, 0.25, 2.0};
    const Scene r = RenderInput::borrow(v).resolved(s);
    EXPECT_FALSE(r.stepVoxels);
    EXPECT_DOUBLE_EQ(r.step, 0.025);
}
