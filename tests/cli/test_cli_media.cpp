// `volcl generate cloud` and multiple scattering through the binary: reproducible outputs, exit codes,
// one-line errors, no partial files.
#include "../TestUtil.hpp"
#include "CliRun.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/wait.h>

namespace {

TEST(CliMedia, GenerateCloudIsReproducibleInAnyFormat) {
    const auto dir = volcl::test::tempDir("cli_media_generate");
    const std::string a = (dir / "a.nrrd").string(), b = (dir / "b.nrrd").string();
    ASSERT_EQ(volcl::test::runVolcl("-q generate cloud --size 24,20,8 --seed 9 -o " + a, dir).exitCode, 0);
    ASSERT_EQ(volcl::test::runVolcl("-q generate cloud --size 24,20,8 --seed 9 -o " + b, dir).exitCode, 0);
    EXPECT_EQ(volcl::test::readFile(a), volcl::test::readFile(b));
    ASSERT_EQ(volcl::test::runVolcl("-q generate cloud --size 24,20,8 --seed 10 -o " + b, dir).exitCode, 0);
    EXPECT_NE(volcl::test::readFile(a), volcl::test::readFile(b));
    for (const char* ext : {".vti", ".nii.gz", ".vdb", ".raw"})
        EXPECT_EQ(volcl::test::runVolcl(
                      "-q generate cloud --size 8,8,4 -o " + (dir / (std::string("c") + ext)).string(), dir)
                      .exitCode,
                  0)
            << ext;
}

TEST(CliMedia, GenerateCloudRefusesBadArgumentsWithoutOutput) {
    const auto dir = volcl::test::tempDir("cli_media_refuse");
    const std::string out = (dir / "c.nrrd").string();
    for (const std::string bad : {"--coverage 0", "--coverage 1.5", "--erosion -1", "--octaves 40",
                                  "--size 0,4,4", "--preset nobody", "--frequency nan"}) {
        const volcl::test::RunResult r =
            volcl::test::runVolcl("generate cloud --size 8,8,8 " + bad + " -o " + out, dir);
        EXPECT_EQ(r.exitCode, 2) << bad;
        EXPECT_EQ(volcl::test::lineCount(r.err), 1u) << bad << ": " << r.err;
        EXPECT_FALSE(std::filesystem::exists(out)) << bad;
    }
    const volcl::test::RunResult fmt =
        volcl::test::runVolcl("generate cloud --size 8,8,8 -o " + (dir / "c.xyz").string(), dir);
    EXPECT_EQ(fmt.exitCode, 2);
    EXPECT_NE(fmt.err.find("c.xyz"), std::string::npos);
    const volcl::test::RunResult missing =
        volcl::test::runVolcl("generate cloud --size 8,8,8 -o " + (dir / "no" / "c.nrrd").string(), dir);
    EXPECT_EQ(missing.exitCode, 1);
    EXPECT_EQ(volcl::test::lineCount(missing.err), 1u);
}

/// A 24 x 24 x 8 generated cloud and a white TF in `dir`; returns "-q render --volume ... --tf ... " at
/// 16 x 16 pixels (empty if the cloud could not be generated).
std::string renderSmallCloud(const std::filesystem::path& dir) {
    const std::string vol = (dir / "c.nrrd").string(), tf = (dir / "tf.json").string();
    if (volcl::test::runVolcl("-q generate cloud --size 24,24,8 -o " + vol, dir).exitCode != 0) return {};
    volcl::test::writeFile(
        tf, R"({"domain": [0, 255], "color": [[0, 1, 1, 1]], "extinction": [[0, 0], [255, 0.5]]})");
    return "-q render --volume " + vol + " --tf " + tf + " --width 16 --height 16 ";
}

TEST(CliMedia, RenderMultipleScatteringAndRefusals) {
    const auto dir = volcl::test::tempDir("cli_media_render");
    const std::string base = renderSmallCloud(dir);
    ASSERT_FALSE(base.empty());
    const std::string a = (dir / "a.png").string(), b = (dir / "b.png").string(); // PNG: no timestamp
    ASSERT_EQ(volcl::test::runVolcl(
                  base + "--scattering 0.9,0.5 --scattering-order multiple --samples 4 -o " + a, dir)
                  .exitCode,
              0);
    ASSERT_EQ(volcl::test::runVolcl(
                  base + "--scattering 0.9,0.5 --scattering-order multiple --samples 4 -o " + b, dir)
                  .exitCode,
              0);
    EXPECT_EQ(volcl::test::readFile(a), volcl::test::readFile(b)); // same seed, same image
    const volcl::test::RunResult noScatter =
        volcl::test::runVolcl(base + "--scattering-order multiple -o " + a, dir);
    EXPECT_EQ(noScatter.exitCode, 2);
    EXPECT_EQ(volcl::test::lineCount(noScatter.err), 1u);
    const volcl::test::RunResult zero = volcl::test::runVolcl(
        base + "--scattering 0.9,0.5 --scattering-order multiple --samples 0 -o " + (dir / "z.exr").string(),
        dir);
    EXPECT_EQ(zero.exitCode, 2);
    EXPECT_FALSE(std::filesystem::exists(dir / "z.exr"));
}

TEST(CliMedia, FrameTimeBudgetChoosesOrRefusesWithoutOutput) {
    const auto dir = volcl::test::tempDir("cli_media_budget");
    const std::string cloud = renderSmallCloud(dir);
    ASSERT_FALSE(cloud.empty());
    const std::string base = cloud + "--scattering 0.9,0.5 ";
    // A reachable budget: the choice is reported (knob, route, expected error) and the image written.
    const volcl::test::RunResult ok =
        volcl::test::runVolcl(base + "--budget-ms 30 -o " + (dir / "ok.png").string(), dir);
    EXPECT_EQ(ok.exitCode, 0) << ok.err;
    EXPECT_TRUE(std::filesystem::exists(dir / "ok.png"));
    EXPECT_NE(ok.err.find("expected error: RMSE"), std::string::npos) << ok.err;
    EXPECT_NE(ok.err.find("instead: "), std::string::npos) << "both routes were weighed: " << ok.err;
    // Bad and unreachable budgets: exit 2, one line, nothing written.
    for (const std::string bad : {"-1", "nan", "inf", "1e-9"}) {
        const auto out = dir / "bad.png";
        const volcl::test::RunResult r =
            volcl::test::runVolcl(base + "--budget-ms " + bad + " -o " + out.string(), dir);
        EXPECT_EQ(r.exitCode, 2) << bad << ": " << r.err;
        EXPECT_EQ(volcl::test::lineCount(r.err), 1u) << bad << ": " << r.err;
        EXPECT_NE(r.err.find("budget_ms"), std::string::npos) << bad << ": " << r.err;
        EXPECT_FALSE(std::filesystem::exists(out)) << bad;
    }
}

} // namespace
