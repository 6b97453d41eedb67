// Fog: the ray marcher and the double reference against an analytic oracle (constant and exponential layers,
// empty box and with a volume inside, rays at several angles including parallel ones), and the hard cases.
#include "TestUtil.hpp"

#include "core/Error.hpp"
#include "core/Volume.hpp"
#include "host/image/ImageIo.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/Scene.hpp"
#include "render/VecMath.hpp"
#include "render/grid/GridRenderer.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <limits>
#include <string>
#include <vector>

namespace {

using namespace volcl;
using volcl::test::computeContext;
using volcl::test::makeFloatVolume;

constexpr double kInf = std::numeric_limits<double>::infinity();

/// Independent oracle of the fog model along one ray, in double. Fog depth from the antiderivative of the
/// density over height, G(h) = h below the base and base + H (1 - exp(-(h - base) / H)) above (H = 0: base),
/// so D = rho |G(h(t1)) - G(h(t0))| / |dh/dt|; a constant volume in its own box adds tau per unit length.
struct Oracle {
    double rho = 0.0, base = 0.0, H = 0.0;
    Vec3 up{0, 1, 0};
    Vec3 flo{0, 0, 0}, fhi{32, 32, 32}; ///< fog box
    Vec3 vlo{0, 0, 0}, vhi{32, 32, 32}; ///< volume box
    double tau = 0.0;                   ///< volume extinction (constant)
    Vec3 cv{0, 0, 0}, cf{1, 1, 1};      ///< volume and fog colours
    std::vector<double> mapCutsX;       ///< height map: x of texel edges (bases mapBase[i] between them)
    std::vector<double> mapBase;

    static bool clip(const Vec3& lo, const Vec3& hi, const Vec3& o, const Vec3& d, double& t0, double& t1) {
        t0 = 0.0;
        t1 = kInf;
        for (int a = 0; a < 3; ++a) {
            if (d[a] == 0.0) {
                if (o[a] < lo[a] || o[a] > hi[a]) return false;
            } else {
                const double u = (lo[a] - o[a]) / d[a], v = (hi[a] - o[a]) / d[a];
                t0 = std::max(t0, std::min(u, v));
                t1 = std::min(t1, std::max(u, v));
            }
        }
        return t1 > t0;
    }
    double G(double h, double b0) const {
        if (h <= b0) return h;
        return H == 0.0 ? b0 : b0 + H * -std::expm1(-(h - b0) / H);
    }
    double density(double h, double b0) const {
        if (h <= b0) return rho;
        return H == 0.0 ? 0.0 : rho * std::exp(-(h - b0) / H);
    }
    /// Fog depth over [ta, tb] (inside the fog box) with one base.
    double depthOneBase(const Vec3& o, const Vec3& d, double ta, double tb, double b0) const {
        if (!(tb > ta)) return 0.0;
        const double h0 = dot(o, up), b = dot(d, up);
        if (b == 0.0) return (tb - ta) * density(h0, b0);
        return rho * std::abs(G(h0 + b * tb, b0) - G(h0 + b * ta, b0)) / std::abs(b);
    }
    /// Fog depth from the ray's start to t.
    double fogDepth(const Vec3& o, const Vec3& d, double t) const {
        double f0, f1;
        if (!clip(flo, fhi, o, d, f0, f1)) return 0.0;
        const double a = f0, b = std::clamp(t, f0, f1);
        if (mapBase.empty()) return depthOneBase(o, d, a, b, base);
        // Split at the texel edges (planes x = const).
        std::vector<double> cuts{a, b};
        for (double x : mapCutsX)
            if (d[0] != 0.0) {
                const double tc = (x - o[0]) / d[0];
                if (tc > a && tc < b) cuts.push_back(tc);
            }
        std::sort(cuts.begin(), cuts.end());
        double D = 0.0;
        for (std::size_t i = 0; i + 1 < cuts.size(); ++i) {
            const double xm = o[0] + d[0] * 0.5 * (cuts[i] + cuts[i + 1]);
            std::size_t k = 0;
            while (k < mapCutsX.size() && xm >= mapCutsX[k])
                ++k;
            D += depthOneBase(o, d, cuts[i], cuts[i + 1], mapBase[k]);
        }
        return D;
    }
    /// (r, g, b, a) along the ray o + t d (d unit). Emission splits by parts: the volume's is
    /// c_v tau J with J = integral over the volume span of exp(-depth), the fog's c_f (alpha - tau J).
    std::array<double, 4> pixel(const Vec3& o, const Vec3& d) const {
        double v0 = 0.0, v1 = 0.0;
        const bool vol = tau > 0.0 && clip(vlo, vhi, o, d, v0, v1);
        auto volDepth = [&](double t) { return vol ? tau * std::max(0.0, std::min(t, v1) - v0) : 0.0; };
        const double total = fogDepth(o, d, kInf) + volDepth(kInf);
        const double alpha = -std::expm1(-total);
        double J = 0.0;
        if (vol) {
            // Composite 5-point Gauss-Legendre: the integrand is smooth inside the volume span, except at
            // the base crossing and texel edges, which sit on panel boundaries often enough at 4000 panels.
            static const double x[5] = {-0.9061798459386640, -0.5384693101056831, 0.0, 0.5384693101056831,
                                        0.9061798459386640};
            static const double w[5] = {0.2369268850561891, 0.4786286704993665, 0.5688888888888889,
                                        0.4786286704993665, 0.2369268850561891};
            const int panels = 4000;
            const double hp = (v1 - v0) / panels;
            for (int p = 0; p < panels; ++p)
                for (int i = 0; i < 5; ++i) {
                    const double t = v0 + hp * (p + 0.5 + 0.5 * x[i]);
                    J += 0.5 * hp * w[i] * std::exp(-(fogDepth(o, d, t) + volDepth(t)));
                }
        }
        const double fogShare = alpha - tau * J;
        std::array<double, 4> out{};
        for (int c = 0; c < 3; ++c)
            out[c] = cv[c] * tau * J + cf[c] * fogShare;
        out[3] = alpha;
        return out;
    }
};

TransferFunction constantTf(double tau, Vec3 c) {
    TransferFunction tf;
    tf.domain = {0.0, 1.0};
    tf.color = {{0.0, c}};
    tf.extinction = {{0.0, tau}};
    return tf;
}

/// Orthographic view of the box centre (16, 16, 16) along direction `dir`, 12 x 12 pixels over 48 units.
Scene view(const Vec3& dir, const Vec3& camUp, double step = 0.5) {
    Scene s;
    Camera c;
    c.target = {16, 16, 16};
    const Vec3 f = normalized(dir);
    c.eye = sub(c.target, scale(f, 100.0));
    c.up = camUp;
    c.height = 48.0;
    s.camera = c;
    s.width = 12;
    s.height = 12;
    s.step = step;
    s.earlyTermination = 1.0;
    return s;
}

FogEffect fogOf(const Oracle& o) {
    FogEffect f;
    f.enabled = true;
    f.density = o.rho;
    f.base = o.base;
    f.falloff = o.H;
    f.color = o.cf;
    f.up = o.up;
    f.box = WorldBox{o.flo, sub(o.fhi, o.flo)};
    return f;
}

struct ViewCase {
    const char* name;
    Vec3 dir, camUp;
};

/// Views from level (rays parallel to horizontal layers) to steep and straight down.
std::vector<ViewCase> views() {
    return {{"level along +z", {0, 0, 1}, {0, 1, 0}},
            {"level along -x", {-1, 0, 0}, {0, 1, 0}},
            {"15 deg down", {0, -std::sin(0.2618), std::cos(0.2618)}, {0, 1, 0}},
            {"45 deg up", {0.3, 1, 1}, {0, 1, 0}},
            {"80 deg down", {0.1, -1, 0.15}, {0, 0, 1}},
            {"straight down", {0, -1, 0}, {0, 0, 1}}};
}

/// Largest channel difference between an image and the oracle over all pixels.
double maxDiff(const ImageBuffer& img, const Scene& s, const Oracle& o) {
    double worst = 0.0;
    for (int y = 0; y < s.height; ++y)
        for (int x = 0; x < s.width; ++x) {
            const CameraRay ray = cameraRay(*s.camera, s.width, s.height, x, y);
            const auto want = o.pixel(ray.origin, ray.direction);
            for (int c = 0; c < 4; ++c) {
                const double got = img.at(x, y, c);
                EXPECT_TRUE(std::isfinite(got));
                worst = std::max(worst, std::abs(got - want[c]));
            }
        }
    return worst;
}

/// Kernel (point sampled; and 2D pre-integrated when `preint`) and reference against the oracle, every view.
void checkAgainstOracle(const Oracle& o, double tol, bool preint = true, bool reference = true) {
    const Volume vol = makeFloatVolume({33, 33, 33}, [](double, double, double) { return 0.5; });
    const TransferFunction tf = constantTf(o.tau, o.cv);
    for (const auto& v : views()) {
        SCOPED_TRACE(v.name);
        Scene s = view(v.dir, v.camUp);
        s.effects.fog = fogOf(o);
        GridRenderer r(computeContext(), vol, tf, s);
        ASSERT_TRUE(r.plan().fog) << r.plan().explain();
        const double point = maxDiff(r.render(), s, o);
        EXPECT_LE(point, tol) << "point sampled";
        std::cout << "  [fog oracle] " << v.name << ": max |kernel - oracle| " << point;
        if (preint) {
            Scene p = s;
            p.preintegration = Preintegration::Table2d;
            GridRenderer rp(computeContext(), vol, tf, p);
            const double pre = maxDiff(rp.render(), p, o);
            EXPECT_LE(pre, tol) << "pre-integrated";
            std::cout << ", 2D pre-integrated " << pre;
        }
        {
            // The scalar kernel too (unlit scenes run as 8-ray packets): shading on a constant field has no
            // normal, so ambient 0.5 + diffuse 0.5 under a unit light leaves every colour as it is.
            Scene l = s;
            l.lights = {{LightKind::Directional, {0.3, 0.5, -0.8}, {1, 1, 1}, 1.0}};
            l.effects.shading = true;
            l.effects.ambient = 0.5;
            l.effects.diffuse = 0.5;
            GridRenderer rl(computeContext(), vol, tf, l);
            ASSERT_TRUE(rl.plan().shading) << rl.plan().explain();
            const double scalar = maxDiff(rl.render(), l, o);
            EXPECT_LE(scalar, tol) << "scalar kernel";
            std::cout << ", scalar kernel " << scalar;
        }
        if (reference) {
            const double ref = maxDiff(referenceRender(vol, tf, s, {0.02, 0}), s, o);
            EXPECT_LE(ref, tol) << "reference";
            std::cout << ", double reference " << ref;
        }
        std::cout << '\n';
    }
}

TEST(Fog, ConstantLayerEmptyBox) {
    Oracle o;
    o.rho = 0.04;
    o.base = 12.0;
    o.H = 0.0; // constant below the base, nothing above
    o.cf = {0.9, 0.8, 0.7};
    checkAgainstOracle(o, 1e-4);
}

TEST(Fog, ExponentialLayerEmptyBox) {
    Oracle o;
    o.rho = 0.05;
    o.base = 10.0;
    o.H = 6.0;
    o.cf = {0.7, 0.8, 1.0};
    checkAgainstOracle(o, 1e-4);
}

TEST(Fog, ExponentialLayerTiltedUp) {
    Oracle o;
    o.rho = 0.05;
    o.base = 14.0;
    o.H = 4.0;
    o.up = normalized({0.3, 1.0, -0.2});
    o.cf = {1.0, 0.9, 0.6};
    checkAgainstOracle(o, 1e-4);
}

TEST(Fog, ConstantLayerWithVolume) {
    Oracle o;
    o.rho = 0.04;
    o.base = 12.0;
    o.H = 0.0;
    o.cf = {0.9, 0.9, 0.9};
    o.tau = 0.03;
    o.cv = {0.2, 0.4, 1.0};
    // The fog's box reaches beyond the volume's on every side: fog alone in front and behind.
    o.flo = {-6, -6, -6};
    o.fhi = {40, 40, 40};
    checkAgainstOracle(o, 1e-4);
}

TEST(Fog, ExponentialLayerWithVolume) {
    Oracle o;
    o.rho = 0.06;
    o.base = 8.0;
    o.H = 5.0;
    o.cf = {1.0, 0.7, 0.5};
    o.tau = 0.04;
    o.cv = {0.1, 0.5, 1.0};
    o.flo = {-6, -6, -6};
    o.fhi = {40, 40, 40};
    checkAgainstOracle(o, 1e-4);
}

TEST(Fog, FalloffHugeIsConstantFog) {
    Oracle o;
    o.rho = 0.03;
    o.base = 4.0;
    o.H = 1e30;
    o.tau = 0.02;
    o.cv = {0.3, 0.3, 1.0};
    checkAgainstOracle(o, 1e-4, false, false);
    // And equals fog of that density everywhere (base above the box).
    Oracle c = o;
    c.H = 0.0;
    c.base = 1000.0;
    checkAgainstOracle(c, 1e-4, false, false);
}

TEST(Fog, FalloffTinyIsASharpTop) {
    Oracle o;
    o.rho = 0.05;
    o.base = 12.0;
    o.H = 1e-6;
    o.tau = 0.02;
    o.cv = {0.3, 1.0, 0.3};
    checkAgainstOracle(o, 1e-4, false, false);
    Oracle sharp = o;
    sharp.H = 0.0; // the same image within the tolerance: 1e-6 of exponential tail
    checkAgainstOracle(sharp, 1e-4, false, false);
}

TEST(Fog, OpaqueInOneStep) {
    // Fog so dense the first step of every ray is opaque: finite, alpha 1, and the colour of what the ray
    // meets first. Same box: the media mixed by extinction; fog box one unit larger: the fog's colour alone.
    // With tau = 1e6 in the volume too, which medium a ray meets first depends on the last float bit of the
    // box entry, so only a convex mix of the two colours is required there.
    const Volume vol = makeFloatVolume({33, 33, 33}, [](double, double, double) { return 0.5; });
    const Vec3 cv{0.2, 0.4, 1.0}, cf{1.0, 0.5, 0.25};
    for (double tau : {0.0, 0.5, 1e6}) {
        SCOPED_TRACE("volume tau " + std::to_string(tau));
        const TransferFunction tf = constantTf(tau, cv);
        for (const auto& v : views()) {
            SCOPED_TRACE(v.name);
            for (double H : {0.0, 3.0})
                for (bool larger : {false, true}) {
                    SCOPED_TRACE(std::string(larger ? "fog box larger" : "same box") + ", H " +
                                 std::to_string(H));
                    Scene s = view(v.dir, v.camUp, 2.0);
                    Oracle o;
                    o.rho = 1e6;
                    o.base = H == 0.0 ? 1000.0 : 16.0; // H = 3: dense below 16, a tail above 1e3 at the top
                    o.H = H;
                    o.cf = cf;
                    o.flo = larger ? Vec3{-1, -1, -1} : Vec3{0, 0, 0};
                    o.fhi = larger ? Vec3{33, 33, 33} : Vec3{32, 32, 32};
                    s.effects.fog = fogOf(o);
                    GridRenderer r(computeContext(), vol, tf, s);
                    const ImageBuffer img = r.render();
                    for (int y = 0; y < s.height; ++y)
                        for (int x = 0; x < s.width; ++x) {
                            const CameraRay ray = cameraRay(*s.camera, s.width, s.height, x, y);
                            for (int c = 0; c < 4; ++c)
                                ASSERT_TRUE(std::isfinite(img.at(x, y, c)));
                            double t0, t1;
                            if (!Oracle::clip(o.flo, o.fhi, ray.origin, ray.direction, t0, t1)) continue;
                            const Vec3 p = add(ray.origin, scale(ray.direction, t0));
                            const double sf = o.density(dot(p, o.up), o.base);
                            if (sf < 1e5) continue; // entry point in the thinner tail: not opaque at once
                            EXPECT_NEAR(img.at(x, y, 3), 1.0, 1e-6);
                            for (int c = 0; c < 3; ++c) {
                                const double got = img.at(x, y, c);
                                if (larger || tau == 0.0) {
                                    EXPECT_NEAR(got, cf[c], 2e-3) << x << "," << y << " c" << c;
                                } else if (tau < 1e3) {
                                    EXPECT_NEAR(got, (cv[c] * tau + cf[c] * sf) / (tau + sf), 2e-3)
                                        << x << "," << y << " c" << c;
                                } else {
                                    EXPECT_GE(got, std::min(cv[c], cf[c]) - 1e-4);
                                    EXPECT_LE(got, std::max(cv[c], cf[c]) + 1e-4);
                                }
                            }
                        }
                }
        }
    }
}

TEST(Fog, SkippingAndEarlyTerminationKeepTheFog) {
    // Half the volume is empty (macrocells skipped): the fog over skipped cells must still be there.
    const Volume vol =
        makeFloatVolume({33, 33, 33}, [](double, double, double z) { return z < 16 ? 0.0 : 1.0; });
    TransferFunction tf;
    tf.domain = {0.0, 1.0};
    tf.color = {{0.0, {0.2, 0.5, 1.0}}};
    tf.extinction = {{0.0, 0.0}, {0.5, 0.0}, {1.0, 0.05}};
    Oracle o;
    o.rho = 0.05;
    o.base = 10.0;
    o.H = 6.0;
    for (const auto& v : views()) {
        SCOPED_TRACE(v.name);
        Scene s = view(v.dir, v.camUp);
        s.effects.fog = fogOf(o);
        s.skipping = SkipMode::On;
        GridRenderer skip(computeContext(), vol, tf, s);
        Scene ns = s;
        ns.skipping = SkipMode::Off;
        GridRenderer noSkip(computeContext(), vol, tf, ns);
        const ImageBuffer a = skip.render(), b = noSkip.render();
        double worst = 0.0;
        for (std::size_t i = 0; i < a.pixels.size(); ++i)
            worst = std::max(worst, double(std::abs(a.pixels[i] - b.pixels[i])));
        EXPECT_LE(worst, 1e-5);
        // And against the double reference (point sampling at step 0.5 vs fine steps: the volume's ramp).
        const ImageBuffer ref = referenceRender(vol, tf, ns, {0.02, 0});
        EXPECT_LE(imageRmse(a, ref), 2e-3);
    }
}

TEST(Fog, HeightMap) {
    // A 2 x 1 map: base 8 for x < 16, 20 for x >= 16 (rays crossing x = 16 change layer there).
    const auto dir = volcl::test::tempDir("fog_height_map");
    ImageBuffer map(2, 1, {"R", "G", "B"});
    map.at(0, 0, 0) = 8.0f / 32.0f;
    map.at(1, 0, 0) = 20.0f / 32.0f;
    for (int c = 1; c < 3; ++c) {
        map.at(0, 0, c) = map.at(0, 0, 0);
        map.at(1, 0, c) = map.at(1, 0, 0);
    }
    writeImage(map, dir / "top.exr");
    Oracle o;
    o.rho = 0.05;
    o.H = 3.0;
    o.tau = 0.02;
    o.cv = {0.2, 0.4, 1.0};
    o.mapCutsX = {16.0};
    o.mapBase = {8.0, 20.0};
    const Volume vol = makeFloatVolume({33, 33, 33}, [](double, double, double) { return 0.5; });
    const TransferFunction tf = constantTf(o.tau, o.cv);
    for (const auto& v : views()) {
        SCOPED_TRACE(v.name);
        Scene s = view(v.dir, v.camUp);
        s.effects.fog = fogOf(o);
        s.effects.fog.box.reset();
        s.effects.fog.heightMap = dir / "top.exr"; // range: the box's extent along up, [0, 32]
        GridRenderer r(computeContext(), vol, tf, s);
        ASSERT_TRUE(r.plan().fogMap);
        EXPECT_LE(maxDiff(r.render(), s, o), 1e-4);
        EXPECT_LE(maxDiff(referenceRender(vol, tf, s, {0.02, 0}), s, o), 2e-3); // midpoints straddle x = 16
    }
}

TEST(Fog, XrayAddsTheFogsDepth) {
    Oracle o;
    o.rho = 0.05;
    o.base = 10.0;
    o.H = 6.0;
    o.tau = 0.02;
    const Volume vol = makeFloatVolume({33, 33, 33}, [](double, double, double) { return 0.5; });
    const TransferFunction tf = constantTf(o.tau, {1, 1, 1});
    Scene s = view({0, -0.5, 1}, {0, 1, 0});
    s.mode = RenderMode::Xray;
    s.effects.fog = fogOf(o);
    GridRenderer r(computeContext(), vol, tf, s);
    const ImageBuffer img = r.render();
    for (int y = 0; y < s.height; ++y)
        for (int x = 0; x < s.width; ++x) {
            const CameraRay ray = cameraRay(*s.camera, s.width, s.height, x, y);
            const double a = o.pixel(ray.origin, ray.direction)[3];
            EXPECT_NEAR(img.at(x, y, 0), a, 1e-4);
        }
}

TEST(Fog, PlannerDropsWhatCannotShow) {
    const Volume vol = makeFloatVolume({9, 9, 9}, [](double, double, double) { return 0.5; });
    const TransferFunction tf = constantTf(0.1, {1, 1, 1});
    Scene s = view({0, 0, 1}, {0, 1, 0});
    s.effects.fog.enabled = true;
    s.effects.fog.density = 0.0;
    EXPECT_FALSE(planEffects(s, vol, tf).fog);
    s.effects.fog.density = 0.1;
    s.effects.fog.base = -5.0; // falloff 0, whole box above the base
    EXPECT_FALSE(planEffects(s, vol, tf).fog);
    s.effects.fog.base = 5.0;
    const EffectPlan p = planEffects(s, vol, tf);
    EXPECT_TRUE(p.fog);
    EXPECT_NE(p.defines.toOptions().find("-DFOG"), std::string::npos);
    s.mode = RenderMode::Mip;
    EXPECT_FALSE(planEffects(s, vol, tf).fog);
    // Not asked: not compiled.
    Scene plain = view({0, 0, 1}, {0, 1, 0});
    EXPECT_EQ(planEffects(plain, vol, tf).defines.toOptions().find("FOG"), std::string::npos);
}

TEST(Fog, BadParametersAreRefused) {
    auto refused = [](const std::string& fog, const std::string& field) {
        const std::string json = R"({"effects": {"fog": )" + fog + "}}";
        try {
            Scene::fromJson(json).validate();
            ADD_FAILURE() << "accepted " << fog;
        } catch (const UsageError& e) {
            EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
        }
    };
    refused(R"({"density": -0.1})", "effects.fog.density");
    refused(R"({"density": 0.1, "falloff": -2})", "effects.fog.falloff");
    refused(R"({"density": 0.1, "color": [1, -1, 0]})", "effects.fog.color");
    refused(R"({"density": 0.1, "up": [0, 0, 0]})", "effects.fog.up");
    refused(R"({"density": 0.1, "box": [[0, 0, 0], [1, -1, 1]]})", "effects.fog.box");
    refused(R"({"density": 0.1, "height_map": "m.png", "up": [0, 1, 1]})", "effects.fog.height_map");
    refused(R"({"density": 0.1, "falloff": 1e400})", "invalid JSON"); // beyond double: refused while parsing
    refused(R"({"density": 0.1, "colour": [1, 1, 1]})", "colour");
    // From a scene file the error names the file.
    const auto sceneDir = volcl::test::tempDir("fog_bad_scene");
    volcl::test::writeFile(sceneDir / "bad.json", R"({"effects": {"fog": {"density": -3}}})");
    try {
        Scene::fromFile(sceneDir / "bad.json");
        ADD_FAILURE() << "accepted a negative density from a file";
    } catch (const UsageError& e) {
        EXPECT_NE(std::string(e.what()).find("bad.json"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("effects.fog.density"), std::string::npos) << e.what();
    }
    // NaN cannot be written in JSON; from the API it is refused the same way.
    const double nan = std::numeric_limits<double>::quiet_NaN();
    for (int field = 0; field < 4; ++field) {
        Scene s;
        s.effects.fog.enabled = true;
        s.effects.fog.density = field == 0 ? nan : 0.1;
        s.effects.fog.falloff = field == 1 ? nan : 1.0;
        s.effects.fog.base = field == 2 ? nan : 0.0;
        s.effects.fog.color = {field == 3 ? nan : 1.0, 1, 1};
        EXPECT_THROW(s.validate(), UsageError) << "NaN field " << field;
    }
    // A height map holding NaN is a data error naming the file.
    const auto dir = volcl::test::tempDir("fog_bad_map");
    ImageBuffer map(2, 2, {"R"});
    map.pixels = {0.1f, std::numeric_limits<float>::quiet_NaN(), 0.2f, 0.3f};
    writeImage(map, dir / "nan.exr");
    const Volume vol = makeFloatVolume({9, 9, 9}, [](double, double, double) { return 0.5; });
    Scene s = view({0, 0, 1}, {0, 1, 0});
    s.effects.fog.enabled = true;
    s.effects.fog.density = 0.1;
    s.effects.fog.falloff = 1.0;
    s.effects.fog.heightMap = dir / "nan.exr";
    try {
        GridRenderer r(computeContext(), vol, constantTf(0.1, {1, 1, 1}), s);
        ADD_FAILURE() << "accepted a NaN height map";
    } catch (const DataError& e) {
        EXPECT_NE(std::string(e.what()).find("nan.exr"), std::string::npos) << e.what();
    }
}

TEST(Fog, SceneJsonRoundTrip) {
    const Scene s = Scene::fromJson(
        R"({"effects": {"fog": {"density": 0.2, "base": 3, "falloff": 2, "color": [0.5, 0.6, 0.7],
            "up": [0, 0, 1], "box": [[-1, -2, -3], [4, 5, 6]], "height_map": "top.png", "height_range": [1, 9]}}})");
    const Scene t = Scene::fromJson(s.toJson());
    const FogEffect& f = t.effects.fog;
    EXPECT_TRUE(f.enabled);
    EXPECT_EQ(f.density, 0.2);
    EXPECT_EQ(f.base, 3.0);
    EXPECT_EQ(f.falloff, 2.0);
    EXPECT_EQ(f.color, (Vec3{0.5, 0.6, 0.7}));
    EXPECT_EQ(f.up, (Vec3{0, 0, 1}));
    ASSERT_TRUE(f.box);
    EXPECT_EQ(f.box->origin, (Vec3{-1, -2, -3}));
    EXPECT_EQ(f.box->hi(), (Vec3{4, 5, 6}));
    EXPECT_EQ(f.heightMap, "top.png");
    ASSERT_TRUE(f.heightRange);
    EXPECT_EQ((*f.heightRange)[1], 9.0);
}

} // namespace
