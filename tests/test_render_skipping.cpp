// Empty-space skipping chosen by measurement: the decision on injected timings, the grid renderer's use of it
// (plan, statistics, cache), and images equal with and without skipping at every macrocell edge.
#include "TestUtil.hpp"

#include "core/Volume.hpp"
#include "core/runtime/Timing.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/Scene.hpp"
#include "render/SkipChoice.hpp"
#include "render/grid/GridRenderer.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace {

using namespace volcl;
using volcl::test::computeContext;
using volcl::test::orthoScene;

// ---- the decision on injected timings ----

/// Probe times per edge, one list per edge consumed in call order (warm-up first), and the calls made.
struct ScriptedProbe {
    std::map<unsigned, std::vector<double>> times;
    std::vector<unsigned> calls;
    SkipProbeTimer timer() {
        return [this](unsigned edge) {
            calls.push_back(edge);
            std::vector<double>& t = times.at(edge);
            const double ms = t.front();
            if (t.size() > 1) t.erase(t.begin());
            return ms;
        };
    }
};

TEST(SkipChoice, InterleavesRoundsAfterOneWarmUpEachAndSkipsCandidatesWithNothingEmpty) {
    ScriptedProbe p;
    p.times = {{0, {5.0}}, {8, {4.0}}, {16, {6.0}}};
    const SkipDecision d = chooseSkipping({{8, 0.3}, {16, 0.2}, {32, 0.0}}, 3, p.timer());
    const std::vector<unsigned> expected{0, 8, 16, 0, 8, 16, 0, 8, 16, 0, 8, 16};
    EXPECT_EQ(p.calls, expected) << "32^3 has no empty cell: never measured";
    EXPECT_EQ(d.edge, 8u);
    EXPECT_EQ(d.rounds, 3);
    ASSERT_EQ(d.timings.size(), 3u);
    EXPECT_EQ(d.timings[0].candidate.edge, 0u);
}

TEST(SkipChoice, MediansIgnoreAnOutlierRound) {
    ScriptedProbe p;
    // Warm-up, then 5 rounds: off is 10 ms but one round hit a load spike (50 ms); 8^3 is 9 ms every round.
    p.times = {{0, {99.0, 10.0, 10.0, 50.0, 10.0, 10.0}}, {8, {99.0, 9.0}}};
    const SkipDecision d = chooseSkipping({{8, 0.4}}, 5, p.timer());
    EXPECT_EQ(d.edge, 8u);
    EXPECT_DOUBLE_EQ(d.timings[0].ms.median, 10.0);
    EXPECT_DOUBLE_EQ(d.timings[1].ms.median, 9.0);
}

TEST(SkipChoice, OffWhenSkippingCostsMoreThanItSaves) {
    ScriptedProbe p;
    p.times = {{0, {5.0}}, {8, {6.0}}, {16, {5.5}}, {32, {5.2}}};
    const SkipDecision d = chooseSkipping({{8, 0.35}, {16, 0.3}, {32, 0.2}}, 5, p.timer());
    EXPECT_EQ(d.edge, 0u);
    EXPECT_EQ(d.timings.size(), 4u);
}

TEST(SkipChoice, TiesGoToOffThenTheFinestEdge) {
    ScriptedProbe p;
    p.times = {{0, {5.0}}, {8, {5.0}}};
    EXPECT_EQ(chooseSkipping({{8, 0.5}}, 3, p.timer()).edge, 0u);
    ScriptedProbe q;
    q.times = {{0, {6.0}}, {8, {5.0}}, {16, {5.0}}};
    EXPECT_EQ(chooseSkipping({{8, 0.5}, {16, 0.4}}, 3, q.timer()).edge, 8u);
}

TEST(SkipChoice, NothingEmptyIsOffWithoutMeasuring) {
    ScriptedProbe p;
    const SkipDecision d = chooseSkipping({{8, 0.0}, {16, 0.0}}, 5, p.timer());
    EXPECT_EQ(d.edge, 0u);
    EXPECT_TRUE(p.calls.empty());
    EXPECT_EQ(d.text(), "off (auto: no macrocell is empty, nothing to skip)");
}

TEST(SkipChoice, TextStatesTheProbeRoundsAndEveryCandidate) {
    ScriptedProbe p;
    p.times = {{0, {4.1}}, {8, {4.52}}, {16, {3.91}}};
    SkipDecision d = chooseSkipping({{8, 0.35}, {16, 0.304}}, 5, p.timer());
    d.width = 96;
    d.height = 96;
    EXPECT_EQ(d.text(),
              "16^3-voxel macrocells (auto: 96x96 probe, medians of 5 interleaved rounds, kernel ms: "
              "off 4.10, 8^3 4.52 (35% empty), 16^3 3.91 (30% empty))");
}

TEST(MedianInterval, OrderStatisticsWithTheirCoverage) {
    // n = 9: [x(2), x(8)] covers 1 - 2 * 10/512 = 96.1 %.
    const MedianInterval nine = medianInterval({9, 1, 8, 2, 7, 3, 6, 4, 5});
    EXPECT_DOUBLE_EQ(nine.median, 5.0);
    EXPECT_DOUBLE_EQ(nine.lo, 2.0);
    EXPECT_DOUBLE_EQ(nine.hi, 8.0);
    EXPECT_NEAR(nine.level, 1.0 - 20.0 / 512.0, 1e-12);
    // n = 5 cannot reach 95 %: the whole range, 93.75 %.
    const MedianInterval five = medianInterval({-1, 2, 0.5, 3, 1});
    EXPECT_DOUBLE_EQ(five.lo, -1.0);
    EXPECT_DOUBLE_EQ(five.hi, 3.0);
    EXPECT_NEAR(five.level, 0.9375, 1e-12);
    EXPECT_TRUE(five.holdsZero());
    EXPECT_FALSE(nine.holdsZero());
}

// ---- the grid renderer on generated volumes ----

/// Cheap deterministic noise in [0, 1) per voxel.
double hashNoise(std::size_t i, std::size_t j, std::size_t k) {
    std::uint32_t h =
        std::uint32_t(i * 73856093u) ^ std::uint32_t(j * 19349663u) ^ std::uint32_t(k * 83492791u);
    h ^= h >> 13;
    h *= 0x5bd1e995u;
    h ^= h >> 15;
    return double(h & 0xffffu) / 65536.0;
}

Volume uint8Volume(Dims d, const std::function<double(double, double, double)>& f) {
    Volume v(d, ScalarType::UInt8);
    auto vals = v.values<std::uint8_t>();
    for (std::size_t k = 0; k < d.z; ++k)
        for (std::size_t j = 0; j < d.y; ++j)
            for (std::size_t i = 0; i < d.x; ++i)
                vals[v.index(i, j, k)] =
                    std::uint8_t(std::clamp(std::lround(f(double(i), double(j), double(k))), 0L, 255L));
    return v;
}

/// MRI-like: a head (skull shell, brain, ventricles) in a background of scanner noise up to 12, which
/// keeps most macrocells out of the empty set for a TF starting low.
Volume mriLike() {
    const Dims d{60, 70, 56};
    return uint8Volume(d, [](double x, double y, double z) {
        const double u = (x - 29.5) / 25.0, v = (y - 34.5) / 30.0, w = (z - 27.5) / 24.0;
        const double r = std::sqrt(u * u + v * v + w * w);
        const double noise = 12.0 * hashNoise(std::size_t(x), std::size_t(y), std::size_t(z));
        if (r > 1.0) return noise;
        if (r > 0.88) return 200.0 + noise; // skull
        const double vent = std::hypot((x - 29.5) / 5.0, (y - 38.0) / 9.0, (z - 27.5) / 6.0);
        return (vent < 1.0 ? 40.0 : 110.0 + 30.0 * u * v) + noise; // ventricles, grey/white matter
    });
}

/// Hydrogen-like: the 2p_z orbital's density r^2 exp(-r) cos^2(theta), mostly empty space.
Volume hydrogenLike() {
    const Dims d{64, 64, 64};
    return uint8Volume(d, [](double x, double y, double z) {
        const double px = (x - 31.5) / 3.0, py = (y - 31.5) / 3.0, pz = (z - 31.5) / 3.0;
        const double r2 = px * px + py * py + pz * pz;
        return 255.0 * pz * pz * std::exp(-std::sqrt(r2)) / (4.0 * std::exp(-2.0));
    });
}

TransferFunction tfOf(std::vector<ExtinctionPoint> extinction) {
    TransferFunction tf;
    tf.domain = {0.0, 255.0};
    tf.color = {{0.0, {0.2, 0.3, 1.0}}, {128.0, {1.0, 0.8, 0.3}}, {255.0, {1.0, 1.0, 1.0}}};
    tf.extinction = std::move(extinction);
    return tf;
}

struct NamedTf {
    const char* name;
    TransferFunction tf;
};

std::vector<NamedTf> hardTfs() {
    return {
        {"ramp", tfOf({{0.0, 0.0}, {20.0, 0.0}, {255.0, 0.4}})},
        {"ramp into the noise", tfOf({{0.0, 0.0}, {6.0, 0.0}, {255.0, 0.4}})},
        {"narrow spike", tfOf({{0.0, 0.0}, {109.5, 0.0}, {110.0, 3.0}, {110.5, 0.0}, {255.0, 0.0}})},
        {"all empty", tfOf({{0.0, 0.0}})},
        {"all opaque", tfOf({{0.0, 8.0}})},
    };
}

/// Injected probe timing that makes `edge` (0: off) the fastest.
SkipProbeTimer favour(unsigned edge) {
    return [edge](unsigned e) { return e == edge ? 1.0 : 2.0; };
}

float worstPixelDifference(const ImageBuffer& a, const ImageBuffer& b) {
    EXPECT_EQ(a.pixels.size(), b.pixels.size());
    float worst = 0.0f;
    for (std::size_t i = 0; i < std::min(a.pixels.size(), b.pixels.size()); ++i)
        worst = std::max(worst, std::abs(a.pixels[i] - b.pixels[i]));
    return worst;
}

Scene sceneFor(const Volume& v) {
    const Dims d = v.dims();
    Scene s = orthoScene(d, 1.1 * double(std::max(d.x, d.y)), 40, 40);
    s.step = 0.5;
    s.earlyTermination = 0.995;
    return s;
}

/// Every macrocell edge auto can choose, on and off: images equal within float rounding.
void expectEqualImagesAtEveryChoice(const Volume& v, const Scene& scene, const char* what) {
    for (const NamedTf& t : hardTfs()) {
        Scene off = scene;
        off.skipping = SkipMode::Off;
        GridRenderer r(computeContext(), v, t.tf, off);
        const ImageBuffer reference = r.render();
        Scene on = scene;
        on.skipping = SkipMode::On;
        r.setScene(on);
        EXPECT_LE(worstPixelDifference(r.render(), reference), 1e-6f) << what << ", " << t.name << ", on";
        Scene autoScene = scene;
        autoScene.skipping = SkipMode::Auto;
        for (unsigned edge : {0u, 8u, 16u, 32u}) {
            r.setSkipProbeTimer(favour(edge));
            r.setScene(autoScene);
            const SkipDecision& d = r.skipDecision();
            // A candidate without an empty cell is never measured, so it cannot be the favoured one.
            const bool measurable =
                edge == 0 || std::any_of(d.timings.begin(), d.timings.end(),
                                         [&](const SkipTiming& x) { return x.candidate.edge == edge; });
            if (measurable) EXPECT_EQ(d.edge, edge) << what << ", " << t.name;
            EXPECT_EQ(r.plan().skipping, d.edge != 0);
            EXPECT_LE(worstPixelDifference(r.render(), reference), 1e-6f)
                << what << ", " << t.name << ", auto favouring " << edge << ", chose " << d.text();
        }
    }
}

TEST(GridSkipping, ImagesEqualWithAndWithoutSkippingOnMriLike) {
    const Volume v = mriLike();
    const Scene s = sceneFor(v);
    expectEqualImagesAtEveryChoice(v, s, "mri-like point sampled (packet kernel)");
    Scene pre = s;
    pre.preintegration = Preintegration::Table2d;
    expectEqualImagesAtEveryChoice(v, pre, "mri-like 2d pre-integration");
}

TEST(GridSkipping, ImagesEqualWithAndWithoutSkippingOnHydrogenLike) {
    const Volume v = hydrogenLike();
    const Scene s = sceneFor(v);
    expectEqualImagesAtEveryChoice(v, s, "hydrogen-like point sampled (packet kernel)");
    Scene shaded = s;
    shaded.effects.shading = true;
    shaded.lights = {{LightKind::Directional, {0.3, 0.5, -0.8}, {1, 1, 1}, 1.0}};
    expectEqualImagesAtEveryChoice(v, shaded, "hydrogen-like shaded (per-ray kernel)");
    Scene cubic = s;
    cubic.filter = ReconstructionFilter::Cubic; // macrocells bounding the spline, merged for coarser edges
    expectEqualImagesAtEveryChoice(v, cubic, "hydrogen-like cubic filter");
}

TEST(GridSkipping, TheChoiceIsInThePlanAndStatistics) {
    const Volume v = hydrogenLike();
    const TransferFunction tf = hardTfs()[0].tf;
    Scene s = sceneFor(v);
    s.skipping = SkipMode::Off;
    GridRenderer r(computeContext(), v, tf, s);
    s.skipping = SkipMode::Auto;
    r.setSkipProbeTimer(favour(16));
    r.setScene(s);
    const auto has = [](const std::vector<std::string>& lines, const std::string& start) {
        return std::any_of(lines.begin(), lines.end(),
                           [&](const std::string& l) { return l.rfind(start, 0) == 0; });
    };
    EXPECT_TRUE(has(r.plan().compiled, "empty-space skipping: 16^3-voxel macrocells (auto: "))
        << r.plan().explain();
    EXPECT_NE(r.plan().defines.toOptions().find("-DSKIPPING"), std::string::npos);
    EXPECT_NE(r.statistics().find("skipping: 16^3-voxel macrocells (auto: "), std::string::npos)
        << r.statistics();

    r.setSkipProbeTimer(favour(0));
    r.setScene(s);
    EXPECT_FALSE(r.plan().skipping);
    EXPECT_FALSE(has(r.plan().compiled, "empty-space skipping"));
    EXPECT_TRUE(has(r.plan().dropped, "empty-space skipping: off (auto: ")) << r.plan().explain();
    EXPECT_EQ(r.plan().defines.toOptions().find("-DSKIPPING"), std::string::npos);

    s.skipping = SkipMode::On;
    r.setScene(s);
    EXPECT_TRUE(has(r.plan().compiled, "empty-space skipping: 8^3-voxel macrocells"));
    EXPECT_NE(r.statistics().find("skipping: 8^3-voxel macrocells (render.skipping on)"), std::string::npos)
        << r.statistics();
}

TEST(GridSkipping, TheChoiceIsCachedUntilTheTfChanges) {
    const Volume v = hydrogenLike();
    Scene s = sceneFor(v);
    GridRenderer r(computeContext(), v, hardTfs()[0].tf, s);
    int calls = 0;
    r.setSkipProbeTimer([&](unsigned e) {
        ++calls;
        return e == 8 ? 1.0 : 2.0;
    });
    r.setScene(s);
    const int first = calls;
    EXPECT_GT(first, 0);
    Camera moved = *s.camera;
    moved.eye[0] += 3.0;
    s.camera = moved;
    r.setScene(s); // a new camera, the same TF and effects: the cached choice
    EXPECT_EQ(calls, first);
    r.setTransferFunction(hardTfs()[1].tf);
    EXPECT_GT(calls, first) << "a new TF measures again";
    const int second = calls;
    r.setTransferFunction(hardTfs()[0].tf); // back to the first TF: still cached
    EXPECT_EQ(calls, second);
    EXPECT_EQ(r.skipDecision().edge, 8u);
}

} // namespace
