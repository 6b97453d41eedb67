// Hostile inputs through the volcl binary: each ends in exit 1 (2 for usage) with one line naming the file,
// within a memory bound, and leaves every input untouched (the reproducers of the hardening work).
#include "../TestUtil.hpp"
#include "CliRun.hpp"
#include "host/io/IoDetail.hpp"
#include "host/io/VolumeIo.hpp"
#include "wavelet/container/VczFormat.hpp"

#include <spawn.h>
#include <sys/mount.h>
#include <sys/stat.h>
#include <sys/wait.h>

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <limits>
#include <numeric>
#include <random>
#include <set>
#include <sstream>

extern char** environ;

using namespace volcl;
namespace fs = std::filesystem;

namespace {

struct RunResult {
    int exitCode = -1;
    std::string err;
    long maxRssKb = 0;
};

// Runs `volcl <args>` in `dir` through /bin/sh with a 60 s guard, so a regression to a hang fails instead of
// blocking the suite. The peak memory is volcl's own, taken by peak_rss: a process this executable spawns
// inherits this executable's peak (under ASan several hundred MB) as its own.
RunResult run(const std::string& args, const fs::path& dir, const std::string& prefix = "",
              int seconds = 60) {
    const fs::path err = dir / "stderr.txt", rss = dir / "peak_rss.txt";
    fs::remove(rss);
    const std::string cmd = "cd '" + dir.string() + "' && " + prefix + " exec " PEAK_RSS_EXE " '" +
                            rss.string() + "' timeout -s KILL " + std::to_string(seconds) +
                            " " VOLCL_EXE " " + args + " >/dev/null 2>'" + err.string() + "' </dev/null";
    const char* argv[] = {"/bin/sh", "-c", cmd.c_str(), nullptr};
    pid_t pid = 0;
    RunResult r;
    if (posix_spawn(&pid, "/bin/sh", nullptr, nullptr, const_cast<char**>(argv), environ) != 0) return r;
    int status = 0;
    if (waitpid(pid, &status, 0) != pid) return r;
    r.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    r.err = test::readFile(err);
    // No figure (peak_rss itself failed) reads as unbounded, so a memory check fails rather than passes.
    r.maxRssKb = fs::exists(rss) ? std::stol("0" + test::readFile(rss)) : std::numeric_limits<long>::max();
    fs::remove(rss); // the tests list `dir`: it holds their files and stderr.txt only
    return r;
}

// A refused input: exit code as asked, one line on stderr that names `file`, less than 500 MB.
void expectRefused(const RunResult& r, int code, const std::string& file, const std::string& why = "") {
    EXPECT_EQ(r.exitCode, code) << r.err;
    EXPECT_EQ(test::lineCount(r.err), 1u) << r.err;
    EXPECT_NE(r.err.find(file), std::string::npos) << "message does not name " << file << ": " << r.err;
    if (!why.empty()) EXPECT_NE(r.err.find(why), std::string::npos) << r.err;
    EXPECT_LT(r.maxRssKb, 500 * 1024) << "peak memory " << r.maxRssKb << " kB";
}

Volume ramp(Dims d) {
    Volume v(d, ScalarType::UInt8);
    auto vals = v.values<std::uint8_t>();
    for (std::size_t i = 0; i < vals.size(); ++i)
        vals[i] = static_cast<std::uint8_t>(i * 7);
    return v;
}

constexpr const char* kTf = R"({"domain": [0, 255],
  "color": [[0, 0.0, 0.0, 0.0], [128, 1.0, 0.6, 0.2], [255, 1.0, 1.0, 1.0]],
  "extinction": [[0, 0.0], [60, 0.0], [80, 0.8], [255, 0.05]]})";

} // namespace

// ---- inputs are never destroyed -------------------------------------------------------------------------

TEST(CliHostile, ConvertRefusesToOverwriteTheDataFileOfItsHeader) {
    const fs::path dir = test::tempDir("hostile_same_data");
    writeVolumeFile(ramp({12, 12, 12}), dir / "a.raw");
    // The shape of nucleon.nrrd: an attached-looking .nrrd whose data sits in ./a.raw.
    test::writeFile(dir / "a.nrrd",
                    "NRRD0001\ntype: uchar\ndimension: 3\nsizes: 12 12 12\ndatafile: ./a.raw\n"
                    "encoding: raw\n\n");
    const std::string before = test::readFile(dir / "a.raw");
    expectRefused(run("convert a.nrrd -o a.raw --crop 0,0,0:10,10,10", dir), 2, "a.raw", "same file");
    EXPECT_EQ(test::readFile(dir / "a.raw"), before);
    // A detached .nhdr output writes its data under a new unique name, never over the input's data file.
    test::writeFile(dir / "b.nrrd", "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 12 12 12\ndata file: a.raw\n"
                                    "encoding: raw\n\n");
    ASSERT_EQ(run("-q convert b.nrrd -o a.nhdr", dir).exitCode, 0) << test::readFile(dir / "stderr.txt");
    EXPECT_EQ(test::readFile(dir / "a.raw"), before);
    EXPECT_EQ(readVolume(dir / "a.nhdr"), readVolume(dir / "b.nrrd"));
    // Writing a.nhdr again would remove the data file its present header names: refused while that file
    // is an input (here through c.nhdr, a copy of the header).
    fs::copy_file(dir / "a.nhdr", dir / "c.nhdr");
    const RunResult again = run("convert c.nhdr -o a.nhdr", dir);
    EXPECT_EQ(again.exitCode, 2) << again.err;
    EXPECT_NE(again.err.find("same file"), std::string::npos) << again.err;
    EXPECT_EQ(readVolume(dir / "c.nhdr"), readVolume(dir / "b.nrrd"));
}

TEST(CliHostile, ConvertRefusesToOverwriteASliceOfAListOrASidecarsRawFile) {
    const fs::path dir = test::tempDir("hostile_same_list");
    Volume slice = ramp({8, 8, 1});
    writeVolumeFile(slice, dir / "s0.raw");
    writeVolumeFile(slice, dir / "s1.raw");
    test::writeFile(dir / "list.nhdr", "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 8 8 2\nencoding: raw\n"
                                       "data file: LIST\ns0.raw\ns1.raw\n");
    const std::string before = test::readFile(dir / "s1.raw");
    expectRefused(run("convert list.nhdr -o s1.raw", dir), 2, "s1.raw", "same file");
    EXPECT_EQ(test::readFile(dir / "s1.raw"), before);
    test::writeFile(dir / "v.dat", "ObjectFileName: s0.raw\nResolution: 8 8 1\nFormat: UCHAR\n");
    expectRefused(run("convert v.dat -o s0.raw", dir), 2, "s0.raw", "same file");
    EXPECT_EQ(test::readFile(dir / "s0.raw"), before);
}

// ---- data files stay beside their header unless allowed -----------------------------------------------

TEST(CliHostile, HeaderDataFilesOutsideTheHeadersDirectoryAreRefusedUnlessAllowed) {
    const fs::path root = test::tempDir("hostile_confine");
    const fs::path dir = root / "inner";
    fs::create_directories(dir);
    writeVolumeFile(ramp({4, 4, 4}), root / "outside.raw");
    test::writeFile(dir / "passwd.nhdr", "NRRD0004\ntype: uchar\ndimension: 1\nsizes: 16\nencoding: raw\n"
                                         "data file: /etc/passwd\nbyte skip: -1\n");
    expectRefused(run("convert passwd.nhdr -o out.raw", dir), 1, "passwd.nhdr", "outside");
    EXPECT_FALSE(fs::exists(dir / "out.raw"));
    test::writeFile(dir / "up.nhdr", "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 4 4 4\nencoding: raw\n"
                                     "data file: ../outside.raw\n");
    expectRefused(run("info up.nhdr", dir), 1, "up.nhdr", "--allow-external-data");
    test::writeFile(dir / "up.mhd", "NDims = 3\nDimSize = 4 4 4\nElementType = MET_UCHAR\n"
                                    "ElementDataFile = ../outside.raw\n");
    expectRefused(run("info up.mhd", dir), 1, "up.mhd", "outside");
    // A symbolic link inside the directory that leads out of it is outside too.
    fs::create_symlink(root / "outside.raw", dir / "link.raw");
    test::writeFile(dir / "link.nhdr", "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 4 4 4\nencoding: raw\n"
                                       "data file: link.raw\n");
    expectRefused(run("info link.nhdr", dir), 1, "link.nhdr", "outside");
    // Allowed on request, and a subdirectory is always inside.
    EXPECT_EQ(run("info up.nhdr --allow-external-data", dir).exitCode, 0);
    EXPECT_EQ(run("convert up.mhd -o copy.raw --allow-external-data", dir).exitCode, 0);
    fs::create_directories(dir / "sub");
    writeVolumeFile(ramp({4, 4, 4}), dir / "sub" / "d.raw");
    test::writeFile(dir / "sub.nhdr", "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 4 4 4\nencoding: raw\n"
                                      "data file: sub/d.raw\n");
    EXPECT_EQ(run("info sub.nhdr", dir).exitCode, 0);
    // A .pvd's DataSet files follow the same rule.
    writeVolumeFile(ramp({4, 4, 4}), root / "outside.vti");
    for (const std::string& f : {std::string("../outside.vti"), (root / "outside.vti").string()}) {
        test::writeFile(dir / "p.pvd",
                        "<VTKFile type=\"Collection\"><Collection><DataSet timestep=\"0\" file=\"" + f +
                            "\"/></Collection></VTKFile>\n");
        expectRefused(run("encode p.pvd -o p.vcz", dir), 1, "p.pvd", "--allow-external-data");
        EXPECT_FALSE(fs::exists(dir / "p.vcz"));
        EXPECT_EQ(run("encode p.pvd -o p.vcz --allow-external-data", dir).exitCode, 0) << f;
        fs::remove(dir / "p.vcz");
    }
}

// ---- non-regular files are refused before any read ------------------------------------------------------

// A FIFO blocked the first read forever, /dev/zero never ends, a directory is no volume: each is refused
// (as the input, or as a data file a header names) with one line naming the file. A 10 s guard turns a
// regression to a hang into a failure.
TEST(CliHostile, NonRegularFilesAreRefusedAsInputsAndAsDataFiles) {
    const fs::path dir = test::tempDir("hostile_nonregular");
    for (const char* f : {"fifo.nrrd", "fifo.vcz", "fifo.raw", "fifo.vti", "fifo.json"})
        ASSERT_EQ(::mkfifo((dir / f).c_str(), 0600), 0) << f;
    fs::create_directories(dir / "dir.nrrd");
    fs::create_directories(dir / "dir.raw");
    auto refused = [&](const std::string& args, const std::string& file) {
        SCOPED_TRACE(args);
        expectRefused(run(args, dir, "", 10), 1, file);
    };
    refused("info fifo.nrrd", "fifo.nrrd");
    refused("info fifo.vcz", "fifo.vcz");
    refused("decode fifo.vcz -o d.raw", "fifo.vcz");
    refused("info dir.nrrd", "dir.nrrd");
    refused("info /dev/zero", "/dev/zero");
    refused("info fifo.vtu", "fifo.vtu");                      // a mesh
    refused("render --scene fifo.json -o s.png", "fifo.json"); // a scene
    for (const char* data : {"fifo.raw", "dir.raw", "/dev/zero"}) {
        const std::string d(data);
        test::writeFile(dir / "h.nhdr", "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 4 4 4\nencoding: raw\n"
                                        "data file: " +
                                            d + "\n");
        refused("info h.nhdr --allow-external-data", "h.nhdr");
        test::writeFile(dir / "h.mhd",
                        "NDims = 3\nDimSize = 4 4 4\nElementType = MET_UCHAR\nElementDataFile = " + d + "\n");
        refused("info h.mhd --allow-external-data", "h.mhd");
        test::writeFile(dir / "h.vvd", "<?xml version=\"1.0\" ?>\n<VoreenData version=\"1\"><Volumes><Volume>"
                                       "<RawData filename=\"" +
                                           d +
                                           "\" format=\"uint8\" x=\"4\" y=\"4\" z=\"4\" />"
                                           "</Volume></Volumes></VoreenData>\n");
        refused("info h.vvd --allow-external-data", "h.vvd");
    }
    writeVolumeFile(ramp({4, 4, 4}), dir / "good.vti");
    for (const char* member : {"fifo.vti", "dir.nrrd", "/dev/zero"}) {
        test::writeFile(dir / "p.pvd", std::string("<VTKFile type=\"Collection\"><Collection>"
                                                   "<DataSet timestep=\"0\" file=\"good.vti\"/>"
                                                   "<DataSet timestep=\"1\" file=\"") +
                                           member + "\"/></Collection></VTKFile>\n");
        refused("encode p.pvd -o p.vcz --allow-external-data", "p.pvd");
        EXPECT_FALSE(fs::exists(dir / "p.vcz"));
    }
}

// An output that exists and is not a regular file (a FIFO, a directory, a device) is refused before any
// work: the commit's rename replaced a FIFO by a regular file.
TEST(CliHostile, OutputsThatAreNotRegularFilesAreRefused) {
    const fs::path dir = test::tempDir("hostile_nonregular_out");
    writeVolumeFile(ramp({4, 4, 4}), dir / "in.nrrd");
    ASSERT_EQ(::mkfifo((dir / "out.raw").c_str(), 0600), 0);
    ASSERT_EQ(::mkfifo((dir / "out.vcz").c_str(), 0600), 0);
    fs::create_directories(dir / "out.nii");
    for (const char* out : {"out.raw", "out.nii"}) {
        SCOPED_TRACE(out);
        expectRefused(run(std::string("convert in.nrrd -o ") + out, dir, "", 10), 1, out);
    }
    expectRefused(run("encode in.nrrd -o out.vcz", dir, "", 10), 1, "out.vcz");
    EXPECT_TRUE(fs::is_fifo(dir / "out.raw"));
    EXPECT_TRUE(fs::is_fifo(dir / "out.vcz"));
}

// ---- size claims are checked before allocation ---------------------------------------------------------

TEST(CliHostile, HugeSizeClaimsAreRefusedBeforeAllocation) {
    const fs::path dir = test::tempDir("hostile_sizes");
    // Ten million data files for a 256x256x93 volume: refused before a single name is built.
    test::writeFile(dir / "quarter.nhdr",
                    "NRRD0004\ntype: short\ndimension: 3\nsizes: 256 256 93\nendian: big\n"
                    "encoding: raw\ndata file: quarter.%d 1 10000000 1\n");
    expectRefused(run("info quarter.nhdr", dir), 1, "quarter.nhdr", "files");
    // 999,999 data files, under the cap of 10^6, that cannot share the 89 MB evenly: refused before a name
    // is built. fuzz_read_mha found 600,000 such files to cost 4 s and 400 MB of names and path checks.
    test::writeFile(dir / "many.mhd", "NDims = 4\nDimSize = 4 4 1000 2775\nElementType = MET_SHORT\n"
                                      "ElementDataFile = d%d.raw 1 999999 1\n");
    expectRefused(run("info many.mhd", dir), 1, "many.mhd", "999999 data files cannot evenly hold");
    writeVolumeFile(ramp({10, 10, 10}), dir / "d.raw");
    test::writeFile(dir / "huge.mhd", "NDims = 3\nDimSize = 100000 1000 1000\nElementType = MET_UCHAR\n"
                                      "ElementDataFile = d.raw\n");
    expectRefused(run("info huge.mhd", dir), 1, "huge.mhd");
    test::writeFile(dir / "huge.nrrd", "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 48 4294967296 42\n"
                                       "encoding: gzip\n\n" +
                                           std::string(64, 'x'));
    expectRefused(run("info huge.nrrd", dir), 1, "huge.nrrd");
    test::writeFile(dir / "huge_raw.nrrd", "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 48 4294967296 42\n"
                                           "encoding: raw\n\n" +
                                               std::string(64, 'x'));
    expectRefused(run("info huge_raw.nrrd", dir), 1, "huge_raw.nrrd");
    test::writeFile(dir / "huge.vtk", "# vtk DataFile Version 3.0\nx\nBINARY\nDATASET STRUCTURED_POINTS\n"
                                      "DIMENSIONS 100000 100000 100000\nPOINT_DATA 1000000000000000\n"
                                      "SCALARS s float\nLOOKUP_TABLE default\n");
    expectRefused(run("info huge.vtk", dir), 1, "huge.vtk");
}

TEST(CliHostile, ForgedVczDimensionsWithValidChecksumsAreRefused) {
    const fs::path dir = test::tempDir("hostile_vcz_dims");
    VczHeader h;
    h.dims = {1u << 20, 1u << 20, 1u << 20};
    h.brick = {1u << 20, 1u << 20, 1u << 20};
    h.type = ScalarType::UInt8;
    h.levels = 0;
    h.frames.resize(1);
    const std::vector<std::vector<std::uint8_t>> payloads{std::vector<std::uint8_t>(16, 0)};
    h.bricks.assign(1, std::vector<VczBrickEntry>(1));
    h.bricks[0][0].offset = vczPreambleSize(h);
    h.bricks[0][0].size = payloads[0].size();
    h.bricks[0][0].checksum = vczChecksum(payloads[0]);
    const std::vector<std::byte> file = writeVcz(h, payloads);
    std::ofstream(dir / "forged.vcz", std::ios::binary)
        .write(reinterpret_cast<const char*>(file.data()), static_cast<std::streamsize>(file.size()));
    expectRefused(run("decode forged.vcz -o out.raw", dir), 1, "forged.vcz", "memory budget");
    expectRefused(run("info forged.vcz", dir), 1, "forged.vcz");
    EXPECT_FALSE(fs::exists(dir / "out.raw"));
}

// ---- .vcz consistency -------------------------------------------------------------------------------

TEST(CliHostile, VczTrailingBytesAndImpossibleCombinationsAreCorruptFiles) {
    const fs::path dir = test::tempDir("hostile_vcz");
    writeVolumeFile(ramp({16, 16, 16}), dir / "v_16x16x16_uint8.raw");
    ASSERT_EQ(run("encode v_16x16x16_uint8.raw -o v.vcz", dir).exitCode, 0);
    std::string bytes = test::readFile(dir / "v.vcz");
    test::writeFile(dir / "appended.vcz", bytes + "extra bytes");
    expectRefused(run("decode appended.vcz -o out.raw", dir), 1, "appended.vcz", "trailing");
    // A lossless file re-labelled cdf97 (no integer form), with every checksum recomputed.
    const auto* raw = reinterpret_cast<const std::byte*>(bytes.data());
    VczHeader h = readVczHeader(std::span<const std::byte>(raw, bytes.size()), "v.vcz");
    ASSERT_EQ(h.transform, TransformKind::IntegerLifting);
    std::vector<std::vector<std::uint8_t>> payloads;
    for (const VczBrickEntry& e : h.bricks[0]) {
        const auto* p = reinterpret_cast<const std::uint8_t*>(bytes.data()) + e.offset;
        payloads.emplace_back(p, p + e.size);
    }
    h.wavelet = Wavelet::Cdf97;
    const std::vector<std::byte> forged = writeVcz(h, payloads);
    std::ofstream(dir / "cdf97int.vcz", std::ios::binary)
        .write(reinterpret_cast<const char*>(forged.data()), static_cast<std::streamsize>(forged.size()));
    expectRefused(run("decode cdf97int.vcz -o out.raw", dir), 1, "cdf97int.vcz", "integer");
    EXPECT_FALSE(fs::exists(dir / "out.raw"));
}

// Found by fuzz_vcz (a stop at 593 MB, then a 2 s timeout): 805-byte files whose wavelet, brick size and
// voxel type asked for a kernel variant no earlier input had built. Its first build ran PoCL's compiler
// inside the sanitizer-instrumented fuzzer. Here they run through the release CLI with PoCL's kernel cache
// off, so every kernel the decode needs is built anew: each file decodes, within the memory bound.
// (In the sanitizer build the sanitizer's quarantine of freed memory is turned off for this run: it would
// hold on to 256 MB of the compiler's freed memory, which is the sanitizer's, not volcl's.)
TEST(CliHostile, BuildingEveryKernelOfADecodeStaysWithinTheMemoryBound) {
    const fs::path dir = test::tempDir("hostile_first_build");
    // 12 x 10 x 8 voxels, haar, lossy, 8^3 bricks: uint16 and uint8.
    for (const auto& [finding, voxelBytes] :
         {std::pair<std::string, std::uintmax_t>{"oom-first-build-of-a-kernel-variant-under-asan.vcz", 2},
          std::pair<std::string, std::uintmax_t>{"timeout-first-build-of-a-kernel-variant-under-asan.vcz",
                                                 1}}) {
        fs::copy_file(fs::path(VOLCL_SOURCE_DIR) / "fuzz/regressions/fuzz_vcz" / finding, dir / finding,
                      fs::copy_options::overwrite_existing);
        fs::remove(dir / "out.raw");
        const RunResult r =
            run("-q decode " + finding + " -o out.raw", dir,
                "POCL_KERNEL_CACHE=0 ASAN_OPTIONS=\"${ASAN_OPTIONS:-}:quarantine_size_mb=0\"");
        EXPECT_EQ(r.exitCode, 0) << finding << ": " << r.err;
        // No message (LeakSanitizer's statistics of the suppressions used may follow in the sanitizer build).
        EXPECT_EQ(r.err.find("volcl:"), std::string::npos) << r.err;
        EXPECT_LT(r.maxRssKb, 500 * 1024) << finding << ": peak memory " << r.maxRssKb << " kB";
        ASSERT_TRUE(fs::exists(dir / "out.raw")) << finding;
        EXPECT_EQ(fs::file_size(dir / "out.raw"), 12u * 10u * 8u * voxelBytes) << finding;
    }
}

// ---- hangs: cost bounded by the output before any work -------------------------------------------------

TEST(CliHostile, PreintegrationWithHugeLengthsFinishes) {
    const fs::path dir = test::tempDir("hostile_preint");
    test::writeFile(dir / "tf.json", kTf);
    for (const char* len : {"1e12", "1e20", "1e30"}) {
        const RunResult r = run(
            std::string("preint --tf tf.json --size 8 --lengths 2 --max-length ") + len + " -o t.exr", dir);
        EXPECT_EQ(r.exitCode, 0) << len << ": " << r.err;
        // The table's entries against the double reference: a saturated segment is opaque, its colour
        // that of its first absorbing point.
        const RunResult c = run("preint --check t.exr --samples 0 --tolerance 1e-4", dir);
        EXPECT_EQ(c.exitCode, 0) << len << ": " << c.err;
    }
    // Lengths beyond 1e30 cannot be stored in the table's float attributes: a usage error at once.
    expectRefused(run("preint --tf tf.json --size 8 --lengths 2 --max-length 1e300 -o t.exr", dir), 2,
                  "--max-length");
    const RunResult r2 = run("preint --tf tf.json --size 256 --step 1e30 -o t2.exr", dir);
    EXPECT_EQ(r2.exitCode, 0) << r2.err;
    const RunResult c2 = run("preint --check t2.exr --samples 2000 --tolerance 1e-4", dir);
    EXPECT_EQ(c2.exitCode, 0) << c2.err;
}

TEST(CliHostile, SceneStepsAreValidatedLikeRenderStep) {
    const fs::path dir = test::tempDir("hostile_steps");
    writeVolumeFile(ramp({16, 16, 16}), dir / "v_16x16x16_uint8.raw");
    test::writeFile(dir / "tf.json", kTf);
    auto scene = [&](const std::string& name, const std::string& render, const std::string& effects) {
        test::writeFile(dir / name, R"({"volume": "v_16x16x16_uint8.raw", "tf": "tf.json",
            "image": {"width": 16, "height": 16}, "render": )" +
                                        render + R"(, "effects": )" + effects + "}");
    };
    scene("huge_step.json", R"({"mode": "dvr", "step": 1e308, "preintegration": "2d"})", "{}");
    expectRefused(run("render --scene huge_step.json -o out.png", dir), 2, "render.step");
    scene("tiny_shadow.json", R"({"mode": "dvr", "step": 0.5})",
          R"({"shading": true, "shadows": true, "shadow_step": 1e-9})");
    expectRefused(run("render --scene tiny_shadow.json -o out.png", dir), 2, "effects.shadow_step");
    scene("nan_shadow.json", R"({"mode": "dvr", "step": 0.5})", R"({"shadows": true, "shadow_step": 1e300})");
    expectRefused(run("render --scene nan_shadow.json -o out.png", dir), 2, "effects.shadow_step");
    EXPECT_FALSE(fs::exists(dir / "out.png"));
}

// ---- messages: one line, the file named, control characters escaped ------------------------------------

TEST(CliHostile, TransferFunctionErrorsAreOneLineNamingTheFile) {
    const fs::path dir = test::tempDir("hostile_tf");
    test::writeFile(dir / "big.json",
                    R"({"domain": [0, 1], "color": [[0, 1, 1, 1]], "extinction": [[0, 1e400]]})");
    expectRefused(run("preint --tf big.json --size 8 --step 1 -o t.exr", dir), 1, "big.json");
    test::writeFile(dir / "garbage.png", "\x89PNG\r\n\x1a\n this is not a PNG at all, just bytes");
    expectRefused(run("preint --tf garbage.png --size 8 --step 1 -o t.exr", dir), 1, "garbage.png");
    // Small EXR strips whose decoding claims more than a strip may take (the fuzzer's: a 693-byte file took
    // 1 GB, a 311-byte one a 15 s table): refused by the header check, before OpenEXR decodes anything.
    for (const char* finding :
         {"oom-wide-zip-strip-line-buffers.exr", "timeout-zip-strip-without-compression-attribute.exr"}) {
        fs::copy_file(fs::path(VOLCL_SOURCE_DIR) / "fuzz/regressions/fuzz_tf_exr" / finding, dir / finding,
                      fs::copy_options::overwrite_existing);
        expectRefused(run(std::string("preint --tf ") + finding + " --size 256 --step 1 -o t.exr", dir), 1,
                      finding, "lines per chunk");
    }
    EXPECT_FALSE(fs::exists(dir / "t.exr"));
}

TEST(CliHostile, ControlCharactersFromHeadersAreEscaped) {
    const fs::path dir = test::tempDir("hostile_ctrl");
    test::writeFile(dir / "cr.nrrd", "NRRD0004\ntype: evil\rname\x1b[2J\ndimension: 3\nsizes: 2 2 2\n"
                                     "encoding: raw\n\n12345678");
    const RunResult r = run("info cr.nrrd", dir);
    expectRefused(r, 1, "cr.nrrd");
    EXPECT_EQ(r.err.find('\r'), std::string::npos) << "raw CR reached the terminal";
    EXPECT_EQ(r.err.find('\x1b'), std::string::npos) << "raw ESC reached the terminal";
    EXPECT_NE(r.err.find("\\r"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("\\x1b"), std::string::npos) << r.err;
}

// what() is a C string: a NUL in a header value used to end the message there.
TEST(CliHostile, NulBytesInHeaderValuesAreEscapedNotCut) {
    const fs::path dir = test::tempDir("hostile_nul");
    using namespace std::string_literals; // "..."s keeps the NUL bytes
    test::writeFile(dir / "nul.nrrd",
                    "NRRD0004\ntype: evil\0name\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n\n12345678"s);
    test::writeFile(dir / "nul.vtk",
                    "# vtk DataFile Version 3.0\nx\nBINARY\nDATASET STRUCTURED_POINTS\n"
                    "DIMENSIONS 2 2 2\nPOINT_DATA 8\nSCALARS s fl\0oat\nLOOKUP_TABLE default\n"s);
    test::writeFile(dir / "nul.mhd",
                    "NDims = 3\nDimSize = 2 2 2\nElementType = MET_U\0CHAR\nElementDataFile = d.raw\n"s);
    for (const auto& [file, tail] : {std::pair<std::string, std::string>{"nul.nrrd", "\\x00name"},
                                     {"nul.vtk", "\\x00oat"},
                                     {"nul.mhd", "\\x00CHAR"}}) {
        ASSERT_NE(test::readFile(dir / file).find('\0'), std::string::npos) << file;
        const RunResult r = run("info " + file, dir);
        expectRefused(r, 1, file, tail);
        EXPECT_EQ(r.err.find('\0'), std::string::npos) << file;
    }
}

// The count of first..last was computed as span / step + 1, which wraps to 0 over the whole range: a
// division by zero (SIGFPE) followed.
TEST(CliHostile, DataFilePatternsOverTheWholeIntegerRangeAreRefused) {
    const fs::path dir = test::tempDir("hostile_pattern");
    const std::string head =
        "NRRD0001\ntype: uchar\ndimension: 3\nsizes: 41 41 41\nencoding: raw\ndata file: ";
    test::writeFile(dir / "all.nhdr", head + "nucleon.%d -9223372036854775808 9223372036854775807 1\n\n");
    test::writeFile(dir / "down.nhdr", head + "nucleon.%d 9223372036854775807 -9223372036854775808 -1\n\n");
    test::writeFile(dir / "wide.nhdr", head + "nucleon.%d -9223372036854775808 9223372036854775807 "
                                              "9223372036854775807\n\n");
    test::writeFile(dir / "zero.nhdr", head + "nucleon.%d 1 5 0\n\n");
    for (const char* f : {"all.nhdr", "down.nhdr"}) {
        expectRefused(run(std::string("info ") + f, dir), 1, f, "2^64 files");
        expectRefused(run(std::string("convert ") + f + " -o out.nii", dir), 1, f, "2^64 files");
    }
    // Three names (min, -1, max): computed without overflow, then refused as 3 files for 41^3 bytes.
    expectRefused(run("info wide.nhdr", dir), 1, "wide.nhdr", "3 data files cannot evenly hold");
    expectRefused(run("info zero.nhdr", dir), 1, "zero.nhdr", "endless");
    EXPECT_FALSE(fs::exists(dir / "out.nii"));
}

// --levels 0 wrote files no decoder reads (lossless) or failed with an internal error (lossy).
TEST(CliHostile, LevelsZeroIsRefusedAtEncodeAndInOldFiles) {
    const fs::path dir = test::tempDir("hostile_levels0");
    writeVolumeFile(ramp({16, 16, 16}), dir / "v_16x16x16_uint8.raw");
    for (const char* mode : {"--lossless", "--psnr 40", "--max-error 2"}) {
        const RunResult r = run(std::string("encode v_16x16x16_uint8.raw -o l0.vcz --levels 0 ") + mode, dir);
        expectRefused(r, 2, "--levels", "between 1 and 8");
        EXPECT_FALSE(fs::exists(dir / "l0.vcz")) << mode;
    }
    // A file such an encoder wrote: a one-level lossless file relabelled 0 levels, checksums recomputed.
    ASSERT_EQ(run("encode v_16x16x16_uint8.raw -o l1.vcz --lossless --levels 1", dir).exitCode, 0);
    const std::string bytes = test::readFile(dir / "l1.vcz");
    const auto* raw = reinterpret_cast<const std::byte*>(bytes.data());
    VczHeader h = readVczHeader(std::span<const std::byte>(raw, bytes.size()), "l1.vcz");
    std::vector<std::vector<std::uint8_t>> payloads;
    for (const VczBrickEntry& e : h.bricks[0]) {
        const auto* p = reinterpret_cast<const std::uint8_t*>(bytes.data()) + e.offset;
        payloads.emplace_back(p, p + e.size);
    }
    h.levels = 0;
    const std::vector<std::byte> forged = writeVcz(h, payloads);
    std::ofstream(dir / "l0.vcz", std::ios::binary)
        .write(reinterpret_cast<const char*>(forged.data()), static_cast<std::streamsize>(forged.size()));
    expectRefused(run("decode l0.vcz -o out.raw", dir), 1, "l0.vcz", "0 levels");
    test::writeFile(dir / "tf.json", kTf);
    expectRefused(run("render --volume l0.vcz --tf tf.json --width 16 --height 16 -o out.png", dir), 1,
                  "l0.vcz", "0 levels");
    EXPECT_FALSE(fs::exists(dir / "out.raw"));
    EXPECT_FALSE(fs::exists(dir / "out.png"));
}

// "preset:NAME" was joined to the scene's directory like a file name: sub/preset:viridis.
TEST(CliHostile, ScenePresetIsNotAPathBesideTheScene) {
    const fs::path dir = test::tempDir("hostile_scene_preset");
    fs::create_directories(dir / "sub");
    writeVolumeFile(ramp({16, 16, 16}), dir / "sub" / "v.nrrd");
    test::writeFile(dir / "sub" / "scene.json", R"({"volume": "v.nrrd", "tf": "preset:viridis"})");
    const RunResult r = run("render --scene sub/scene.json --width 16 --height 16 -o s.png", dir);
    EXPECT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(fs::exists(dir / "s.png"));
}

// The hidden temporary repeated the whole output name: names of 234-255 bytes went over NAME_MAX.
TEST(CliHostile, OutputNamesOf255BytesAreWritten) {
    const fs::path dir = test::tempDir("hostile_long_name");
    writeVolumeFile(ramp({16, 16, 16}), dir / "v.nrrd");
    test::writeFile(dir / "tf.json", kTf);
    const std::string nii = std::string(251, 'a') + ".nii", png = std::string(251, 'b') + ".png";
    ASSERT_EQ(nii.size(), 255u);
    const RunResult c = run("convert v.nrrd -o " + nii, dir);
    EXPECT_EQ(c.exitCode, 0) << c.err;
    EXPECT_EQ(readVolume(dir / nii).dims(), (Dims{16, 16, 16}));
    const RunResult r = run("render --volume v.nrrd --tf tf.json --width 16 --height 16 -o " + png, dir);
    EXPECT_EQ(r.exitCode, 0) << r.err;
    EXPECT_GT(fs::file_size(dir / png), 0u);
    EXPECT_EQ(test::listing(dir), (std::set<std::string>{"v.nrrd", "tf.json", "stderr.txt", nii, png}));
}

// Notes (defaults the command chose) used to come before a failure: two lines on stderr for exit 1.
TEST(CliHostile, RenderNotesDoNotPrecedeAnError) {
    const fs::path dir = test::tempDir("hostile_render_notes");
    writeVolumeFile(ramp({16, 16, 16}), dir / "v.nrrd");
    test::writeFile(dir / "tf.json", kTf);
    expectRefused(run("render --volume v.nrrd --tf tf.json --width 16 --height 16 -o nodir/x.png", dir), 1,
                  "nodir/x.png");
    // On success they are still printed.
    const RunResult ok = run("render --volume v.nrrd --tf tf.json --width 16 --height 16 -o x.png", dir);
    EXPECT_EQ(ok.exitCode, 0) << ok.err;
    EXPECT_NE(ok.err.find("camera:"), std::string::npos) << ok.err;
}

// ---- geometry and versions ----------------------------------------------------------------------------

TEST(CliHostile, NonFiniteGeometryIsRefusedNamingTheFile) {
    const fs::path dir = test::tempDir("hostile_geometry");
    const std::string data(8, '\x01');
    test::writeFile(
        dir / "nan_spacing.nrrd",
        "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nspacings: nan 1 1\nencoding: raw\n\n" + data);
    test::writeFile(dir / "inf_origin.nrrd",
                    "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nspace dimension: 3\n"
                    "space origin: (inf,0,0)\nencoding: raw\n\n" +
                        data);
    test::writeFile(dir / "nan.mhd", "NDims = 3\nDimSize = 2 2 2\nElementType = MET_UCHAR\nOffset = nan 0 0\n"
                                     "ElementDataFile = LOCAL\n" +
                                         data);
    test::writeFile(dir / "nan.vtk", "# vtk DataFile Version 3.0\nx\nASCII\nDATASET STRUCTURED_POINTS\n"
                                     "DIMENSIONS 2 2 2\nSPACING 1 nan 1\nORIGIN 0 0 0\nPOINT_DATA 8\n"
                                     "SCALARS s unsigned_char\nLOOKUP_TABLE default\n1 1 1 1 1 1 1 1\n");
    for (const char* f : {"nan_spacing.nrrd", "inf_origin.nrrd", "nan.mhd", "nan.vtk"})
        expectRefused(run(std::string("info ") + f, dir), 1, f);
    // NIfTI: pixdim and scl_slope are float fields of the 348-byte header.
    auto nifti = [&](const std::string& name, std::size_t offset, float value) {
        std::string h(352, '\0');
        auto put16 = [&](std::size_t at, std::int16_t v) { std::memcpy(&h[at], &v, 2); };
        auto putF = [&](std::size_t at, float v) { std::memcpy(&h[at], &v, 4); };
        const std::int32_t size = 348;
        std::memcpy(&h[0], &size, 4);
        put16(40, 3), put16(42, 2), put16(44, 2), put16(46, 2), put16(48, 1);
        put16(70, 2), put16(72, 8); // uint8
        putF(76, 1), putF(80, 1), putF(84, 1), putF(88, 1);
        putF(108, 352), putF(112, 1);
        std::memcpy(&h[344], "n+1", 4);
        putF(offset, value);
        test::writeFile(dir / name, h + data);
    };
    nifti("nan_pixdim.nii", 84, std::numeric_limits<float>::quiet_NaN());
    nifti("inf_slope.nii", 112, std::numeric_limits<float>::infinity());
    nifti("good.nii", 112, 1.0f);
    EXPECT_EQ(run("info good.nii", dir).exitCode, 0) << test::readFile(dir / "stderr.txt");
    expectRefused(run("info nan_pixdim.nii", dir), 1, "nan_pixdim.nii", "pixdim");
    expectRefused(run("info inf_slope.nii", dir), 1, "inf_slope.nii", "scl_slope");
}

TEST(CliHostile, UnknownNrrdVersionsAreRefused) {
    const fs::path dir = test::tempDir("hostile_nrrd_version");
    const std::string body =
        "type: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n\n" + std::string(8, '\1');
    test::writeFile(dir / "v9.nrrd", "NRRD0009\n" + body);
    test::writeFile(dir / "v5.nrrd", "NRRD0005\n" + body);
    expectRefused(run("info v9.nrrd", dir), 1, "v9.nrrd", "version");
    EXPECT_EQ(run("info v5.nrrd", dir).exitCode, 0) << test::readFile(dir / "stderr.txt");
}

// ---- signals and limits during a write -----------------------------------------------------------------

TEST(CliHostile, FileSizeLimitEndsInACleanErrorWithoutTemporaries) {
    const fs::path dir = test::tempDir("hostile_xfsz");
    writeVolumeFile(ramp({64, 64, 64}), dir / "v_64x64x64_uint8.raw");
    // ulimit -f counts 1024-byte blocks: the 256 KiB output cannot be written under 64 KiB.
    const RunResult r = run("convert v_64x64x64_uint8.raw -o out.raw", dir, "ulimit -f 64;");
    expectRefused(r, 1, "out.raw");
    for (const auto& e : fs::directory_iterator(dir))
        EXPECT_EQ(e.path().filename().string().find("out.raw"), std::string::npos) << "leftover " << e.path();
}

TEST(CliHostile, SigkillDuringAWriteLeavesNoTemporary) {
    const fs::path dir = test::tempDir("hostile_kill");
    const fs::path out = dir / "out";
    fs::create_directories(out);
    writeVolumeFile(ramp({256, 256, 256}), dir / "v_256x256x256_uint8.raw");
    for (int attempt = 0; attempt < 5; ++attempt) {
        const std::string cmd = VOLCL_EXE " -q convert " + (dir / "v_256x256x256_uint8.raw").string() +
                                " -o " + (out / "big.nrrd").string();
        const char* argv[] = {"/bin/sh", "-c", nullptr, nullptr};
        const std::string full = "exec " + cmd;
        argv[2] = full.c_str();
        pid_t pid = 0;
        ASSERT_EQ(posix_spawn(&pid, "/bin/sh", nullptr, nullptr, const_cast<char**>(argv), environ), 0);
        usleep(static_cast<useconds_t>(20000 + attempt * 40000)); // reading, converting, compressing
        kill(pid, SIGKILL);
        int status = 0;
        waitpid(pid, &status, 0);
        for (const auto& e : fs::directory_iterator(out))
            EXPECT_EQ(e.path().filename().string(), "big.nrrd") << "leftover temporary " << e.path();
    }
}

// ---- every output one commit: full disks, size limits, series ------------------------------------------

namespace {

// A 64 KB tmpfs at `dir`; false (the caller skips) where mounting is refused.
bool mountSmallTmpfs(const fs::path& dir) {
    fs::create_directories(dir);
    return ::mount("tmpfs", dir.c_str(), "tmpfs", 0, "size=64k") == 0;
}

// Fills the file system of `dir` to its last block.
void fillUp(const fs::path& dir) {
    std::ofstream fill(dir / "fill", std::ios::binary);
    const std::string block(4096, 'f');
    while (fill.write(block.data(), std::streamsize(block.size())) && fill.flush()) {
    }
}

struct Unmount {
    fs::path dir;
    ~Unmount() { ::umount2(dir.c_str(), MNT_DETACH); }
};

std::set<std::string> names(const fs::path& dir) {
    std::set<std::string> out;
    for (const auto& e : fs::directory_iterator(dir))
        out.insert(e.path().filename().string());
    return out;
}

// Frames a constant, b constant, c noise: as .nii.gz the first two take a few hundred bytes, the third
// about 32 KB, so a limit between them fails the series at its last frame.
TimeSeries twoQuietFramesAndANoisyOne() {
    TimeSeries ts;
    for (int f = 0; f < 3; ++f) {
        Volume v({32, 32, 32}, ScalarType::UInt8);
        std::uint32_t state = 99;
        for (auto& x : v.values<std::uint8_t>()) {
            state = state * 1664525u + 1013904223u;
            x = f < 2 ? static_cast<std::uint8_t>(f + 1) : static_cast<std::uint8_t>(state >> 24);
        }
        ts.frames.push_back(std::move(v));
    }
    return ts;
}

} // namespace

// The issue's reproducers: on a full file system `convert -o t.vdb` left a truncated t.vdb and `render -o
// t.png` a 0-byte t.png, both with exit 0 (OpenVDB's and OpenImageIO's writes went unchecked). Each now
// fails with one line naming the file, keeps the old target and leaves nothing new; so do .nhdr and series.
TEST(CliHostile, FullDiskFailsEveryWriterCleanly) {
    const fs::path dir = test::tempDir("hostile_full_disk");
    writeVolumeFile(ramp({64, 64, 64}), dir / "v_64x64x64_uint8.raw");
    writeSeriesFile(twoQuietFramesAndANoisyOne(), dir / "s.nii");
    test::writeFile(dir / "tf.json", kTf);
    const fs::path full = dir / "full";
    if (!mountSmallTmpfs(full))
        GTEST_SKIP() << "cannot mount a tmpfs here (needs root): " << std::strerror(errno);
    const Unmount unmount{full};
    for (const char* old : {"t.vdb", "t.png", "t.nhdr", "f_00.nii.gz"})
        test::writeFile(full / old, "old");
    fillUp(full);
    const std::set<std::string> before = names(full);
    struct Case {
        std::string args, target;
    } cases[] = {
        {"convert v_64x64x64_uint8.raw -o full/t.vdb", "t.vdb"},
        {"render --volume v_64x64x64_uint8.raw --tf tf.json --width 96 --height 96 -o full/t.png", "t.png"},
        {"convert v_64x64x64_uint8.raw -o full/t.nhdr", "t.nhdr"},
        {"convert s.nii -o full/f_%02d.nii.gz", "f_0"},
    };
    for (const Case& c : cases) {
        expectRefused(run(c.args, dir), 1, c.target);
        EXPECT_EQ(names(full), before) << c.args;
    }
    for (const char* old : {"t.vdb", "t.png", "t.nhdr", "f_00.nii.gz"})
        EXPECT_EQ(test::readFile(full / old), "old") << old;
}

// Unprivileged: the file size limit cuts the OpenVDB writer short (it wrote a truncated file, exit 0).
TEST(CliHostile, FileSizeLimitInTheVdbWriterFailsCleanly) {
    const fs::path dir = test::tempDir("hostile_xfsz_vdb");
    writeVolumeFile(ramp({64, 64, 64}), dir / "v_64x64x64_uint8.raw");
    test::writeFile(dir / "t.vdb", "old");
    expectRefused(run("convert v_64x64x64_uint8.raw -o t.vdb", dir, "ulimit -f 16;"), 1, "t.vdb");
    EXPECT_EQ(test::readFile(dir / "t.vdb"), "old");
    EXPECT_EQ(names(dir), (std::set<std::string>{"t.vdb", "v_64x64x64_uint8.raw", "stderr.txt"}));
}

// A series written as a pattern is all or nothing: the limit stops its last frame, and the first two
// (which fit) must not stay behind; an old frame file keeps its content. Without the limit all three land.
TEST(CliHostile, SeriesPatternOutputIsAllOrNothing) {
    const fs::path dir = test::tempDir("hostile_series_commit");
    writeSeriesFile(twoQuietFramesAndANoisyOne(), dir / "s.nii");
    test::writeFile(dir / "f_01.nii.gz", "old");
    expectRefused(run("convert s.nii -o f_%02d.nii.gz", dir, "ulimit -f 8;"), 1, "f_02.nii.gz");
    EXPECT_EQ(names(dir), (std::set<std::string>{"s.nii", "f_01.nii.gz", "stderr.txt"}));
    EXPECT_EQ(test::readFile(dir / "f_01.nii.gz"), "old");
    ASSERT_EQ(run("-q convert s.nii -o f_%02d.nii.gz", dir).exitCode, 0)
        << test::readFile(dir / "stderr.txt");
    const TimeSeries source = readVolumeFile(dir / "s.nii");
    for (int f = 0; f < 3; ++f)
        EXPECT_EQ(readVolume(dir / ("f_0" + std::to_string(f) + ".nii.gz")), source.frames[std::size_t(f)]);
    EXPECT_EQ(names(dir).size(), 5u);
    // The same through `decode` of a .vcz series (frames decoded and written one at a time).
    const fs::path vcz = test::tempDir("hostile_series_commit_vcz");
    std::string frames;
    for (int f = 0; f < 3; ++f) {
        const std::string name = "fr" + std::to_string(f) + "_32x32x32_uint8.raw";
        writeVolumeFile(source.frames[std::size_t(f)], vcz / name);
        frames += name + " ";
    }
    ASSERT_EQ(run("-q encode " + frames + "-o s.vcz", vcz).exitCode, 0) << test::readFile(vcz / "stderr.txt");
    const std::set<std::string> before = names(vcz);
    expectRefused(run("decode s.vcz -o f_%02d.nii.gz", vcz, "ulimit -f 8;"), 1, "f_02.nii.gz");
    EXPECT_EQ(names(vcz), before);
}

// ---- budgets (issue #40): every count that multiplies work is checked before any allocation or loop ------

TEST(CliHostile, InfoReportsACorruptBrickPayload) {
    const fs::path dir = test::tempDir("hostile_vcz_payload");
    writeVolumeFile(ramp({16, 16, 16}), dir / "v_16x16x16_uint8.raw");
    ASSERT_EQ(run("encode v_16x16x16_uint8.raw -o v.vcz", dir).exitCode, 0);
    ASSERT_EQ(run("info v.vcz", dir).exitCode, 0);
    std::string bytes = test::readFile(dir / "v.vcz");
    const auto* raw = reinterpret_cast<const std::byte*>(bytes.data());
    const VczHeader h = readVczHeader(std::span<const std::byte>(raw, bytes.size()), "v.vcz");
    const VczBrickEntry& last = h.bricks[0].back();
    ASSERT_GT(last.size, 0u);
    bytes[last.offset + last.size / 2] ^= 0x5a; // inside the payload; the index's checksum is left as it was
    test::writeFile(dir / "flipped.vcz", bytes);
    expectRefused(run("info flipped.vcz", dir), 1, "flipped.vcz", "checksum");
    expectRefused(run("info --json flipped.vcz", dir), 1, "flipped.vcz", "checksum");
}

// A step just above the per-ray bound (5e7 samples across the diagonal) ran for minutes on a 64x64 image:
// the frame's samples (pixels x samples per ray x shadow samples per sample) are budgeted before any kernel.
TEST(CliHostile, SamplesPerFrameAreBudgetedBeforeRendering) {
    const fs::path dir = test::tempDir("hostile_frame_samples");
    writeVolumeFile(ramp({16, 16, 16}), dir / "v_16x16x16_uint8.raw");
    test::writeFile(dir / "tf.json", kTf);
    auto scene = [&](const std::string& name, const std::string& render, const std::string& effects) {
        test::writeFile(dir / name, R"({"volume": "v_16x16x16_uint8.raw", "tf": "tf.json",
            "image": {"width": 64, "height": 64}, "render": )" +
                                        render + R"(, "effects": )" + effects + "}");
    };
    // The diagonal is 16 sqrt(3) = 27.7: 6e-7 is 4.6e7 samples per ray, 1.9e11 per 64x64 frame.
    scene("fine_step.json", R"({"mode": "dvr", "step": 6e-7})", "{}");
    expectRefused(run("render --scene fine_step.json -o out.png", dir, "", 10), 2,
                  "fine_step.json: render.step", "samples per frame");
    scene("fine_shadow.json", R"({"mode": "dvr", "step": 0.5})",
          R"({"shading": true, "shadows": true, "shadow_step": 6e-7})");
    expectRefused(run("render --scene fine_shadow.json -o out.png", dir, "", 10), 2,
                  "fine_shadow.json: render.step and effects.shadow_step", "samples per frame");
    expectRefused(run("render --scene fine_shadow.json --shadow-step 1e-6 -o out.png", dir, "", 10), 2,
                  "effects.shadow_step", "samples per frame");
    EXPECT_FALSE(fs::exists(dir / "out.png"));
    // The same frame at ordinary steps renders.
    scene("ordinary.json", R"({"mode": "dvr", "step": 0.5})", R"({"shading": true, "shadows": true})");
    EXPECT_EQ(run("-q render --scene ordinary.json -o out.png", dir).exitCode, 0);
}

// A 4096 x 16 3D table took 48 s and 12.7 GB for a 64x64 render: nodes^2 x lengths is budgeted (2^24
// entries) before the table is allocated, for a scene's table and for `volcl preint`.
TEST(CliHostile, PreintegrationTableEntriesAreBudgeted) {
    const fs::path dir = test::tempDir("hostile_table_entries");
    writeVolumeFile(ramp({16, 16, 16}), dir / "v_16x16x16_uint8.raw");
    test::writeFile(dir / "tf.json", kTf);
    test::writeFile(dir / "big_table.json", R"({"volume": "v_16x16x16_uint8.raw", "tf": "tf.json",
        "image": {"width": 64, "height": 64}, "render": {"mode": "dvr", "step": 0.5, "preintegration": "3d",
        "table_size": 4096, "table_lengths": 16}})");
    expectRefused(run("render --scene big_table.json -o out.png", dir, "", 20), 2, "render.table_size",
                  "2^24");
    expectRefused(
        run("render --volume v_16x16x16_uint8.raw --tf tf.json --width 64 --height 64 --preintegration 3d "
            "--table-size 2048 --table-lengths 8 -o out.png",
            dir, "", 20),
        2, "render.table_size", "2^24");
    EXPECT_FALSE(fs::exists(dir / "out.png"));
    expectRefused(run("preint --tf tf.json --size 4096 --lengths 16 --max-length 1 -o t.exr", dir, "", 20), 2,
                  "4096x4096x16", "2^24");
    expectRefused(run("preint --tf tf.json --size 8192 --step 1 -o t.exr", dir, "", 20), 2, "8192x8192x1",
                  "2^24");
    EXPECT_FALSE(fs::exists(dir / "t.exr"));
}

// 16,384 points alternating between two saturated colours in the diverging space: each interval bisected
// to 4,095 points made 67 million (29 s, 1.96 GB in `preint`). The whole list shares a piece budget.
TEST(CliHostile, ColourSpacePiecesAreBudgeted) {
    const fs::path dir = test::tempDir("hostile_colour_pieces");
    std::ostringstream j;
    j << R"([{"Name": "alternating", "ColorSpace": "Diverging", "RGBPoints": [)";
    for (int i = 0; i < 16384; ++i)
        j << (i ? ", " : "") << i << (i % 2 ? ", 0.23, 0.30, 0.75" : ", 0.71, 0.02, 0.15");
    j << "]}]";
    test::writeFile(dir / "alternating.json", j.str());
    expectRefused(run("preint --tf alternating.json --size 8 --step 1 -o t.exr", dir, "", 20), 1,
                  "alternating.json", "65536 linear pieces");
    EXPECT_FALSE(fs::exists(dir / "t.exr"));
}

// `CELLS 1099511627776 800` reserved 2^40 cells and failed with "out of memory", naming no file.
TEST(CliHostile, LegacyVtkCellCountsBeyondTheirDataAreRefused) {
    const fs::path dir = test::tempDir("hostile_vtk_cells");
    const std::string head = "# vtk DataFile Version 2.0\nforged\nASCII\nDATASET UNSTRUCTURED_GRID\n"
                             "POINTS 4 float\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n";
    const std::string tail = "CELL_TYPES 1\n10\nPOINT_DATA 4\nSCALARS s float 1\nLOOKUP_TABLE default\n"
                             "0 1 2 3\n";
    test::writeFile(dir / "tet.vtk", head + "CELLS 1 5\n4 0 1 2 3\n" + tail);
    ASSERT_EQ(run("info tet.vtk", dir).exitCode, 0);
    test::writeFile(dir / "forged.vtk", head + "CELLS 1099511627776 5\n4 0 1 2 3\n" + tail);
    expectRefused(run("info forged.vtk", dir), 1, "forged.vtk", "CELLS");
}

// Collections: 3,001 <Volume>s naming one 2.8 MB file took 58 s and 12.3 GB before failing naming no file;
// a .pvd naming one .vti 2,000 times took 68 s and 6.2 GB. The .vvd's volumes together are claimed against
// the memory budget before any is read; a .pvd lists each file once. (ulimit keeps the unfixed reader from
// taking the machine's memory: it fails instead.)
// A cap on the address space for commands that used to allocate gigabytes, so a regression fails here rather
// than exhausting the machine; AddressSanitizer reserves terabytes of shadow memory, so its build relies on
// the peak-memory check of expectRefused alone.
#if defined(__SANITIZE_ADDRESS__)
const std::string kAddressSpaceCap;
#else
const std::string kAddressSpaceCap = "ulimit -v 4000000;";
#endif

TEST(CliHostile, CollectionMembersAreBudgetedBeforeAnyIsRead) {
    const fs::path dir = test::tempDir("hostile_collections");
    {
        std::ofstream(dir / "big.raw", std::ios::binary).put('\0');
        fs::resize_file(dir / "big.raw", 256u * 256u * 512u * 2u); // sparse: 64 MiB of uint16 zeros
    }
    std::string vvd = "<?xml version=\"1.0\" ?>\n<VoreenData version=\"1\"><Volumes>\n";
    for (int i = 0; i < 3001; ++i)
        vvd += "<Volume><RawData filename=\"big.raw\" format=\"uint16\" x=\"256\" y=\"256\" z=\"512\" "
               "/></Volume>\n";
    test::writeFile(dir / "many.vvd", vvd + "</Volumes></VoreenData>\n");
    expectRefused(run("info many.vvd", dir, kAddressSpaceCap, 20), 1, "many.vvd", "memory budget");
    expectRefused(run("convert many.vvd -o out.nrrd", dir, kAddressSpaceCap, 20), 1, "many.vvd",
                  "memory budget");
    EXPECT_FALSE(fs::exists(dir / "out.nrrd"));
    // Within the budget, one file named again is the same volume again: refused before any is read.
    writeVolumeFile(ramp({16, 16, 16}), dir / "small.raw");
    std::string twice = "<?xml version=\"1.0\" ?>\n<VoreenData version=\"1\"><Volumes>\n";
    for (int i = 0; i < 3001; ++i)
        twice += "<Volume><RawData filename=\"small.raw\" format=\"uint8\" x=\"16\" y=\"16\" z=\"16\" "
                 "/></Volume>\n";
    test::writeFile(dir / "twice.vvd", twice + "</Volumes></VoreenData>\n");
    expectRefused(run("info twice.vvd", dir, kAddressSpaceCap, 20), 1, "twice.vvd", "more than one <Volume>");

    writeVolumeFile(ramp({16, 16, 16}), dir / "one.vti");
    std::string pvd = "<VTKFile type=\"Collection\"><Collection>";
    for (int t = 0; t < 2000; ++t)
        pvd += "<DataSet timestep=\"" + std::to_string(t) + "\" file=\"one.vti\"/>";
    test::writeFile(dir / "repeated.pvd", pvd + "</Collection></VTKFile>\n");
    expectRefused(run("encode repeated.pvd -o out.vcz", dir, kAddressSpaceCap, 20), 1, "repeated.pvd",
                  "more than once");
    EXPECT_FALSE(fs::exists(dir / "out.vcz"));
}

// A 255 KB .nii.gz of 256 MB of zeros took 12 s and 521 MB for `info`. Above 64 MiB an output may come from
// at most 1000 times fewer compressed bytes (deflate's own limit is ~1032:1, reached only by constant data):
// the gzip of a NIfTI and of a raw file, NRRD's gzip encoding and VTK XML's zlib blocks alike.
TEST(CliHostile, DecompressionRatiosAreBudgeted) {
    const fs::path dir = test::tempDir("hostile_inflate");
    const Volume zeros({512, 512, 384}, ScalarType::UInt8); // 96 MiB
    for (const char* name : {"z.nii.gz", "z_512x512x384_uint8.raw.gz", "z.nrrd"})
        writeVolumeFile(zeros, dir / name);
    // volcl writes VTK XML in 32 KiB blocks (about 540:1 at best); VTK may write the array as one block.
    {
        const std::vector<std::byte> block = io::deflateBytes(zeros.bytes(), io::Wrapper::Zlib, 9);
        const std::uint64_t header[4] = {1, zeros.byteSize(), 0, block.size()};
        std::ofstream out(dir / "z.vti", std::ios::binary);
        out << R"(<?xml version="1.0"?>
<VTKFile type="ImageData" version="1.0" byte_order="LittleEndian" header_type="UInt64" compressor="vtkZLibDataCompressor">
<ImageData WholeExtent="0 511 0 511 0 383" Origin="0 0 0" Spacing="1 1 1"><Piece Extent="0 511 0 511 0 383">
<PointData Scalars="s"><DataArray type="UInt8" Name="s" format="appended" offset="0"/></PointData>
</Piece></ImageData>
<AppendedData encoding="raw">_)";
        out.write(reinterpret_cast<const char*>(header), sizeof header);
        out.write(reinterpret_cast<const char*>(block.data()), static_cast<std::streamsize>(block.size()));
        out << "\n</AppendedData>\n</VTKFile>\n";
    }
    for (const char* name : {"z.nii.gz", "z_512x512x384_uint8.raw.gz", "z.nrrd", "z.vti"}) {
        ASSERT_LT(fs::file_size(dir / name), 96u * 1024u * 1024u / 1000u) << name;
        expectRefused(run(std::string("info ") + name, dir, "", 30), 1, name, "decompression budget");
    }
    // Below 64 MiB any ratio deflate can reach is read.
    writeVolumeFile(Volume({512, 512, 128}, ScalarType::UInt8), dir / "small.nii.gz");
    EXPECT_EQ(run("-q info small.nii.gz", dir).exitCode, 0);
}

// The blunt-fin grid with its points shuffled: every tet spans much of the mesh, so the overlap search of
// the cell caster tested n^2 / 2 tet pairs and every ray re-entered hundreds of folded tets (128x128: 56 s,
// the real grid 0.6 s). More than 10% folded faces is no tetrahedral mesh: refused before any search.
TEST(CliHostile, ShuffledPlot3dGridIsRefusedAsFolded) {
    fs::path data;
    VOLCL_REQUIRE_SHARED_DATA(data);
    const fs::path xyz = data / "unstructured/bluntfinxyz.bin", q = data / "unstructured/bluntfinq.bin";
    if (!fs::exists(xyz) || !fs::exists(q)) GTEST_SKIP() << "blunt-fin PLOT3D files not in " << data;
    const fs::path dir = test::tempDir("hostile_shuffled_grid");
    std::string grid = test::readFile(xyz);
    // Big-endian: three int32 dims, then the x, y and z arrays of float32; permute the points jointly.
    auto dim = [&](int i) {
        const auto* b = reinterpret_cast<const unsigned char*>(grid.data()) + 4 * i;
        return std::size_t(b[0]) << 24 | std::size_t(b[1]) << 16 | std::size_t(b[2]) << 8 | std::size_t(b[3]);
    };
    const std::size_t n = dim(0) * dim(1) * dim(2);
    ASSERT_EQ(grid.size(), 12 + 12 * n);
    std::vector<std::size_t> perm(n);
    std::iota(perm.begin(), perm.end(), std::size_t(0));
    std::shuffle(perm.begin(), perm.end(), std::mt19937(1));
    std::string shuffled = grid;
    for (std::size_t a = 0; a < 3; ++a)
        for (std::size_t i = 0; i < n; ++i)
            std::memcpy(&shuffled[12 + 4 * (a * n + i)], &grid[12 + 4 * (a * n + perm[i])], 4);
    test::writeFile(dir / "shufxyz.bin", shuffled);
    fs::copy_file(q, dir / "shufq.bin", fs::copy_options::overwrite_existing);
    expectRefused(run("render --volume shufxyz.bin --tf preset:viridis --width 128 --height 128 -o out.png",
                      dir, "", 30),
                  1, "shufxyz.bin", "folded");
    EXPECT_FALSE(fs::exists(dir / "out.png"));
    // The grid as written renders.
    fs::copy_file(xyz, dir / "bluntfinxyz.bin", fs::copy_options::overwrite_existing);
    fs::copy_file(q, dir / "bluntfinq.bin", fs::copy_options::overwrite_existing);
    const RunResult r =
        run("-q render --volume bluntfinxyz.bin --tf preset:viridis --width 32 --height 32 -o out.png", dir);
    EXPECT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(fs::exists(dir / "out.png"));
}
