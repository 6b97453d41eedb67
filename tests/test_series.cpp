// Time-series input: natural order, globs, .pvd collections, 4D files, grid mismatches and bad paths.
#include "TestUtil.hpp"
#include "core/Error.hpp"
#include "host/io/Series.hpp"
#include "host/io/VolumeIo.hpp"

#include <fstream>

using namespace volcl;
namespace fs = std::filesystem;

namespace {

Volume frameVolume(Dims d, std::uint16_t seed) {
    Volume v(d, ScalarType::UInt16);
    auto vals = v.values<std::uint16_t>();
    for (std::size_t i = 0; i < vals.size(); ++i)
        vals[i] = static_cast<std::uint16_t>(seed * 1000 + i % 997);
    return v;
}

// Writes frames seed 0..n-1 as name_<k>.nrrd (no zero padding: natural order matters).
std::vector<fs::path> writeFrames(const fs::path& dir, std::size_t n, Dims d = {6, 5, 4}) {
    std::vector<fs::path> out;
    for (std::size_t k = 0; k < n; ++k) {
        out.push_back(dir / ("frame_" + std::to_string(k) + ".nrrd"));
        writeVolumeFile(frameVolume(d, static_cast<std::uint16_t>(k)), out.back());
    }
    return out;
}

void writeText(const fs::path& p, const std::string& text) {
    std::ofstream(p, std::ios::binary) << text;
}

std::uint16_t firstValue(const Volume& v) {
    return v.values<std::uint16_t>()[0];
}

} // namespace

TEST(Series, NaturalOrderComparesDigitRunsAsNumbers) {
    EXPECT_TRUE(naturalLess("frame_2", "frame_10"));
    EXPECT_FALSE(naturalLess("frame_10", "frame_2"));
    EXPECT_TRUE(naturalLess("a9b", "a10a"));
    EXPECT_TRUE(naturalLess("isabel_02", "isabel_3"));
    EXPECT_TRUE(naturalLess("x1", "x1y"));
    EXPECT_TRUE(naturalLess("run1_t9", "run1_t10"));
    EXPECT_TRUE(naturalLess("run1_t99", "run2_t1"));
    // Equal numbers: more leading zeros first, so the order is total and strict.
    EXPECT_TRUE(naturalLess("f007", "f7"));
    EXPECT_FALSE(naturalLess("f7", "f007"));
    EXPECT_FALSE(naturalLess("same", "same"));
    // Runs longer than any integer type still compare by value.
    EXPECT_TRUE(naturalLess("t99999999999999999999", "t100000000000000000000"));
}

TEST(Series, SeveralFilesKeepTheirOrder) {
    const fs::path dir = test::tempDir("series_files");
    const auto files = writeFrames(dir, 3);
    const std::vector<std::string> in{files[2].string(), files[0].string(), files[1].string()};
    const SeriesInput s = readSeriesInputs(in);
    ASSERT_EQ(s.series.frames.size(), 3u);
    EXPECT_EQ(firstValue(s.series.frames[0]), 2000);
    EXPECT_EQ(firstValue(s.series.frames[1]), 0);
    EXPECT_EQ(firstValue(s.series.frames[2]), 1000);
    EXPECT_EQ(s.sources[0].file, files[2]);
    EXPECT_TRUE(s.series.times.empty());
}

TEST(Series, GlobExpandsInNaturalOrder) {
    const fs::path dir = test::tempDir("series_glob");
    writeFrames(dir, 12); // frame_0 .. frame_11: byte order would put frame_10 before frame_2
    const std::vector<std::string> in{(dir / "frame_*.nrrd").string()};
    const SeriesInput s = readSeriesInputs(in);
    ASSERT_EQ(s.series.frames.size(), 12u);
    for (std::size_t k = 0; k < 12; ++k)
        EXPECT_EQ(firstValue(s.series.frames[k]), k * 1000) << "frame " << k;
    EXPECT_EQ(s.sources[2].file.filename(), "frame_2.nrrd");
    EXPECT_EQ(s.sources[10].file.filename(), "frame_10.nrrd");
    // Wildcards in a folder component too, and `?`.
    const auto files = expandGlob((dir.parent_path() / "series_gl?b" / "frame_1?.nrrd").string());
    ASSERT_EQ(files.size(), 2u);
    EXPECT_EQ(files[0].filename(), "frame_10.nrrd");
}

TEST(Series, EmptyGlobIsAnIoErrorNamingThePattern) {
    const fs::path dir = test::tempDir("series_glob_empty");
    const std::string pattern = (dir / "nothing_*.vti").string();
    try {
        readSeriesInputs(std::vector<std::string>{pattern});
        FAIL() << "an empty glob was accepted";
    } catch (const IoError& e) {
        EXPECT_NE(std::string(e.what()).find(pattern), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("matches no file"), std::string::npos) << e.what();
    }
}

TEST(Series, MissingFileIsAnIoErrorNamingIt) {
    const fs::path dir = test::tempDir("series_missing");
    const auto files = writeFrames(dir, 1);
    const std::string missing = (dir / "frame_9.nrrd").string();
    try {
        readSeriesInputs(std::vector<std::string>{files[0].string(), missing});
        FAIL() << "a missing file was accepted";
    } catch (const IoError& e) {
        EXPECT_NE(std::string(e.what()).find(missing), std::string::npos) << e.what();
    }
}

TEST(Series, MismatchedFramesAreRefusedNamingTheFrame) {
    const fs::path dir = test::tempDir("series_mismatch");
    const auto files = writeFrames(dir, 2);
    const fs::path odd = dir / "odd.nrrd";
    writeVolumeFile(frameVolume({6, 5, 3}, 7), odd);
    const fs::path typed = dir / "typed.nrrd";
    writeVolumeFile(frameVolume({6, 5, 4}, 7).convertedTo(ScalarType::Float32), typed);
    Volume spaced = frameVolume({6, 5, 4}, 7);
    spaced.spacing = {1, 1, 2};
    const fs::path spacedPath = dir / "spaced.nrrd";
    writeVolumeFile(spaced, spacedPath);
    Volume moved = frameVolume({6, 5, 4}, 7);
    moved.origin = {0, 3, 0};
    const fs::path movedPath = dir / "moved.nrrd";
    writeVolumeFile(moved, movedPath);
    struct Case {
        fs::path file;
        std::string what;
    };
    for (const Case& c : {Case{odd, "dims 6x5x3"}, Case{typed, "type float32"}, Case{spacedPath, "spacing"},
                          Case{movedPath, "origin"}}) {
        try {
            readSeriesInputs(std::vector<std::string>{files[0].string(), files[1].string(), c.file.string()});
            FAIL() << c.file << " was accepted";
        } catch (const DataError& e) {
            const std::string m = e.what();
            EXPECT_NE(m.find("frame 2 (" + c.file.string() + ")"), std::string::npos) << m;
            EXPECT_NE(m.find(c.what), std::string::npos) << m;
        }
    }
}

TEST(Series, PvdListsDataSetsInTimeOrderRelativeToItsFolder) {
    const fs::path dir = test::tempDir("series_pvd");
    fs::create_directories(dir / "steps");
    writeFrames(dir / "steps", 3);
    writeText(dir / "run.pvd", R"(<?xml version="1.0"?>
<VTKFile type="Collection" version="0.1">
  <Collection>
    <DataSet timestep="0.5" group="" part="0" file="steps/frame_1.nrrd"/>
    <DataSet timestep="0" group="" part="0" file="steps/frame_0.nrrd"/>
    <DataSet timestep="2.5" group="" part="0" file="steps/frame_2.nrrd"/>
  </Collection>
</VTKFile>
)");
    const SeriesInput s = readSeriesInputs(std::vector<std::string>{(dir / "run.pvd").string()});
    ASSERT_EQ(s.series.frames.size(), 3u);
    EXPECT_EQ(firstValue(s.series.frames[0]), 0);
    EXPECT_EQ(firstValue(s.series.frames[1]), 1000);
    EXPECT_EQ(firstValue(s.series.frames[2]), 2000);
    EXPECT_EQ(s.series.times, (std::vector<double>{0, 0.5, 2.5}));
}

TEST(Series, PvdWithABadPathNamesTheMissingFile) {
    const fs::path dir = test::tempDir("series_pvd_bad");
    writeFrames(dir, 1);
    writeText(dir / "run.pvd", R"(<VTKFile type="Collection"><Collection>
    <DataSet timestep="0" file="frame_0.nrrd"/><DataSet timestep="1" file="gone/frame_1.nrrd"/>
    </Collection></VTKFile>)");
    try {
        readSeriesInputs(std::vector<std::string>{(dir / "run.pvd").string()});
        FAIL() << "a .pvd naming a missing file was accepted";
    } catch (const IoError& e) {
        EXPECT_NE(std::string(e.what()).find((dir / "gone/frame_1.nrrd").string()), std::string::npos)
            << e.what();
    }
}

TEST(Series, MalformedPvdFilesAreIoErrors) {
    const fs::path dir = test::tempDir("series_pvd_malformed");
    struct Case {
        std::string text, what;
    };
    for (const Case& c :
         {Case{"<VTKFile type=\"Collection\"><Collection><DataSet file=\"a", "not a valid .pvd"},
          Case{"<VTKFile type=\"ImageData\"></VTKFile>", "not a ParaView collection"},
          Case{"<VTKFile type=\"Collection\"><Collection/></VTKFile>", "no DataSet"},
          Case{"<VTKFile type=\"Collection\"><Collection><DataSet timestep=\"0\"/>"
               "</Collection></VTKFile>",
               "no file attribute"},
          Case{"", "not a valid .pvd"}}) {
        writeText(dir / "x.pvd", c.text);
        try {
            readPvd(dir / "x.pvd");
            FAIL() << "accepted: " << c.text;
        } catch (const IoError& e) {
            EXPECT_NE(std::string(e.what()).find(c.what), std::string::npos) << e.what();
        }
    }
    // The DataSet files exist: readPvd checks each like a header's data file before the parts.
    writeText(dir / "a.vti", "");
    writeText(dir / "b.vti", "");
    writeText(dir / "parts.pvd", R"(<VTKFile type="Collection"><Collection>
    <DataSet timestep="0" part="0" file="a.vti"/><DataSet timestep="0" part="1" file="b.vti"/>
    </Collection></VTKFile>)");
    EXPECT_THROW(readPvd(dir / "parts.pvd"), DataError);
}

// The memory budget bounds the whole series: a .pvd of many files is refused at the frame that would
// pass it, naming that frame's file, before its voxels are allocated.
TEST(Series, TheMemoryBudgetCoversTheWholeSeries) {
    const fs::path dir = test::tempDir("series_budget");
    writeFrames(dir, 10, {16, 16, 16}); // 8 KiB of uint16 voxels each
    std::string pvd = "<VTKFile type=\"Collection\"><Collection>";
    for (int t = 0; t < 10; ++t)
        pvd +=
            "<DataSet timestep=\"" + std::to_string(t) + "\" file=\"frame_" + std::to_string(t) + ".nrrd\"/>";
    writeText(dir / "many.pvd", pvd + "</Collection></VTKFile>");
    const std::vector<std::string> inputs{(dir / "many.pvd").string()};
    ReadOptions options;
    // The NRRD reader may claim twice a frame while it reads one, so the last frame needs 2 x 8 KiB free.
    options.memoryBudget = 11 * 8192;
    EXPECT_EQ(readSeriesInputs(inputs, options).series.frames.size(), 10u);
    for (const std::size_t budget :
         {std::size_t{10 * 8192}, std::size_t{4 * 8192 + 100}, std::size_t{4 * 8192}}) {
        options.memoryBudget = budget;
        try {
            readSeriesInputs(inputs, options);
            FAIL() << "10 frames of 8 KiB were read within a budget of " << budget << " bytes";
        } catch (const IoError& e) {
            const std::string what = e.what();
            EXPECT_NE(what.find((dir / "frame_").string()), std::string::npos) << what;
            EXPECT_NE(what.find("memory budget"), std::string::npos) << what;
        }
    }
}

TEST(Series, FourDimensionalNiftiGivesEveryFrame) {
    fs::path data;
    VOLCL_REQUIRE_SHARED_DATA(data);
    const fs::path nii = data / "timevarying/functional.nii.gz";
    const SeriesInput s = readSeriesInputs(std::vector<std::string>{nii.string()});
    ASSERT_EQ(s.series.frames.size(), 20u);
    EXPECT_EQ(s.series.frames[0].dims(), (Dims{17, 21, 3}));
    EXPECT_EQ(s.sources[5].indexInFile, 5u);
    EXPECT_EQ(s.sources[5].describe(5), "frame 5 (" + nii.string() + ", volume 5)");
    // A 4D file after a 3D one of another grid: the message names the 4D file's frame.
    const fs::path dir = test::tempDir("series_4d_mix");
    const auto files = writeFrames(dir, 1);
    try {
        readSeriesInputs(std::vector<std::string>{files[0].string(), nii.string()});
        FAIL();
    } catch (const DataError& e) {
        EXPECT_NE(std::string(e.what()).find("frame 1 (" + nii.string() + ")"), std::string::npos)
            << e.what();
    }
}

TEST(Series, RealSeriesByGlobMatchesTheFileList) {
    fs::path data;
    VOLCL_REQUIRE_SHARED_DATA(data);
    const fs::path dir = data / "timevarying/isabel";
    const SeriesInput g = readSeriesInputs(std::vector<std::string>{(dir / "isabel_0*.vti").string()});
    ASSERT_EQ(g.series.frames.size(), 4u);
    for (std::size_t k = 0; k < 4; ++k) {
        EXPECT_EQ(g.sources[k].file.filename(), "isabel_0" + std::to_string(k + 2) + ".vti");
        EXPECT_EQ(g.series.frames[k], readVolume(dir / ("isabel_0" + std::to_string(k + 2) + ".vti")));
    }
}
