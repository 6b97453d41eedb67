// ParaView colour maps against VTK: colour spaces, normalised presets fitted to the data, opacity unit
// distance, built-in presets, colour-only defaults; ParaView 2D transfer functions from state files against pvbatch.
#include "TestUtil.hpp"

#include "core/Error.hpp"
#include "host/tf/BuiltinPresets.hpp"
#include "host/tf/ColorSpaces.hpp"
#include "host/tf/TransferFunction.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <sys/wait.h>

namespace {

using volcl::TransferFunction;

std::filesystem::path tmpDir() {
    std::filesystem::path d = std::filesystem::path(VOLCL_TEST_TMP_DIR) / "tf_paraview";
    std::filesystem::create_directories(d);
    return d;
}

struct VtkSamples {
    bool available = false;
    std::vector<std::array<double, 4>> xrgb;
};

/// Runs tests/vtk_ctf_reference.py (Debian's interpreter with python3-vtk9) on `json` rescaled to [lo, hi].
VtkSamples vtkColors(const std::string& name, std::string_view json, double lo, double hi, int n) {
    const auto file = tmpDir() / (name + ".json");
    std::ofstream(file) << json;
    std::ostringstream cmd;
    cmd << "/usr/bin/python3 " << VOLCL_SOURCE_DIR << "/tests/vtk_ctf_reference.py " << file << ' ' << lo
        << ' ' << hi << ' ' << n << " 2>&1";
    FILE* p = ::popen(cmd.str().c_str(), "r");
    VtkSamples out;
    if (!p) return out;
    std::string text;
    char buf[4096];
    while (std::size_t got = std::fread(buf, 1, sizeof buf, p))
        text.append(buf, got);
    const int status = ::pclose(p);
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
        if (!(WIFEXITED(status) && WEXITSTATUS(status) == 77))
            ADD_FAILURE() << "VTK reference failed: " << text;
        return out;
    }
    std::istringstream in(text);
    std::array<double, 4> v{};
    while (in >> v[0] >> v[1] >> v[2] >> v[3])
        out.xrgb.push_back(v);
    out.available = true;
    EXPECT_EQ(out.xrgb.size(), std::size_t(n));
    return out;
}

/// Largest channel difference between volcl (exact and kernel-float sampling) and VTK over [lo, hi].
void expectMatchesVtk(const std::string& name, std::string_view json, double lo, double hi, double tol,
                      int samples = 256) {
    const VtkSamples ref = vtkColors(name, json, lo, hi, samples);
    if (!ref.available) GTEST_SKIP() << "python3-vtk9 is not installed (import vtk failed): no VTK reference";
    const TransferFunction tf = TransferFunction::fromJson(json).fittedTo({lo, hi});
    const auto knots = tf.packKnots();
    double worstExact = 0.0, worstKernel = 0.0, worstAt = 0.0;
    for (const auto& [x, r, g, b] : ref.xrgb) {
        const auto c = tf.colorAt(x);
        const auto k = TransferFunction::sampleFloat(knots, float(x));
        const std::array<double, 3> want{r, g, b};
        for (int i = 0; i < 3; ++i) {
            if (std::abs(c[std::size_t(i)] - want[std::size_t(i)]) > worstExact) worstAt = x;
            worstExact = std::max(worstExact, std::abs(c[std::size_t(i)] - want[std::size_t(i)]));
            worstKernel = std::max(worstKernel, std::abs(double(k[std::size_t(i)]) - want[std::size_t(i)]));
        }
    }
    EXPECT_LE(worstExact, tol) << name << " at s = " << worstAt;
    EXPECT_LE(worstKernel, tol) << name;
    std::printf("%s: worst channel difference to VTK %.2e (exact), %.2e (kernel floats)\n", name.c_str(),
                worstExact, worstKernel);
}

TEST(ParaViewColorSpaces, CoolToWarmEqualsVtk) {
    // The preset as ParaView ships it (normalised, Diverging) spread over a uint8 data range.
    expectMatchesVtk("cool-to-warm", volcl::builtinPresetJson("cool-to-warm"), 0.0, 255.0, 1e-3);
}

TEST(ParaViewColorSpaces, NormalisedViridisEqualsVtk) {
    // The built-in preset (Lab) and ParaView's own copy of the table (Diverging, whose teal run crosses the
    // +-180 degree hue line and loops round the hue circle there, in VTK as here).
    const std::string lab(volcl::builtinPresetJson("viridis"));
    expectMatchesVtk("viridis", lab, -40.0, 1200.0, 1e-3);
    std::string diverging = lab;
    diverging.replace(diverging.find("\"Lab\""), 5, "\"Diverging\"");
    expectMatchesVtk("viridis-diverging", diverging, 0.0, 255.0, 1e-3);
    // 256 samples of a 256-point map fall on its points; 1001 land between them too.
    expectMatchesVtk("viridis-between", lab, -40.0, 1200.0, 1e-3, 1001);
    expectMatchesVtk("viridis-diverging-between", diverging, 0.0, 255.0, 1e-3, 1001);
}

TEST(ParaViewColorSpaces, HsvLabAndStepEqualVtk) {
    // Hue wrap (red to magenta the short way), grey end points, a dark toe in Lab, steps.
    expectMatchesVtk("hsv", R"({"ColorSpace": "HSV",
        "RGBPoints": [0, 1, 0, 0,  0.3, 0.9, 0.1, 0.8,  0.7, 0.5, 0.5, 0.5,  1, 0.1, 0.9, 0.3]})",
                     0.0, 1.0, 1e-3);
    expectMatchesVtk("lab", R"({"ColorSpace": "Lab",
        "RGBPoints": [0, 0.01, 0.0, 0.02,  0.5, 0.2, 0.8, 1.0,  1, 1, 0.9, 0.1]})",
                     0.0, 1.0, 1e-3);
    expectMatchesVtk("diverging-own", R"({"ColorSpace": "Diverging",
        "RGBPoints": [0, 0.0, 0.6, 0.2,  1, 0.8, 0.1, 0.7]})",
                     0.0, 1.0, 1e-3);
    expectMatchesVtk("step", R"({"ColorSpace": "Step",
        "RGBPoints": [0, 1, 0, 0,  0.25, 0, 1, 0,  1, 0, 0, 1]})",
                     0.0, 1.0, 1e-9);
}

TEST(ParaViewColorSpaces, DivergingPassesThroughWhite) {
    // Independent of VTK: two saturated ends with distant hues meet at a neutral near-white (Msh M >= 88).
    const auto mid = volcl::interpolateColor(volcl::ColorSpace::Diverging, {0.23, 0.299, 0.754},
                                             {0.706, 0.016, 0.150}, 0.5);
    EXPECT_NEAR(mid[0], mid[1], 0.02);
    EXPECT_NEAR(mid[1], mid[2], 0.02);
    EXPECT_GT(mid[0], 0.8);
    // Lab round trip and HSV round trip.
    const std::array<double, 3> c{0.3, 0.6, 0.9};
    const auto back = volcl::labToRgb(volcl::rgbToLab(c));
    const auto hsv = volcl::hsvToRgb(volcl::rgbToHsv(c));
    for (int i = 0; i < 3; ++i) {
        EXPECT_NEAR(back[std::size_t(i)], c[std::size_t(i)], 1e-3);
        EXPECT_NEAR(hsv[std::size_t(i)], c[std::size_t(i)], 1e-12);
    }
}

TEST(ParaViewImport, NormalisedPresetIsFittedToTheDataRange) {
    // Before: the [0, 1] map stayed on [0, 1], so uint8 data saw only its top colour and opacity.
    const TransferFunction tf = TransferFunction::fromJson(
        R"({"ColorSpace": "RGB", "RGBPoints": [0, 0, 0, 1, 1, 1, 0, 0], "Points": [0, 0, 0.5, 0, 1, 0.5, 0.5, 0]})");
    EXPECT_TRUE(tf.normalized);
    const TransferFunction fit = tf.fittedTo({0.0, 200.0});
    EXPECT_EQ(fit.domain, (std::array<double, 2>{0.0, 200.0}));
    EXPECT_NEAR(fit.colorAt(100.0)[0], 0.5, 1e-12);
    EXPECT_NEAR(fit.extinctionAt(200.0), std::log(2.0), 1e-12);
    EXPECT_NEAR(fit.extinctionAt(100.0), 0.5 * std::log(2.0), 1e-12);
    // Data inside [0, 1] is spread over too (issue #37: data in 1e-6..1e-4 saw only the map's bottom);
    // --tf-range wins over both.
    EXPECT_EQ(tf.fittedTo({0.0, 0.5}).domain, (std::array<double, 2>{0.0, 0.5}));
    EXPECT_EQ(tf.fittedTo({1.9e-6, 1.04e-4}).domain, (std::array<double, 2>{1.9e-6, 1.04e-4}));
    const std::array<double, 2> explicitRange{10.0, 20.0};
    EXPECT_EQ(tf.fittedTo({0.0, 200.0}, explicitRange).domain, explicitRange);
    // A map authored in data units is left alone.
    const TransferFunction own = TransferFunction::fromJson(
        R"({"RGBPoints": [0, 0, 0, 1, 100, 1, 0, 0], "Points": [0, 0, 0.5, 0, 100, 1, 0.5, 0]})");
    EXPECT_FALSE(own.normalized);
    EXPECT_EQ(own.fittedTo({0.0, 255.0}).domain, (std::array<double, 2>{0.0, 100.0}));
    // Constant data and bad ranges.
    EXPECT_EQ(tf.fittedTo({7.0, 7.0}).domain, (std::array<double, 2>{6.5, 7.5}));
    EXPECT_THROW(tf.rescaled({5.0, 5.0}), volcl::UsageError);
    EXPECT_THROW(tf.rescaled({0.0, NAN}), volcl::UsageError);
}

TEST(ParaViewImport, OpacityUnitDistance) {
    const char* pv =
        R"({"RGBPoints": [0, 1, 1, 1, 100, 1, 1, 1], "Points": [0, 0.5, 0.5, 0, 100, 0.5, 0.5, 0]})";
    // Opacity a over a unit distance d: tau = -ln(1 - a) / d, so a ray of length d keeps 1 - a.
    EXPECT_NEAR(TransferFunction::fromJson(pv).extinctionAt(50.0), std::log(2.0), 1e-12);
    EXPECT_NEAR(TransferFunction::fromJson(pv, 4.0).extinctionAt(50.0), std::log(2.0) / 4.0, 1e-12);
    EXPECT_THROW(TransferFunction::fromJson(pv, 0.0), volcl::UsageError);
    EXPECT_THROW(TransferFunction::fromJson(pv, -1.0), volcl::UsageError);
}

TEST(ParaViewImport, ColourOnlyPresetHasParaViewsDefaultOpacityRamp) {
    // Issue #37: a colour-only map (every built-in preset) gets ParaView's default opacity, 0 to 1 linear in
    // opacity over its colour range. Once (an earlier fix) a ramp linear in tau reached tau 1000 at once
    // and drew a solid blob; then a 0..0.1 ramp drew presets as a fog. Closed form: tau = -ln(1 - t).
    const TransferFunction tf = TransferFunction::fromJson(R"({"RGBPoints": [0, 0, 0, 0, 1, 1, 1, 1]})");
    EXPECT_EQ(tf.extinctionAt(0.0), 0.0);
    for (double t : {0.1, 0.25, 0.5, 0.75, 0.9})
        EXPECT_NEAR(tf.extinctionAt(t), -std::log1p(-t), 2e-4) << t;
    EXPECT_NEAR(tf.extinctionAt(1.0), volcl::kMaxImportedExtinction, 1e-9);
    // The same ramp as the default transfer function's.
    const TransferFunction ref = TransferFunction::paraViewDefault({0.0, 1.0}, 1.0);
    for (double t : {0.05, 0.3, 0.6, 0.95})
        EXPECT_NEAR(tf.extinctionAt(t), ref.extinctionAt(t), 1e-12) << t;
}

TEST(ParaViewImport, BuiltinPresets) {
    for (const auto& name : TransferFunction::builtinPresetNames()) {
        const TransferFunction tf = TransferFunction::fromFile("preset:" + name);
        EXPECT_TRUE(tf.normalized) << name;
        EXPECT_EQ(tf.domain, (std::array<double, 2>{0.0, 1.0})) << name;
        // ParaView's default opacity ramp (issue #37): opacity 1 at the top, half at the middle.
        EXPECT_NEAR(tf.maxExtinction(), volcl::kMaxImportedExtinction, 1e-9) << name;
        EXPECT_NEAR(tf.extinctionAt(0.5), std::log(2.0), 1e-12) << name;
        EXPECT_NO_THROW(tf.packKnots()) << name;
    }
    EXPECT_GE(TransferFunction::builtinPresetNames().size(), 5u);
    try {
        TransferFunction::fromFile("preset:nope");
        ADD_FAILURE() << "unknown preset accepted";
    } catch (const volcl::UsageError& e) {
        EXPECT_NE(std::string(e.what()).find("viridis"), std::string::npos) << e.what();
    }
}

TEST(ParaViewImport, UnknownColourSpaceNamed) {
    try {
        TransferFunction::fromJson(R"({"ColorSpace": "Lab/CIEDE2000", "RGBPoints": [0,0,0,1, 1,1,0,0]})");
        ADD_FAILURE() << "accepted";
    } catch (const volcl::DataError& e) {
        EXPECT_NE(std::string(e.what()).find("Lab/CIEDE2000"), std::string::npos) << e.what();
    }
    EXPECT_THROW(TransferFunction::fromJson(R"({"RGBPoints": [1,0,0,1, 0,1,0,0]})"), volcl::DataError);
}

} // namespace

TEST(ParaViewImport, DefaultTransferFunctionIsParaViewsGreyAndOpacityRamp) {
    // Closed form: over [lo, hi], colour grey t and opacity t per unit distance d, t = (s - lo) / (hi - lo),
    // so tau = -ln(1 - t) / d (ParaView's ramp is linear in opacity, not in extinction).
    const double lo = 20.0, hi = 220.0, d = 1.7;
    const TransferFunction tf = TransferFunction::paraViewDefault({lo, hi}, d);
    EXPECT_EQ(tf.domain, (std::array<double, 2>{lo, hi}));
    for (double t : {0.0, 0.1, 0.37, 0.5, 0.8, 0.9}) {
        const double s = lo + t * (hi - lo);
        for (double c : tf.colorAt(s))
            EXPECT_NEAR(c, t, 1e-12) << t;
        EXPECT_NEAR(tf.extinctionAt(s) * d, -std::log1p(-t), 2e-4) << t;
    }
    EXPECT_NEAR(tf.extinctionAt(hi) * d, volcl::kMaxImportedExtinction, 1e-9);
    // Constant data: a unit range centred on the value.
    EXPECT_EQ(TransferFunction::paraViewDefault({7.0, 7.0}, 1.0).domain, (std::array<double, 2>{6.5, 7.5}));
}

namespace {

/// Runs tests/paraview/tf2d_state.py in pvbatch (on a private Xvfb) into `dir`: ParaView's state file and its own
/// 2D function sampled at its texels. False, with the reason in `why`, when ParaView's Python is absent.
bool paraViewFunction2D(const std::filesystem::path& dir, std::string& why) {
    const std::filesystem::path modules = VOLCL_PARAVIEW_PYTHON;
    if (std::system("command -v pvbatch >/dev/null 2>&1") != 0) {
        why = "pvbatch is not installed";
        return false;
    }
    if (!std::filesystem::exists(modules / "paraview/simple.py")) {
        why = "ParaView's Python modules are not in " + modules.string() + " (scripts/paraview-python.sh)";
        return false;
    }
    std::filesystem::create_directories(dir);
    const std::string src = VOLCL_SOURCE_DIR;
    const std::string cmd = "PYTHONPATH='" + modules.string() + "' bash '" + src +
                            "/tests/paraview/with_xvfb.sh' pvbatch '" + src +
                            "/tests/paraview/tf2d_state.py' '" + dir.string() + "' >'" +
                            (dir / "log.txt").string() + "' 2>&1";
    const int status = std::system(cmd.c_str());
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0)
        << "pvbatch failed: " << volcl::test::readFile(dir / "log.txt");
    return true;
}

} // namespace

// A state saved by ParaView 5.11 with three boxes (two apart, one overlapping the second): volcl's reading of
// it against ParaView's own function of those boxes (vtkPVTransferFunction2D at 256 x 256 texels). ParaView
// draws each box as a 128 x 128 uint8 texture of its Gaussian, so opacities agree within the texel steps
// (1/255 and one box texel of the Gaussian's slope); colours are the box's within 1/255. Where boxes
// overlap, ParaView's "over" of opacities is a sum of extinctions, as volcl adds widgets.
TEST(ParaViewImport, TwoDimensionalStateMatchesParaViewsFunction) {
    const std::filesystem::path dir = tmpDir() / "tf2d_state";
    std::string why;
    if (!paraViewFunction2D(dir, why)) GTEST_SKIP() << why << ": no ParaView reference";
    const TransferFunction tf = TransferFunction::fromFile(dir / "state.pvsm");
    ASSERT_EQ(tf.widgets.size(), 3u);
    for (const auto& w : tf.widgets) {
        EXPECT_EQ(w.shape, volcl::TfWidgetShape::ParaViewBox);
        EXPECT_EQ(w.unitDistance, 2.5); // the representation's ScalarOpacityUnitDistance
    }
    EXPECT_EQ(tf.domain[0], 37.0);
    EXPECT_EQ(tf.domain[1], 277.0);
    std::ifstream in(dir / "function.txt");
    double s = 0, g = 0, r = 0, gr = 0, b = 0, a = 0;
    std::size_t texels = 0, inside = 0, overlap = 0;
    double worstAlpha = 0.0, worstColour = 0.0, worstOverlap = 0.0;
    // Texels within two box texels of an edge are left out: ParaView rounds box edges to its texels.
    auto nearEdge = [](const volcl::TfWidget& w, double x, double y) {
        const double ex = 2.0 * (w.valueRange[1] - w.valueRange[0]) / 128 + 240.0 / 256,
                     ey = 2.0 * (w.gradientRange[1] - w.gradientRange[0]) / 128 + 60.0 / 256;
        return std::abs(x - w.valueRange[0]) < ex || std::abs(x - w.valueRange[1]) < ex ||
               std::abs(y - w.gradientRange[0]) < ey || std::abs(y - w.gradientRange[1]) < ey;
    };
    while (in >> s >> g >> r >> gr >> b >> a) {
        ++texels;
        int covering = 0;
        bool edge = false;
        for (const auto& w : tf.widgets) {
            edge = edge || nearEdge(w, s, g);
            covering += w.extinction(s, g) > 0.0;
        }
        if (edge) continue;
        const auto c = tf.classify(s, g);
        const double alpha = 1.0 - std::exp(-c[3] * 2.5);
        if (covering == 0) {
            EXPECT_EQ(a, 0.0) << s << ", " << g;
            EXPECT_EQ(c[3], 0.0) << s << ", " << g;
        } else if (covering == 1) {
            ++inside;
            worstAlpha = std::max(worstAlpha, std::abs(alpha - a));
            worstColour =
                std::max({worstColour, std::abs(c[0] - r), std::abs(c[1] - gr), std::abs(c[2] - b)});
        } else {
            ++overlap;
            worstOverlap = std::max(worstOverlap, std::abs(alpha - a));
        }
    }
    EXPECT_EQ(texels, 256u * 256u);
    EXPECT_GT(inside, 5000u);
    EXPECT_GT(overlap, 500u);
    EXPECT_LT(worstAlpha, 0.02);
    EXPECT_LT(worstColour, 1.0 / 255 + 1e-6);
    EXPECT_LT(worstOverlap, 0.02);
    std::printf(
        "ParaView 2D function vs volcl: %zu texels in one box (opacity within %.4f, colour %.4f), %zu in "
        "two (opacity within %.4f)\n",
        inside, worstAlpha, worstColour, overlap, worstOverlap);
}

// A state volcl cannot read as one 2D function is refused with what it holds.
TEST(ParaViewImport, TwoDimensionalStateRefusals) {
    // A state file beyond 64 MiB is refused before it is read (a sparse file of 100 MiB).
    const std::filesystem::path big = tmpDir() / "big.pvsm";
    std::filesystem::remove(big);
    std::ofstream(big).close();
    std::filesystem::resize_file(big, std::uintmax_t(100) << 20);
    try {
        TransferFunction::fromFile(big);
        ADD_FAILURE() << "a 100 MiB state was read";
    } catch (const volcl::IoError& e) {
        EXPECT_NE(std::string(e.what()).find("more than the 64 MiB"), std::string::npos) << e.what();
    }
    std::filesystem::remove(big);
    auto state = [](const std::string& body) {
        return "<ParaView><ServerManagerState>" + body + "</ServerManagerState></ParaView>";
    };
    auto function = [](const std::string& id, const std::string& boxes) {
        std::string e;
        std::istringstream in(boxes);
        double v = 0;
        for (int i = 0; in >> v; ++i)
            e += "<Element index=\"" + std::to_string(i) + "\" value=\"" + std::to_string(v) + "\"/>";
        return "<Proxy group=\"transfer_2d_functions\" type=\"TransferFunction2D\" id=\"" + id +
               "\"><Property name=\"Boxes\">" + e + "</Property></Proxy>";
    };
    auto user = [](const std::string& id, int gradient) {
        return "<Proxy group=\"representations\" type=\"UniformGridRepresentation\" id=\"r" + id +
               "\"><Property name=\"UseTransfer2D\"><Element index=\"0\" value=\"1\"/></Property>"
               "<Property name=\"TransferFunction2D\"><Proxy value=\"" +
               id +
               "\"/></Property>"
               "<Property name=\"UseGradientForTransfer2D\"><Element index=\"0\" value=\"" +
               std::to_string(gradient) + "\"/></Property></Proxy>";
    };
    const std::string box = "10 1 20 3 1 0.5 0.2 0.6";
    // Read: one function, in use or the only one with boxes.
    EXPECT_EQ(TransferFunction::fromParaViewState(state(function("7", box) + user("7", 1)), "s.pvsm")
                  .widgets.size(),
              1u);
    EXPECT_EQ(TransferFunction::fromParaViewState(state(function("7", box) + function("8", "")), "s.pvsm")
                  .widgets.size(),
              1u);
    for (const auto& [xml, why] : std::vector<std::pair<std::string, std::string>>{
             {"<VTKFile/>", "not a ParaView state"},
             {state(""), "0 2D transfer functions"},
             {state(function("7", box) + function("8", box)), "2 2D transfer functions with boxes"},
             {state(function("7", box) + function("8", box) + user("7", 1) + user("8", 1)), "2 2D transfer"},
             {state(function("7", box) + user("7", 0)), "another array"},
             {state(function("7", "10 1 20 3 1 0.5 0.2")), "groups of 8"},
             {state(function("7", "10 1 20 3 1 1.5 0.2 0.6")), "outside [0, 1]"},
             {state(function("7", "10 1 0 3 1 0.5 0.2 0.6")), "zero width"},
         }) {
        try {
            TransferFunction::fromParaViewState(xml, "s.pvsm");
            ADD_FAILURE() << "accepted: " << xml;
        } catch (const volcl::Error& e) {
            EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
        }
    }
}
