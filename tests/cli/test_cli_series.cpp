// `volcl encode` on series given as several files, a quoted glob, a .pvd or a 4D file; refusals; real
// series decoded frame by frame with `volcl decode --frame K` and compared bit for bit.
#include "../TestUtil.hpp"
#include "CliRun.hpp"
#include "host/io/VolumeIo.hpp"

#include <sys/wait.h>

#include <algorithm>
#include <fstream>
#include <sstream>

using namespace volcl;
namespace fs = std::filesystem;

namespace {

bool sameVoxels(const Volume& a, const Volume& b) {
    return a.dims() == b.dims() && a.type() == b.type() &&
           std::equal(a.bytes().begin(), a.bytes().end(), b.bytes().begin(), b.bytes().end());
}

// Decodes frames of `vcz` with --frame K (all, or those in `only`) and compares each with `frames[K]` bit for bit.
void expectFramesDecodeExactly(const fs::path& vcz, const std::vector<fs::path>& frames, const fs::path& dir,
                               std::vector<std::size_t> only = {}) {
    if (only.empty())
        for (std::size_t k = 0; k < frames.size(); ++k)
            only.push_back(k);
    for (std::size_t k : only) {
        const fs::path out = dir / ("frame_" + std::to_string(k) + ".nrrd");
        const test::RunResult d = test::runVolcl("decode " + test::quoted(vcz) + " --frame " +
                                                     std::to_string(k) + " -o " + test::quoted(out),
                                                 dir);
        ASSERT_EQ(d.exitCode, 0) << d.err;
        EXPECT_TRUE(sameVoxels(readVolume(out), readVolume(frames[k])))
            << "frame " << k << " of " << frames[k];
    }
}

std::vector<fs::path> writeFrames(const fs::path& dir, std::size_t n, Dims d = {9, 7, 5}) {
    std::vector<fs::path> out;
    for (std::size_t k = 0; k < n; ++k) {
        Volume v(d, ScalarType::UInt16);
        auto vals = v.values<std::uint16_t>();
        for (std::size_t i = 0; i < vals.size(); ++i)
            vals[i] = static_cast<std::uint16_t>((i * 37 + k * 5003) % 65536);
        out.push_back(dir / ("step_" + std::to_string(k) + ".nrrd"));
        writeVolumeFile(v, out.back());
    }
    return out;
}

} // namespace

TEST(CliSeries, EncodeTakesSeveralFilesAGlobAndAPvd) {
    const fs::path dir = test::tempDir("cli_series_forms");
    const auto frames = writeFrames(dir, 11); // step_10 sorts after step_9 only in natural order
    std::string list;
    for (const fs::path& f : frames)
        list += test::quoted(f) + " ";
    test::RunResult r = test::runVolcl("encode " + list + "-o " + test::quoted(dir / "list.vcz"), dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    expectFramesDecodeExactly(dir / "list.vcz", frames, dir, {0, 2, 10});

    r = test::runVolcl(
        "encode " + test::quoted(dir / "step_*.nrrd") + " -o " + test::quoted(dir / "glob.vcz"), dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_EQ(test::readFile(dir / "glob.vcz"), test::readFile(dir / "list.vcz"))
        << "the glob must give the list's frame order";

    std::ofstream pvd(dir / "run.pvd");
    pvd << "<VTKFile type=\"Collection\" version=\"0.1\"><Collection>\n";
    for (std::size_t k = 0; k < frames.size(); ++k)
        pvd << "<DataSet timestep=\"" << k << "\" part=\"0\" file=\"" << frames[k].filename().string()
            << "\"/>\n";
    pvd << "</Collection></VTKFile>\n";
    pvd.close();
    r = test::runVolcl("encode " + test::quoted(dir / "run.pvd") + " -o " + test::quoted(dir / "pvd.vcz"),
                       dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    expectFramesDecodeExactly(dir / "pvd.vcz", frames, dir, {1, 9}); // the .pvd's times are stored too
}

TEST(CliSeries, RefusalsExitOneWithOneLineAndNoOutput) {
    const fs::path dir = test::tempDir("cli_series_refusals");
    const auto frames = writeFrames(dir, 2);
    const fs::path odd = dir / "odd.nrrd";
    {
        Volume v({9, 7, 4}, ScalarType::UInt16);
        writeVolumeFile(v, odd);
    }
    std::ofstream(dir / "bad.pvd") << "<VTKFile type=\"Collection\"><Collection><DataSet timestep=\"0\" "
                                      "file=\"step_0.nrrd\"/><DataSet timestep=\"1\" file=\"nowhere.vti\"/>"
                                      "</Collection></VTKFile>";
    struct Case {
        std::string inputs, mustName;
    };
    for (const Case& c :
         {Case{test::quoted(frames[0]) + " " + test::quoted(frames[1]) + " " + test::quoted(odd),
               "frame 2 (" + odd.string()},
          Case{test::quoted(frames[0]) + " " + test::quoted(dir / "missing.nrrd"), "missing.nrrd"},
          Case{test::quoted(dir / "none_*.vti"), "none_*.vti"},
          Case{test::quoted(dir / "bad.pvd"), (dir / "nowhere.vti").string()}}) {
        const test::RunResult r =
            test::runVolcl("encode " + c.inputs + " -o " + test::quoted(dir / "out.vcz"), dir);
        EXPECT_EQ(r.exitCode, 1) << c.inputs << ": " << r.err;
        EXPECT_EQ(test::lineCount(r.err), 1u) << r.err;
        EXPECT_NE(r.err.find(c.mustName), std::string::npos) << r.err;
        EXPECT_FALSE(fs::exists(dir / "out.vcz"));
    }
    // The output among the inputs is a usage error, and the input stays untouched.
    const std::string before = test::readFile(frames[1]);
    const test::RunResult r = test::runVolcl("encode " + test::quoted(frames[0]) + " " +
                                                 test::quoted(frames[1]) + " -o " + test::quoted(frames[1]),
                                             dir);
    EXPECT_NE(r.exitCode, 0);
    EXPECT_EQ(test::readFile(frames[1]), before);
}

TEST(CliSeries, ViscousFingeringRoundTripsLosslessly) {
    fs::path data;
    VOLCL_REQUIRE_SHARED_DATA(data);
    const fs::path dir = test::tempDir("cli_series_viscous");
    const fs::path src = data / "timevarying/viscousfingers";
    std::vector<fs::path> frames;
    for (int k = 1; k <= 20; ++k) {
        char name[64];
        std::snprintf(name, sizeof name, "%03d_density_%03d_064_2.0.vti", k, k);
        frames.push_back(src / name);
    }
    const test::RunResult r = test::runVolcl("encode " + test::quoted(src / "*_density_*.vti") +
                                                 " --lossless -o " + test::quoted(dir / "vf.vcz"),
                                             dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    expectFramesDecodeExactly(dir / "vf.vcz", frames, dir);
}

TEST(CliSeries, IsabelGroupRoundTripsLosslessly) {
    fs::path data;
    VOLCL_REQUIRE_SHARED_DATA(data);
    const fs::path dir = test::tempDir("cli_series_isabel");
    const fs::path src = data / "timevarying/isabel";
    std::vector<fs::path> frames;
    std::string list;
    for (int k = 2; k <= 5; ++k) {
        frames.push_back(src / ("isabel_0" + std::to_string(k) + ".vti"));
        list += test::quoted(frames.back()) + " ";
    }
    const test::RunResult r =
        test::runVolcl("encode " + list + "-o " + test::quoted(dir / "isabel.vcz"), dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    expectFramesDecodeExactly(dir / "isabel.vcz", frames, dir);
    // The glob form gives the same file.
    const test::RunResult g = test::runVolcl(
        "encode " + test::quoted(src / "isabel_0*.vti") + " -o " + test::quoted(dir / "glob.vcz"), dir);
    ASSERT_EQ(g.exitCode, 0) << g.err;
    EXPECT_EQ(test::readFile(dir / "glob.vcz"), test::readFile(dir / "isabel.vcz"));
}

TEST(CliSeries, FourDimensionalNiftiEncodesEveryFrame) {
    fs::path data;
    VOLCL_REQUIRE_SHARED_DATA(data);
    const fs::path dir = test::tempDir("cli_series_nifti");
    const fs::path nii = data / "timevarying/functional.nii.gz";
    const test::RunResult r =
        test::runVolcl("encode " + test::quoted(nii) + " -o " + test::quoted(dir / "f.vcz"), dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const TimeSeries ts = readVolumeFile(nii);
    for (std::size_t k : {std::size_t(0), std::size_t(19)}) {
        const fs::path out = dir / "k.nrrd";
        const test::RunResult d = test::runVolcl("decode " + test::quoted(dir / "f.vcz") + " --frame " +
                                                     std::to_string(k) + " -o " + test::quoted(out),
                                                 dir);
        ASSERT_EQ(d.exitCode, 0) << d.err;
        EXPECT_TRUE(sameVoxels(readVolume(out), ts.frames[k])) << "frame " << k;
    }
}

TEST(CliSeries, MotionFramesInfoAndEveryFrameByPattern) {
    const fs::path dir = test::tempDir("cli_series_motion");
    std::vector<fs::path> frames;
    for (std::size_t k = 0; k < 6; ++k) {
        // A smooth field moving by one voxel per frame: P frames pay off.
        Volume v({24, 20, 12}, ScalarType::UInt16);
        auto vals = v.values<std::uint16_t>();
        for (std::size_t z = 0; z < 12; ++z)
            for (std::size_t y = 0; y < 20; ++y)
                for (std::size_t x = 0; x < 24; ++x)
                    vals[v.index(x, y, z)] =
                        static_cast<std::uint16_t>(2000 + 40 * (x + k) + 25 * y + 3 * z * z);
        frames.push_back(dir / ("m_" + std::to_string(k) + ".nrrd"));
        writeVolumeFile(v, frames.back());
    }
    test::RunResult r = test::runVolcl("encode " + test::quoted(dir / "m_*.nrrd") + " -o " +
                                           test::quoted(dir / "m.vcz") + " --gop 4 --b-frames 1",
                                       dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.err.find(" P, "), std::string::npos) << r.err;
    expectFramesDecodeExactly(dir / "m.vcz", frames, dir, {1, 3, 5});
    r = test::runVolcl("decode " + test::quoted(dir / "m.vcz") + " -o " + test::quoted(dir / "out_%02d.nrrd"),
                       dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    for (std::size_t k = 0; k < frames.size(); ++k)
        EXPECT_TRUE(
            sameVoxels(readVolume(dir / ("out_0" + std::to_string(k) + ".nrrd")), readVolume(frames[k])))
            << "frame " << k;
    const std::string info =
        std::string(VOLCL_EXE) + " info " + test::quoted(dir / "m.vcz") + " > " + (dir / "info.txt").string();
    ASSERT_EQ(std::system(info.c_str()), 0);
    const std::string text = test::readFile(dir / "info.txt");
    EXPECT_NE(text.find("(6 frames)"), std::string::npos) << text;
    EXPECT_NE(text.find(" I "), std::string::npos) << text;
    EXPECT_GE(test::lineCount(text), 6u + 7u) << text;
    for (const std::string bad : {"--motion sideways", "--gop 0"}) {
        r = test::runVolcl("encode " + test::quoted(dir / "m_*.nrrd") + " -o " +
                               test::quoted(dir / "bad.vcz") + " " + bad,
                           dir);
        EXPECT_EQ(r.exitCode, 2) << bad << ": " << r.err; // usage errors
        EXPECT_EQ(test::lineCount(r.err), 1u) << r.err;
        EXPECT_FALSE(fs::exists(dir / "bad.vcz"));
    }
}
