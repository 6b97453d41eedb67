// The volcl executable: exit codes (0/1/2), one-line errors on stderr, atomic outputs, demo end to end.
#include "../TestUtil.hpp"
#include "CliRun.hpp"
#include "host/image/ImageIo.hpp"
#include "host/io/NiftiMetadata.hpp"
#include "host/io/VolumeIo.hpp"

#include <sys/wait.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

using namespace volcl;

namespace {} // namespace

TEST(Cli, HelpExitsZero) {
    auto dir = test::tempDir("cli_help");
    test::RunResult r = test::runVolcl("--help", dir);
    EXPECT_EQ(r.exitCode, 0);
    EXPECT_NE(r.out.find("info"), std::string::npos);
    EXPECT_NE(r.out.find("demo"), std::string::npos);
}

TEST(Cli, UsageErrorsExitTwo) {
    auto dir = test::tempDir("cli_usage");
    EXPECT_EQ(test::runVolcl("", dir).exitCode, 2);
    EXPECT_EQ(test::runVolcl("no-such-command", dir).exitCode, 2);
    test::RunResult r = test::runVolcl("info", dir); // missing required file
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_EQ(test::lineCount(r.err), 1u) << r.err;
    EXPECT_EQ(test::runVolcl("info x.raw --type int64", dir).exitCode, 2);
}

TEST(Cli, CropBoxRefusalsExitTwoAndABoxOutsideRendersTheBackground) {
    auto dir = test::tempDir("cli_crop_box");
    Volume v({6, 6, 6}, ScalarType::UInt8);
    std::fill(v.values<std::uint8_t>().begin(), v.values<std::uint8_t>().end(), std::uint8_t(200));
    writeVolumeFile(v, dir / "a.nrrd");
    const std::string render = "render --volume " + (dir / "a.nrrd").string() + " --width 8 --height 8 -o ";
    for (const std::string bad : {"--crop-box 4,0,0:3,5,5", "--crop-box 0,0,0:5,5",
                                  "--crop-box 0,0,0:1,1,1vox "
                                  "--clip 1,0,0,0 --clip 0,1,0,0 "
                                  "--clip 0,0,1,0"}) {
        test::RunResult r = test::runVolcl(render + (dir / "bad.exr").string() + " " + bad, dir);
        EXPECT_EQ(r.exitCode, 2) << bad;
        EXPECT_EQ(test::lineCount(r.err), 1u) << r.err;
        EXPECT_FALSE(std::filesystem::exists(dir / "bad.exr")) << bad;
    }
    for (const std::string mode : {"dvr", "emission"}) {
        const auto out = dir / (mode + ".exr");
        test::RunResult r =
            test::runVolcl(render + out.string() + " --mode " + mode + " --crop-box 20,20,20:30,30,30", dir);
        ASSERT_EQ(r.exitCode, 0) << r.err;
        const ImageBuffer img = readImage(out);
        for (float p : img.pixels)
            EXPECT_EQ(p, 0.0f) << mode;
    }
}

TEST(Cli, MissingFileExitsOneWithOneLine) {
    auto dir = test::tempDir("cli_missing");
    test::RunResult r = test::runVolcl("info " + (dir / "nope.nrrd").string(), dir);
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_EQ(test::lineCount(r.err), 1u) << r.err;
    EXPECT_NE(r.err.find("nope.nrrd"), std::string::npos) << r.err;
}

TEST(Cli, GarbageFileExitsOneWithoutCrash) {
    auto dir = test::tempDir("cli_garbage");
    std::ofstream(dir / "bad.nrrd") << "NRRD0004\nsizes: 99999 99999 99999\ntype: float\nencoding: raw\n\nxx";
    test::RunResult r = test::runVolcl("info " + (dir / "bad.nrrd").string(), dir);
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_EQ(test::lineCount(r.err), 1u) << r.err;
}

TEST(Cli, ConvertRefusesToOverwriteItsInput) {
    auto dir = test::tempDir("cli_same");
    Volume v({4, 4, 4}, ScalarType::UInt8);
    writeVolumeFile(v, dir / "a.nrrd");
    std::string before = test::readFile(dir / "a.nrrd");
    test::RunResult r =
        test::runVolcl("convert " + (dir / "a.nrrd").string() + " -o " + (dir / "a.nrrd").string(), dir);
    EXPECT_NE(r.exitCode, 0);
    EXPECT_EQ(test::readFile(dir / "a.nrrd"), before) << "input must stay untouched";
}

TEST(Cli, FailedConvertLeavesNoOutput) {
    auto dir = test::tempDir("cli_atomic");
    Volume v({4, 4, 4}, ScalarType::UInt8);
    writeVolumeFile(v, dir / "a.nrrd");
    test::RunResult r = test::runVolcl("convert " + (dir / "a.nrrd").string() + " -o " +
                                           (dir / "out.nrrd").string() + " --crop 0,0,0:9,9,9",
                                       dir);
    EXPECT_NE(r.exitCode, 0);
    EXPECT_FALSE(std::filesystem::exists(dir / "out.nrrd"));
    for (const auto& e : std::filesystem::directory_iterator(dir))
        EXPECT_EQ(e.path().filename().string().find("out.nrrd"), std::string::npos)
            << "leftover " << e.path();
}

TEST(Cli, ConvertRoundTripsRawNrrdVdbBitExactly) {
    auto dir = test::tempDir("cli_roundtrip");
    for (ScalarType t : {ScalarType::UInt8, ScalarType::UInt16, ScalarType::Int16}) {
        // Fill with a full-range pattern through float conversion (exact for these integers).
        Volume f({13, 7, 5}, ScalarType::Float32);
        auto fv = f.values<float>();
        for (std::size_t i = 0; i < fv.size(); ++i) {
            long long r = (long long)((i * 2654435761ull) % 65536);
            fv[i] = float(t == ScalarType::UInt8 ? r % 256 : t == ScalarType::Int16 ? r - 32768 : r);
        }
        fv[0] = 0; // zero voxels must survive VDB's background handling
        Volume v = f.convertedTo(t);
        std::string name(scalarTypeName(t));
        auto raw = dir / ("v_13x7x5_" + name + ".raw");
        writeVolumeFile(v, raw);
        ASSERT_EQ(test::runVolcl("convert " + raw.string() + " -o " + (dir / (name + ".nrrd")).string(), dir)
                      .exitCode,
                  0);
        ASSERT_EQ(test::runVolcl("convert " + (dir / (name + ".nrrd")).string() + " -o " +
                                     (dir / (name + ".vdb")).string(),
                                 dir)
                      .exitCode,
                  0);
        test::RunResult back = test::runVolcl("convert " + (dir / (name + ".vdb")).string() + " -o " +
                                                  (dir / ("back_13x7x5_" + name + ".raw")).string(),
                                              dir);
        ASSERT_EQ(back.exitCode, 0) << back.err;
        Volume r = readVolume(dir / ("back_13x7x5_" + name + ".raw"));
        EXPECT_EQ(r.type(), t);
        EXPECT_TRUE(std::equal(r.bytes().begin(), r.bytes().end(), v.bytes().begin(), v.bytes().end()))
            << "raw -> NRRD -> VDB -> raw must be bit-exact for " << name;
    }
}

TEST(Cli, InfoJsonHasContractFields) {
    auto dir = test::tempDir("cli_info");
    Volume v({3, 2, 1}, ScalarType::UInt16);
    v.values<std::uint16_t>()[5] = 1000;
    writeVolumeFile(v, dir / "v.nrrd");
    test::RunResult r = test::runVolcl("info --json " + (dir / "v.nrrd").string(), dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    auto j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["dims"], nlohmann::json({3, 2, 1}));
    EXPECT_EQ(j["type"], "uint16");
    EXPECT_EQ(j["range"], nlohmann::json({0.0, 1000.0}));
}

TEST(Cli, InfoHistogram2dOfARampIsOneRow) {
    // s = 2 z on unit spacing: every voxel's gradient magnitude is 2 (one-sided at the faces too), so the
    // whole histogram sits in the top row (the gradient axis ends at the 99.5th percentile, 2).
    auto dir = test::tempDir("cli_histogram2d");
    const Volume v = test::makeFloatVolume({4, 3, 9}, [](double, double, double z) { return 2.0 * z; });
    writeVolumeFile(v, dir / "ramp.nrrd");
    test::RunResult r = test::runVolcl(
        "info " + (dir / "ramp.nrrd").string() + " --histogram2d " + (dir / "h.png").string(), dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(test::has(r.out, "gradient magnitude 0 .. 2 per world unit")) << r.out;
    const ImageBuffer h = readImage(dir / "h.png");
    ASSERT_EQ(h.width, 256);
    double top = 0.0, rest = 0.0;
    for (int y = 0; y < h.height; ++y)
        for (int x = 0; x < h.width; ++x)
            (y == 0 ? top : rest) += h.at(x, y, 0);
    EXPECT_GT(top, 0.0);
    EXPECT_EQ(rest, 0.0);
    // A mesh or a .vcz is refused with one line, before any output.
    test::writeFile(dir / "x.vcz", "not a vcz");
    r = test::runVolcl("info " + (dir / "x.vcz").string() + " --histogram2d " + (dir / "g.png").string(),
                       dir);
    EXPECT_EQ(r.exitCode, 2) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir / "g.png"));
}

TEST(Cli, GradientTfRefusalsAreOneLine) {
    auto dir = test::tempDir("cli_gradient_tf");
    const Volume v = test::makeFloatVolume({6, 6, 6}, [](double x, double, double) { return x; });
    writeVolumeFile(v, dir / "v.nrrd");
    test::writeFile(dir / "zero.json", R"({"domain": [0, 5], "widgets": [{"type": "box", "value": [2, 2],
        "gradient": [0, 1], "color": [1, 1, 1], "extinction": 1}]})");
    test::writeFile(dir / "ok.json", R"({"domain": [0, 5], "widgets": [{"type": "box", "value": [1, 4],
        "gradient": [0.5, 2], "color": [1, 1, 1], "extinction": 1}]})");
    const std::string base = "render --volume " + (dir / "v.nrrd").string() + " --width 8 --height 8 -o ";
    test::RunResult r =
        test::runVolcl(base + (dir / "a.png").string() + " --tf " + (dir / "zero.json").string(), dir);
    EXPECT_EQ(r.exitCode, 1) << r.err;
    EXPECT_EQ(test::lineCount(r.err), 1u) << r.err;
    EXPECT_TRUE(test::has(r.err, "zero.json")) << r.err;
    r = test::runVolcl(base + (dir / "b.png").string() + " --tf " + (dir / "ok.json").string() +
                           " --preintegration 2d",
                       dir);
    EXPECT_EQ(r.exitCode, 2) << r.err;
    EXPECT_EQ(test::lineCount(r.err), 1u) << r.err;
    r = test::runVolcl(base + (dir / "c.png").string() + " --tf " + (dir / "ok.json").string(), dir);
    EXPECT_EQ(r.exitCode, 0) << r.err;
    for (const char* f : {"a.png", "b.png"})
        EXPECT_FALSE(std::filesystem::exists(dir / f)) << f;
    EXPECT_TRUE(std::filesystem::exists(dir / "c.png"));
}

TEST(Cli, LabelRefusalsAreOneLineAndLabelMapsEncodeLosslessly) {
    auto dir = test::tempDir("cli_labels");
    const Volume v = test::makeFloatVolume({6, 6, 6}, [](double x, double, double) { return x; });
    writeVolumeFile(v, dir / "v.nrrd");
    Volume labels({6, 6, 6}, ScalarType::UInt8);
    labels.values<std::uint8_t>()[100] = 3;
    writeVolumeFile(labels, dir / "seg.nrrd");
    test::writeFile(dir / "bad.txt", "1 liver 255 128 0 999\n");
    test::writeFile(dir / "ok.json", R"({"labels": [{"label": 3, "color": [1, 0, 0]}]})");
    const std::string base = "render --volume " + (dir / "v.nrrd").string() +
                             " --width 8 --height 8 --labels " + (dir / "seg.nrrd").string() + " -o ";
    // A bad table: exit 1, one line naming it, no image.
    test::RunResult r =
        test::runVolcl(base + (dir / "a.png").string() + " --label-table " + (dir / "bad.txt").string(), dir);
    EXPECT_EQ(r.exitCode, 1) << r.err;
    EXPECT_EQ(test::lineCount(r.err), 1u) << r.err;
    EXPECT_TRUE(test::has(r.err, "bad.txt")) << r.err;
    // Labels in a mode they do not draw: a usage error.
    r = test::runVolcl(base + (dir / "b.png").string() + " --mode mip", dir);
    EXPECT_EQ(r.exitCode, 2) << r.err;
    EXPECT_EQ(test::lineCount(r.err), 1u) << r.err;
    // --label-table without labels.
    r = test::runVolcl("render --volume " + (dir / "v.nrrd").string() + " -o " + (dir / "c.png").string() +
                           " --label-table " + (dir / "ok.json").string(),
                       dir);
    EXPECT_EQ(r.exitCode, 2) << r.err;
    // A label map encodes losslessly: an error bound or PSNR is met exactly (with a note), a bit budget is
    // refused in one line.
    r = test::runVolcl("encode " + (dir / "seg.nrrd").string() + " --labels --bpv 0.5 -o " +
                           (dir / "seg_lossy.vcz").string(),
                       dir);
    EXPECT_EQ(r.exitCode, 2) << r.err;
    EXPECT_EQ(test::lineCount(r.err), 1u) << r.err;
    EXPECT_TRUE(test::has(r.err, "seg.nrrd")) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir / "seg_lossy.vcz"));
    r = test::runVolcl("encode " + (dir / "seg.nrrd").string() + " --labels --psnr 40 -o " +
                           (dir / "seg_exact.vcz").string(),
                       dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(test::has(r.err, "coded losslessly")) << r.err;
    ASSERT_EQ(test::runVolcl(
                  "decode " + (dir / "seg_exact.vcz").string() + " -o " + (dir / "back.nrrd").string(), dir)
                  .exitCode,
              0);
    const Volume back = readVolumeFile(dir / "back.nrrd").frames.at(0);
    ASSERT_EQ(back.bytes().size(), labels.bytes().size());
    EXPECT_TRUE(std::equal(labels.bytes().begin(), labels.bytes().end(), back.bytes().begin()));
    r = test::runVolcl("encode " + (dir / "seg.nrrd").string() + " --labels -o " + (dir / "seg.vcz").string(),
                       dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    // A NIfTI marked NIFTI_INTENT_LABEL (1002) is a label map without the flag.
    WriteOptions wo;
    wo.nifti = niftiMetadataForVolume(labels);
    wo.nifti->intentCode = 1002;
    writeVolumeFile(labels, dir / "seg.nii.gz", wo);
    r = test::runVolcl(
        "encode " + (dir / "seg.nii.gz").string() + " --bpv 0.5 -o " + (dir / "seg_lossy.vcz").string(), dir);
    EXPECT_EQ(r.exitCode, 2) << r.err;
    EXPECT_TRUE(test::has(r.err, "NIFTI_INTENT_LABEL")) << r.err;
    // The brick renderer has no label kernel: --labels with a .vcz input is refused in one line.
    r = test::runVolcl("render --volume " + (dir / "seg.vcz").string() + " --width 8 --height 8 --labels " +
                           (dir / "seg.nrrd").string() + " -o " + (dir / "d.png").string(),
                       dir);
    EXPECT_EQ(r.exitCode, 2) << r.err;
    EXPECT_EQ(test::lineCount(r.err), 1u) << r.err;
    EXPECT_TRUE(test::has(r.err, ".vcz")) << r.err;
    r = test::runVolcl(base + (dir / "e.png").string() + " --label-table " + (dir / "ok.json").string() +
                           " --label-mode alone",
                       dir);
    EXPECT_EQ(r.exitCode, 0) << r.err;
    for (const char* f : {"a.png", "b.png", "c.png", "d.png", "seg_lossy.vcz"})
        EXPECT_FALSE(std::filesystem::exists(dir / f)) << f;
    EXPECT_TRUE(std::filesystem::exists(dir / "e.png"));
}

TEST(Cli, DevicesListsPocl) {
    auto dir = test::tempDir("cli_devices");
    test::RunResult r = test::runVolcl("devices", dir);
    EXPECT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("0: "), std::string::npos) << r.out;
}

TEST(Cli, DemoRunsAndWritesPhantoms) {
    auto dir = test::tempDir("cli_demo");
    test::RunResult r = test::runVolcl("demo -o " + (dir / "demo").string() + " --phantom-size 48", dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    Volume ml = readVolume(dir / "demo" / "marschner_lobb.nrrd");
    EXPECT_EQ(ml.dims(), (Dims{41, 41, 41}));
    Volume sl = readVolume(dir / "demo" / "shepp_logan.nrrd");
    EXPECT_EQ(sl.dims(), (Dims{48, 48, 48}));
    EXPECT_NE(r.out.find("range"), std::string::npos);
}

// `-q demo` whose output cannot be written: exit 1 with the error as the only stderr line (the report
// lines came first, so a failure was four lines; found by the long fault campaign).
TEST(Cli, QuietDemoFailsWithOneLine) {
    auto dir = test::tempDir("cli_demo_quiet");
    std::filesystem::create_directories(dir / "demo" / "marschner_lobb.nrrd"); // a directory: no write
    test::RunResult r =
        test::runVolcl("-q demo -o " + (dir / "demo").string() + " --ml-size 6 --phantom-size 12", dir);
    EXPECT_EQ(r.exitCode, 1) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_NE(r.err.find("marschner_lobb.nrrd"), std::string::npos) << r.err;
}

// Mean |4-neighbour Laplacian| of the luminance over the object's interior (pixels brighter than 0.05 with
// all four neighbours so), relative to its mean luminance: pixel-scale ripple such as moire rings.
double relativeRoughness(const ImageBuffer& im) {
    auto lum = [&](int x, int y) { return (im.at(x, y, 0) + im.at(x, y, 1) + im.at(x, y, 2)) / 3.0; };
    double rough = 0, sum = 0;
    for (int y = 1; y + 1 < im.height; ++y)
        for (int x = 1; x + 1 < im.width; ++x) {
            const double c = lum(x, y), n = lum(x, y - 1), s = lum(x, y + 1), w = lum(x - 1, y),
                         e = lum(x + 1, y);
            if (std::min({c, n, s, w, e}) <= 0.05) continue;
            rough += std::abs(4 * c - n - s - w - e);
            sum += c;
        }
    return sum > 0 ? rough / sum : INFINITY;
}

// The demo's first image is a smooth, shaded rendering: no moire on the phantom's surfaces (the old
// unshaded render of the voxelised phantom measured 0.17 here, the band-limited shaded one 0.024), and no
// OpenCL compiler chatter ("1 warning generated.") reaches the user.
TEST(Cli, DemoImageIsSmoothAndKernelWarningsStayQuiet) {
    auto dir = test::tempDir("cli_demo_image");
    // Empty program caches (ours and PoCL's), so every kernel is compiled from source in this run: a
    // cached binary would hide the compiler's output.
    const std::string fresh = "VOLCL_CACHE_DIR=" + (dir / "volcl-cache").string() +
                              " POCL_CACHE_DIR=" + (dir / "pocl-cache").string() + " " + VOLCL_EXE;
    test::RunResult r = test::runProgram(fresh, "demo -o " + (dir / "demo").string(), dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_EQ(r.err.find("warning"), std::string::npos) << r.err;
    EXPECT_EQ(r.out.find("warning"), std::string::npos) << r.out;
    const ImageBuffer im = readImage(dir / "demo" / "phantom.png");
    ASSERT_GE(im.channelCount(), 3);
    const double roughness = relativeRoughness(im);
    EXPECT_LT(roughness, 0.06) << "phantom.png ripples (moire)";
}

#if defined(VOLCL_WITH_BENCH) // the `volcl bench` module is built (VOLCL_BUILD_BENCH)
// `volcl bench codec` reports what a user running the CLI once per file sees (a fresh process per run)
// beside the warm in-process figure; before, it reported the warm figure only. Speeds are not checked.
TEST(Cli, BenchCodecReportsColdAndWarmFigures) {
    std::filesystem::path data;
    VOLCL_REQUIRE_SHARED_DATA(data);
    auto dir = test::tempDir("cli_bench_cold");
    const auto csv = dir / "codec.csv";
    test::RunResult r = test::runVolcl(
        "bench codec --data " + data.string() +
            " --dataset hydrogenatom --mode lossless --coder fast --no-xz --runs 1 --csv " + csv.string(),
        dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.err.find("cold (a fresh volcl process per run"), std::string::npos) << r.err;
    std::ifstream in(csv);
    std::string header, row;
    std::getline(in, header);
    ASSERT_NE(header.find("encode_cold_MBps,decode_cold_MBps"), std::string::npos) << header;
    bool sawOurs = false;
    while (std::getline(in, row)) {
        if (row.find("volcl-fast") == std::string::npos) continue;
        sawOurs = true;
        // The last two columns are the cold figures: measured, so positive.
        const std::size_t last = row.rfind(','), before = row.rfind(',', last - 1);
        EXPECT_GT(std::stod(row.substr(last + 1)), 0.0) << row;
        EXPECT_GT(std::stod(row.substr(before + 1, last - before - 1)), 0.0) << row;
    }
    EXPECT_TRUE(sawOurs);
}
#endif

// OpenImageIO is a module loaded on first image access; without it, image commands fail with one line.
TEST(Cli, MissingImageModuleIsAOneLineError) {
    auto dir = test::tempDir("cli_no_oiio");
    const std::filesystem::path exe(VOLCL_EXE), bin = dir / "bin";
    std::filesystem::create_directories(bin);
    std::filesystem::copy_file(exe, bin / "volcl");
    // The copy goes under the SONAME the executable asks for (libvolcl.so links to libvolcl.so.MAJOR.MINOR).
    const std::filesystem::path lib = exe.parent_path() / "libvolcl.so";
    const std::filesystem::path soname =
        std::filesystem::is_symlink(lib) ? std::filesystem::read_symlink(lib).filename() : lib.filename();
    std::filesystem::copy_file(lib, bin / soname);
    // LD_LIBRARY_PATH wins over the copy's RUNPATH, so the library (and its module lookup) is the copy's.
    const std::string copy = "LD_LIBRARY_PATH=" + bin.string() + " " + (bin / "volcl").string();
    EXPECT_EQ(test::runProgram(copy, "--help", dir).exitCode, 0);
    test::RunResult r =
        test::runProgram(copy, "demo -o " + (dir / "demo").string() + " --phantom-size 16", dir);
    EXPECT_EQ(r.exitCode, 1) << r.err;
    // demo reports progress on stderr before it writes its first image; the error is one line after it.
    const std::size_t last = r.err.rfind('\n', r.err.size() - 2);
    const std::string error = r.err.substr(last == std::string::npos ? 0 : last + 1);
    EXPECT_EQ(error.rfind("volcl: ", 0), 0u) << r.err;
    EXPECT_EQ(test::lineCount(error), 1u) << r.err;
    EXPECT_NE(error.find("libvolcl_oiio.so"), std::string::npos) << r.err;
}

TEST(Cli, InfoRefusesPointsVdbAndCorruptedCopiesWithOneLine) {
    std::filesystem::path data;
    VOLCL_REQUIRE_SHARED_DATA(data);
    auto dir = test::tempDir("cli_corrupt");
    test::RunResult points = test::runVolcl("info " + (data / "vdb" / "sphere_points.vdb").string(), dir);
    EXPECT_EQ(points.exitCode, 1);
    EXPECT_EQ(test::lineCount(points.err), 1u) << points.err;
    EXPECT_NE(points.err.find("sphere_points.vdb"), std::string::npos) << points.err;

    // Truncated copies of real files in several formats. Detached headers keep their header and get
    // half of their payload file; single files lose their last third.
    struct Case {
        const char* file;
        const char* payload; // detached payload beside the header, or nullptr
    };
    for (Case c :
         {Case{"regular/nucleon.nrrd", "nucleon.raw"}, Case{"regular/HeadMRVolume.mhd", "HeadMRVolume.raw"},
          Case{"regular/neghip.slc", nullptr}, Case{"regular/ironProt.vtk", nullptr},
          Case{"vdb/grid0.vdb", nullptr}, Case{"timevarying/functional.nii.gz", nullptr},
          Case{"timevarying/viscousfingers/001_density_001_064_2.0.vti", nullptr}}) {
        std::filesystem::path src = data / c.file;
        std::string bytes = test::readFile(src);
        if (c.payload) {
            std::string payload = test::readFile(src.parent_path() / c.payload);
            std::ofstream(dir / c.payload, std::ios::binary) << payload.substr(0, payload.size() / 2);
        } else {
            bytes = bytes.substr(0, bytes.size() * 2 / 3);
        }
        std::ofstream(dir / src.filename(), std::ios::binary) << bytes;
        test::RunResult r = test::runVolcl("info " + (dir / src.filename()).string(), dir);
        EXPECT_EQ(r.exitCode, 1) << c.file << ": " << r.err;
        EXPECT_EQ(test::lineCount(r.err), 1u) << c.file << ": " << r.err;
    }
}
