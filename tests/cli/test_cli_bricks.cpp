// `.vcz` as a volume everywhere through the binary: info lists bricks, levels and ranges; render draws from
// the bricks (lod full equals the decoded volume's image, --stats), convert and compare read it, --frame
// picks a series frame, and a corrupted brick met while rendering exits 1 naming the brick with no output
// left.
#include "../TestUtil.hpp"
#include "../VczTestUtil.hpp"
#include "CliRun.hpp"
#include "core/MemoryBudget.hpp"
#include "host/image/ImageIo.hpp"
#include "host/io/VolumeIo.hpp"
#include "wavelet/container/VczFormat.hpp"

#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <span>
#include <sstream>

using namespace volcl;
namespace fs = std::filesystem;

namespace {

double maxAbs(const fs::path& a, const fs::path& b) {
    const ImageBuffer x = readImage(a), y = readImage(b);
    EXPECT_EQ(x.pixels.size(), y.pixels.size());
    double m = 0;
    for (std::size_t i = 0; i < x.pixels.size() && i < y.pixels.size(); ++i)
        m = std::max(m, double(std::abs(x.pixels[i] - y.pixels[i])));
    return m;
}

const char* kTf = R"({"domain": [0, 255], "color": [[0, 0.2, 0.3, 0.9], [128, 1, 0.6, 0.2], [255, 1, 1, 1]],
  "extinction": [[0, 0], [40, 0], [90, 0.2], [255, 0.5]]})";

void writeBall(const fs::path& p, int shift) {
    const Volume v = test::makeFloatVolume({40, 36, 30}, [shift](double x, double y, double z) {
        const double r =
            std::sqrt((x - 20 - shift) * (x - 20 - shift) + (y - 18) * (y - 18) + (z - 15) * (z - 15));
        return r < 13 ? 250 - 12 * r : 0;
    });
    Volume u8(v.dims(), ScalarType::UInt8);
    for (std::size_t i = 0; i < v.voxelCount(); ++i)
        u8.values<std::uint8_t>()[i] = std::uint8_t(v.values<float>()[i]);
    writeVolumeFile(u8, p);
}

TEST(CliBricks, VczIsAVolumeEverywhere) {
    const fs::path dir = test::tempDir("cli_bricks");
    writeBall(dir / "ball.nrrd", 0);
    test::writeFile(dir / "tf.json", kTf);
    test::RunResult r = test::runVolcl("encode " + test::quoted(dir / "ball.nrrd") +
                                           " --brick 16 --levels 2 -o " + test::quoted(dir / "ball.vcz"),
                                       dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    r = test::runVolcl("info " + test::quoted(dir / "ball.vcz"), dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("bricks   18 (3 x 3 x 2), level-of-detail statistics stored"), std::string::npos)
        << r.out;
    r = test::runVolcl("info --json " + test::quoted(dir / "ball.vcz"), dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("\"max_error\""), std::string::npos);
    r = test::runVolcl("convert " + test::quoted(dir / "ball.vcz") + " -o " + test::quoted(dir / "back.nrrd"),
                       dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    r = test::runVolcl("compare " + test::quoted(dir / "ball.nrrd") + " " + test::quoted(dir / "back.nrrd") +
                           " --json",
                       dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("\"max_abs_error\": 0.0,"), std::string::npos) << r.out;
    const std::string cam = " --tf " + test::quoted(dir / "tf.json") +
                            " --tf-range 0,255 --width 64 --height 64 --eye 60,-30,-40 --target 20,18,15";
    r = test::runVolcl("render --volume " + test::quoted(dir / "back.nrrd") + cam + " -o " +
                           test::quoted(dir / "grid.exr"),
                       dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    r = test::runVolcl("render --volume " + test::quoted(dir / "ball.vcz") + cam + " --lod full --stats -o " +
                           test::quoted(dir / "bricks.exr"),
                       dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.err.find("bricks visited"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("hidden by the TF"), std::string::npos) << r.err;
    EXPECT_LE(maxAbs(dir / "grid.exr", dir / "bricks.exr"), 1e-6);
    r = test::runVolcl("render --volume " + test::quoted(dir / "ball.vcz") + cam +
                           " --lod auto --lod-error 0.01 --cache-mb 1 -o " + test::quoted(dir / "auto.exr"),
                       dir);
    EXPECT_EQ(r.exitCode, 0) << r.err;
}

TEST(CliBricks, SeriesFrameAndCorruptedBrick) {
    const fs::path dir = test::tempDir("cli_bricks_series");
    writeBall(dir / "f0.nrrd", 0);
    writeBall(dir / "f1.nrrd", 4);
    test::writeFile(dir / "tf.json", kTf);
    test::RunResult r =
        test::runVolcl("encode " + test::quoted(dir / "f0.nrrd") + " " + test::quoted(dir / "f1.nrrd") +
                           " --brick 16 --levels 2 -o " + test::quoted(dir / "s.vcz"),
                       dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    r = test::runVolcl(
        "decode " + test::quoted(dir / "s.vcz") + " --frame 1 -o " + test::quoted(dir / "f1back.nrrd"), dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const std::string cam = " --tf " + test::quoted(dir / "tf.json") +
                            " --tf-range 0,255 --width 48 --height 48 --eye 60,-30,-40 --target 20,18,15";
    r = test::runVolcl("render --volume " + test::quoted(dir / "f1back.nrrd") + cam + " -o " +
                           test::quoted(dir / "grid1.exr"),
                       dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    r = test::runVolcl("render --volume " + test::quoted(dir / "s.vcz") + cam + " --frame 1 -o " +
                           test::quoted(dir / "bricks1.exr"),
                       dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_LE(maxAbs(dir / "grid1.exr", dir / "bricks1.exr"), 1e-6);
    r = test::runVolcl("render --volume " + test::quoted(dir / "s.vcz") + cam + " --frame 2 -o " +
                           test::quoted(dir / "none.exr"),
                       dir);
    EXPECT_EQ(r.exitCode, 2) << r.err;
    EXPECT_FALSE(fs::exists(dir / "none.exr"));

    // Damage one payload byte of a brick the view needs (brick 4 holds the ball's centre).
    std::string bytes = test::readFile(dir / "s.vcz");
    const VczHeader h = readVczHeader(std::as_bytes(std::span(bytes.data(), bytes.size())), "s.vcz");
    bytes[h.bricks[1][4].offset + 2] ^= 0x20;
    test::writeFile(dir / "bad.vcz", bytes);
    r = test::runVolcl("--quiet render --volume " + test::quoted(dir / "bad.vcz") + cam + " --frame 1 -o " +
                           test::quoted(dir / "bad.exr"),
                       dir);
    EXPECT_EQ(r.exitCode, 1) << r.err;
    EXPECT_NE(r.err.find("brick 4"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("bad.vcz"), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(fs::exists(dir / "bad.exr"));
}

// A forged .vcz whose decoded frame (2048x2048x1023 float32, 16 GiB) is larger than the memory budget (half of
// the machine's memory), its 256 payloads sparse zeros of `payloadBytes` each (their checksums match): what the
// brick path holds is the index and a pool, so it opens; whole-frame decodes stay bounded by the frame's size.
fs::path writeHugeSparseVcz(const fs::path& dir, std::uint64_t payloadBytes) {
    const Volume small = test::makeFloatVolume({8, 8, 8}, [](double, double, double) { return 0.0; });
    writeVolumeFile(small, dir / "small.nrrd");
    const test::RunResult r = test::runVolcl(
        "encode " + test::quoted(dir / "small.nrrd") + " -o " + test::quoted(dir / "small.vcz"), dir);
    EXPECT_EQ(r.exitCode, 0) << r.err;
    const std::string bytes = test::readFile(dir / "small.vcz");
    VczHeader h = readVczHeader(std::as_bytes(std::span(bytes.data(), bytes.size())), "small.vcz");
    h.metadata.erase("volcl:lod");
    h.dims = {2048, 2048, 1023};
    h.brick = {256, 256, 256};
    const std::vector<std::uint8_t> zeros(payloadBytes, 0);
    VczBrickEntry e;
    e.size = payloadBytes;
    e.checksum = vczChecksum(zeros);
    h.bricks.assign(1, std::vector<VczBrickEntry>(h.brickCount(), e));
    const std::size_t preamble = vczPreambleSize(h);
    for (std::size_t b = 0; b < h.brickCount(); ++b)
        h.bricks[0][b].offset = preamble + b * payloadBytes;
    const std::vector<std::byte> head = writeVcz(h, {});
    EXPECT_EQ(head.size(), preamble);
    const fs::path out = dir / "huge.vcz";
    test::writeFile(out, std::string_view(reinterpret_cast<const char*>(head.data()), head.size()));
    fs::resize_file(out, preamble + h.brickCount() * payloadBytes); // a hole: no disk used
    return out;
}

TEST(CliBricks, AVczLargerThanTheMemoryBudgetOpensForItsBricks) {
    const fs::path dir = test::tempDir("cli_bricks_huge");
    const fs::path vcz = writeHugeSparseVcz(dir, std::uint64_t(4) << 20); // a 1 GiB file
    ASSERT_GT(std::size_t(2048) * 2048 * 1023 * sizeof(float), defaultMemoryBudget())
        << "the forged frame must exceed this machine's memory budget";

    test::RunResult r = test::runVolcl("info " + test::quoted(vcz), dir); // the index and every checksum
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("2048"), std::string::npos) << r.out;

    // A whole-frame decode is refused before anything is allocated, one line naming the file.
    r = test::runVolcl("--quiet convert " + test::quoted(vcz) + " -o " + test::quoted(dir / "whole.nrrd"),
                       dir);
    EXPECT_EQ(r.exitCode, 1) << r.err;
    EXPECT_NE(r.err.find("huge.vcz"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("memory budget"), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(fs::exists(dir / "whole.nrrd"));

    // Rendered from its bricks with a TF that hides its (indexed) values: nothing decoded, a transparent image.
    test::writeFile(dir / "hide.json",
                    R"({"domain": [0, 1], "color": [[0, 1, 1, 1], [1, 1, 1, 1]],
                        "extinction": [[0, 0], [0.5, 0], [1, 1]]})");
    const std::string cam = " --width 32 --height 32 --tf-range 0,1 --lod auto --cache-mb 64 --stats";
    r = test::runVolcl("render --volume " + test::quoted(vcz) + " --tf " + test::quoted(dir / "hide.json") +
                           cam + " -o " + test::quoted(dir / "hidden.exr"),
                       dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.err.find("decoded 0"), std::string::npos) << r.err;
    const ImageBuffer img = readImage(dir / "hidden.exr");
    EXPECT_TRUE(std::all_of(img.pixels.begin(), img.pixels.end(), [](float v) { return v == 0.0f; }));

    // A TF that shows them decodes bricks (a crop box keeps one 64 MiB brick in the working set): their zero
    // payloads are refused naming the file and a brick.
    test::writeFile(
        dir / "show.json",
        R"({"domain": [0, 1], "color": [[0, 1, 1, 1], [1, 1, 1, 1]], "extinction": [[0, 1], [1, 1]]})");
    r = test::runVolcl("--quiet render --volume " + test::quoted(vcz) + " --tf " +
                           test::quoted(dir / "show.json") +
                           " --width 32 --height 32 --tf-range 0,1 --lod auto --cache-mb 128 --crop-box "
                           "10,10,10:100,100,100vox -o " +
                           test::quoted(dir / "shown.exr"),
                       dir);
    EXPECT_EQ(r.exitCode, 1) << r.err;
    EXPECT_NE(r.err.find("huge.vcz"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("brick"), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(fs::exists(dir / "shown.exr"));

    // What the brick path holds is budgeted: a pool as large as the whole frame is refused, naming the file.
    r = test::runVolcl("--quiet render --volume " + test::quoted(vcz) + " --tf " +
                           test::quoted(dir / "hide.json") +
                           " --width 32 --height 32 --tf-range 0,1 --lod auto --cache-mb 1000000 -o " +
                           test::quoted(dir / "pool.exr"),
                       dir);
    EXPECT_EQ(r.exitCode, 1) << r.err;
    EXPECT_NE(r.err.find("huge.vcz"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("brick pool"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir / "pool.exr"));
}

} // namespace

// A cloud generated straight into a .vcz (streamed brick row by brick row) renders from its bricks, with a
// cache holding only the clipped region's bricks, as that region decoded in full renders: the .vcz render is
// clipped to the region's box, the cropped volume's render needs no clip. A generate into a missing directory
// fails naming the file and leaves nothing.
TEST(CliBricks, StreamedCloudRendersAsACroppedRegion) {
    const fs::path dir = test::tempDir("cli_bricks_stream");
    test::writeFile(dir / "tf.json", kTf);
    test::RunResult r = test::runVolcl(
        "generate cloud --size 96,80,48 --seed 3 --frequency 3 -o " + test::quoted(dir / "cloud.vcz"), dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.err.find("peak RSS"), std::string::npos) << r.err;
    r = test::runVolcl(
        "generate cloud --size 96,80,48 --seed 3 --frequency 3 -o " + test::quoted(dir / "cloud.nrrd"), dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    r = test::runVolcl("compare " + test::quoted(dir / "cloud.vcz") + " " + test::quoted(dir / "cloud.nrrd") +
                           " --json",
                       dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("\"max_abs_error\": 0.0,"), std::string::npos) << r.out;

    r = test::runVolcl("decode " + test::quoted(dir / "cloud.vcz") + " --region 66,0,0:96,80,40 -o " +
                           test::quoted(dir / "crop.nrrd"),
                       dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const std::string cam = " --tf " + test::quoted(dir / "tf.json") +
                            " --tf-range 0,255 --width 64 --height 64" +
                            " --eye 150,-60,90 --target 81,40,20 --view-height 110";
    r = test::runVolcl("render --volume " + test::quoted(dir / "crop.nrrd") + cam + " -o " +
                           test::quoted(dir / "crop.exr"),
                       dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    // The region shares four faces with the volume: two planes clip the others. The bricks of x < 64 lie
    // wholly on the cut side (with the voxel their cells reach across): out of the working set.
    const std::string clip = " --clip 1,0,0,-66 --clip 0,0,-1,39";
    r = test::runVolcl("render --volume " + test::quoted(dir / "cloud.vcz") + cam + clip +
                           " --lod full --cache-mb 2 --stats -o " + test::quoted(dir / "clipped.exr"),
                       dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.err.find("bricks visited 2 (reachable 2,"), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find("coarsened"), std::string::npos) << r.err; // the budget holds the region at level 0
    // Float noise: the clipped march enters at the plane, the cropped one at its box (1.7e-6 measured).
    EXPECT_LE(maxAbs(dir / "crop.exr", dir / "clipped.exr"), 1e-5);

    r = test::runVolcl("generate cloud --size 40,40,20 -o " + test::quoted(dir / "missing" / "c.vcz"), dir);
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("c.vcz"), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(fs::exists(dir / "missing"));
}

namespace {

std::string fileText(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

} // namespace

// `encode --stream` reads raw, NRRD (gzip attached, raw detached) and NIfTI (.nii, .nii.gz, oriented int16)
// by slabs and writes the bytes the whole-volume encoder writes, once the padding of the preamble it
// reserved is dropped; truncated inputs are refused with one line
// naming the file and leave no output; inputs that cannot stream are refused with --stream.
TEST(CliBricks, StreamedEncodeEqualsTheWholeVolumeEncode) {
    const fs::path dir = test::tempDir("cli_bricks_stream_encode");
    writeBall(dir / "ball_40x36x30_uint8.raw", 0);
    writeBall(dir / "ball.nrrd", 1);
    writeBall(dir / "ball.nhdr", 2);
    writeBall(dir / "ball.nii", 3);
    writeBall(dir / "ball.nii.gz", 4);
    Volume i16({33, 20, 17}, ScalarType::Int16);
    for (std::size_t i = 0; i < i16.voxelCount(); ++i)
        i16.values<std::int16_t>()[i] = std::int16_t(int(i % 977) - 400);
    i16.spacing = {0.7, 1.1, 2.5};
    i16.origin = {-12, 3, 40};
    i16.direction = {0, -1, 0, 1, 0, 0, 0, 0, 1};
    i16.anatomical = true;
    writeVolumeFile(i16, dir / "oriented.nii.gz");
    for (const char* in : {"ball_40x36x30_uint8.raw", "ball.nrrd", "ball.nhdr", "ball.nii", "ball.nii.gz",
                           "oriented.nii.gz"}) {
        const std::string opts = " --brick 16 --levels 2 -o ";
        test::RunResult r =
            test::runVolcl("encode " + test::quoted(dir / in) + opts + test::quoted(dir / "whole.vcz"), dir);
        ASSERT_EQ(r.exitCode, 0) << in << r.err;
        EXPECT_EQ(r.err.find("streamed"), std::string::npos) << r.err; // small: the whole-volume encoder
        r = test::runVolcl(
            "encode --stream " + test::quoted(dir / in) + opts + test::quoted(dir / "streamed.vcz"), dir);
        ASSERT_EQ(r.exitCode, 0) << in << r.err;
        EXPECT_NE(r.err.find("streamed in"), std::string::npos) << r.err;
        const std::string streamed = fileText(dir / "streamed.vcz");
        const auto* first = reinterpret_cast<const std::byte*>(streamed.data());
        const std::vector<std::byte> unpadded =
            test::rewrittenVcz(std::vector<std::byte>(first, first + streamed.size()), "streamed.vcz");
        const std::string whole = fileText(dir / "whole.vcz");
        EXPECT_TRUE(unpadded.size() == whole.size() &&
                    std::memcmp(unpadded.data(), whole.data(), whole.size()) == 0)
            << in;
    }
    // Truncated raw data and a cut gzip stream: exit 1, one line naming the file, no output.
    const std::string raw = fileText(dir / "ball_40x36x30_uint8.raw");
    test::writeFile(dir / "cut_40x36x30_uint8.raw", raw.substr(0, raw.size() - 5));
    const std::string gz = fileText(dir / "ball.nii.gz");
    test::writeFile(dir / "cut.nii.gz", gz.substr(0, gz.size() / 2));
    for (const char* in : {"cut_40x36x30_uint8.raw", "cut.nii.gz"}) {
        const test::RunResult r = test::runVolcl(
            "encode --stream " + test::quoted(dir / in) + " -o " + test::quoted(dir / "cut.vcz"), dir);
        EXPECT_EQ(r.exitCode, 1) << in << r.err;
        EXPECT_NE(r.err.find(in), std::string::npos) << r.err;
        EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
        EXPECT_FALSE(fs::exists(dir / "cut.vcz")) << in;
    }
    // What the stream cannot code: named, exit 2.
    for (const std::string args : {"--max-error 2 " + test::quoted(dir / "ball.nrrd"),
                                   test::quoted(dir / "ball.nrrd") + " " + test::quoted(dir / "ball.nii")}) {
        const test::RunResult r =
            test::runVolcl("encode --stream " + args + " -o " + test::quoted(dir / "no.vcz"), dir);
        EXPECT_EQ(r.exitCode, 2) << args << r.err;
        EXPECT_NE(r.err.find("--stream"), std::string::npos) << r.err;
        EXPECT_FALSE(fs::exists(dir / "no.vcz"));
    }
}
