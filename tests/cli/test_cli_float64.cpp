// The volcl executable on float64 volumes: NIfTI, NRRD, npy and VTI kept as float64 through encode and
// decode (bit for bit lossless, every voxel within a bound), info, render's note, and the refusals.
#include "../TestUtil.hpp"
#include "CliRun.hpp"
#include "host/io/VolumeIo.hpp"

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>

using namespace volcl;

namespace {

// 20x17x11 doubles: a smooth field with detail below float32's precision, NaN, +/-Inf, -0, a float64
// subnormal and values beyond float32's range.
Volume adversarial() {
    Volume v({20, 17, 11}, ScalarType::Float64);
    auto s = v.values<double>();
    for (std::size_t i = 0; i < s.size(); ++i)
        s[i] = 50 * std::sin(0.05 * double(i)) + 1e-10 * double(i % 7);
    s[0] = std::bit_cast<double>(0x7ff8000000001234ull);
    s[1] = INFINITY;
    s[2] = -INFINITY;
    s[3] = -0.0;
    s[4] = 1e-310;
    s[5] = 1e300;
    s[6] = -1e-300;
    v.spacing = {0.5, 1, 2};
    return v;
}

bool bitsEqual(const Volume& a, const Volume& b) {
    if (a.type() != ScalarType::Float64 || b.type() != ScalarType::Float64 || a.dims() != b.dims())
        return false;
    for (std::size_t i = 0; i < a.voxelCount(); ++i)
        if (std::bit_cast<std::uint64_t>(a.values<double>()[i]) !=
            std::bit_cast<std::uint64_t>(b.values<double>()[i]))
            return false;
    return true;
}

} // namespace

TEST(CliFloat64, LosslessRoundTripIsBitExactThroughEveryFloat64Format) {
    const auto dir = test::tempDir("cli_float64_lossless");
    const Volume v = adversarial();
    for (const char* in : {"in.nii.gz", "in.nrrd", "in.npy", "in.vti"}) {
        writeVolumeFile(v, dir / in);
        const auto r =
            test::runVolcl("encode " + test::quoted(dir / in) + " -o " + test::quoted(dir / "v.vcz"), dir);
        ASSERT_EQ(r.exitCode, 0) << in << ": " << r.err;
        for (const char* out : {"out.nii", "out.nrrd", "out.npy"}) {
            const auto d = test::runVolcl(
                "decode " + test::quoted(dir / "v.vcz") + " -o " + test::quoted(dir / out), dir);
            ASSERT_EQ(d.exitCode, 0) << d.err;
            EXPECT_TRUE(bitsEqual(v, readVolume(dir / out))) << in << " -> " << out;
        }
    }
    const auto info = test::runVolcl("info " + test::quoted(dir / "v.vcz"), dir);
    EXPECT_TRUE(test::has(info.out, "float64")) << info.out;
}

TEST(CliFloat64, RelativeBoundsHoldOnEveryVoxelAndABitBudgetIsRefused) {
    const auto dir = test::tempDir("cli_float64_lossy");
    const Volume v = adversarial();
    writeVolumeFile(v, dir / "in.nrrd");
    for (const char* flags : {"--rel-error 1e-4", "--pw-rel-error 1e-3"}) {
        const auto r = test::runVolcl("encode " + test::quoted(dir / "in.nrrd") + " -o " +
                                          test::quoted(dir / "v.vcz") + " " + flags,
                                      dir);
        ASSERT_EQ(r.exitCode, 0) << r.err;
        ASSERT_EQ(test::runVolcl(
                      "decode " + test::quoted(dir / "v.vcz") + " -o " + test::quoted(dir / "o.nrrd"), dir)
                      .exitCode,
                  0);
        const Volume o = readVolume(dir / "o.nrrd");
        ASSERT_EQ(o.type(), ScalarType::Float64);
        const bool pointwise = std::string(flags).starts_with("--pw");
        double lo = INFINITY, hi = -INFINITY;
        for (double x : v.values<double>())
            if (std::isfinite(x)) lo = std::min(lo, x), hi = std::max(hi, x);
        std::size_t wrong = 0;
        for (std::size_t i = 0; i < v.voxelCount(); ++i) {
            const double x = v.values<double>()[i], y = o.values<double>()[i];
            if (!std::isfinite(x) || x == 0)
                wrong += std::bit_cast<std::uint64_t>(x) != std::bit_cast<std::uint64_t>(y) &&
                         !(x == 0 && !pointwise && std::abs(y) <= 1e-4 * hi - 1e-4 * lo);
            else
                wrong += !(std::abs(x - y) <= (pointwise ? 1e-3 * std::abs(x) : 1e-4 * hi - 1e-4 * lo));
        }
        EXPECT_EQ(wrong, 0u) << flags;
    }
    const auto b = test::runVolcl(
        "encode " + test::quoted(dir / "in.nrrd") + " -o " + test::quoted(dir / "b.vcz") + " --bpv 2", dir);
    EXPECT_EQ(b.exitCode, 2);
    EXPECT_TRUE(test::has(b.err, "float64")) << b.err;
    EXPECT_FALSE(std::filesystem::exists(dir / "b.vcz"));
}
