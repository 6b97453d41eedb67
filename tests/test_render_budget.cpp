// The frame-time budget planner and the measured effect costs, on a renderer with a known time law (no
// timing of real frames here: the budget's measured accuracy is in docs/media.md).
#include "host/Error.hpp"
#include "host/render/EffectCosts.hpp"
#include "host/render/EffectPlan.hpp"
#include "host/render/VecMath.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace {

using namespace volcl;

/// Frame time A + B / step (+ 50% with fog, + 1 ms with shading); every pixel 0.5 + C step^2 (a second-order
/// discretisation error).
class LawRenderer final : public VolumeRenderer {
public:
    static constexpr double A = 2.0, B = 3.0, C = 0.01;
    explicit LawRenderer(const Scene& s) { LawRenderer::setScene(s); }
    WorldBox bounds() const override { return {{0, 0, 0}, {63, 63, 63}}; }
    ValueRange valueRange() const override { return {0.0, 1.0}; }
    EffectPlan planEffects(const Scene& s) const override {
        return volcl::planEffects(s, bounds(), valueRange(), "none");
    }
    void setScene(const Scene& s) override {
        scene_ = s;
        plan_ = planEffects(s);
        camera_ = s.camera ? *s.camera : defaultCamera(bounds());
        ++sceneChanges;
    }
    void setTransferFunction(const TransferFunction&) override {}
    void setView(const Camera& c, int w, int h, double step) override {
        camera_ = c;
        scene_.width = w;
        scene_.height = h;
        scene_.step = step;
    }
    ImageBuffer render() override {
        ms_ = A + B / scene_.step * (plan_.fog ? 1.5 : 1.0) + (plan_.shading ? 1.0 : 0.0);
        ImageBuffer img(scene_.width, scene_.height, {"R", "G", "B", "A"});
        for (float& v : img.pixels)
            v = float(0.5 + C * scene_.step * scene_.step);
        return img;
    }
    const cl::Buffer& outputBuffer() const noexcept override {
        static const cl::Buffer none;
        return none;
    }
    const EffectPlan& plan() const noexcept override { return plan_; }
    const Scene& scene() const noexcept override { return scene_; }
    const Camera& camera() const noexcept override { return camera_; }
    double lastKernelMilliseconds() const noexcept override { return ms_; }
    double lastTableMilliseconds() const noexcept override { return 0.0; }
    std::string statistics() const override { return "law renderer"; }
    int sceneChanges = 0;

private:
    Scene scene_;
    Camera camera_;
    EffectPlan plan_;
    double ms_ = 0.0;
};

Scene baseScene() {
    Scene s;
    s.width = 16;
    s.height = 16;
    s.step = 0.5;
    return s;
}

TEST(Budget, PicksTheStepThatFits) {
    LawRenderer r(baseScene());
    const double budget = 14.0; // 2 + 3 / step = 14 at step 0.25
    const BudgetChoice c = fitBudget(r, budget, {stepKnob(r.scene(), r.bounds())}, 1);
    EXPECT_EQ(c.knob, "render.step");
    EXPECT_NEAR(c.value, 0.25, 1e-9);
    EXPECT_NEAR(c.predictedMs, budget, 1e-9);
    EXPECT_NEAR(c.measuredMs, budget, 1e-9);
    EXPECT_TRUE(c.met());
    // The error law fitted by doubling: C step^2 at the chosen step (RMSE of a uniform offset).
    EXPECT_NEAR(c.expectedError, LawRenderer::C * 0.25 * 0.25, 1e-6);
    EXPECT_NEAR(r.scene().step, 0.25, 1e-9) << "the renderer is left on the chosen scene";
    EXPECT_NE(c.text().find("render.step 0.25"), std::string::npos) << c.text();
}

TEST(Budget, CoarserWhenTheBudgetIsTight) {
    Scene s = baseScene();
    s.effects.fog.enabled = true;
    s.effects.fog.density = 0.1;
    s.effects.fog.falloff = 4.0;
    s.effects.fog.base = 30.0;
    LawRenderer r(s);
    const BudgetChoice c = fitBudget(r, 3.5, {stepKnob(r.scene(), r.bounds())}, 1); // 2 + 4.5 / step
    EXPECT_NEAR(c.value, 3.0, 1e-9);
    EXPECT_TRUE(c.met());
}

TEST(Budget, BelowTheFixedCostSaysSo) {
    LawRenderer r(baseScene());
    const BudgetChoice c = fitBudget(r, 1.0, {stepKnob(r.scene(), r.bounds())}, 1); // below A = 2 ms
    EXPECT_FALSE(c.met());
    EXPECT_EQ(c.value, stepKnob(baseScene(), r.bounds()).hi);
    bool said = false;
    for (const auto& n : c.notes)
        said = said || n.find("fixed cost") != std::string::npos;
    EXPECT_TRUE(said) << c.text();
    EXPECT_THROW(fitBudget(r, 0.0, {stepKnob(r.scene(), r.bounds())}), UsageError);
    EXPECT_THROW(fitBudget(r, -1.0, {stepKnob(r.scene(), r.bounds())}), UsageError);
    EXPECT_THROW(fitBudget(r, 5.0, {}), UsageError);
}

TEST(EffectCosts, OneLinePerCompiledEffectAndTheSceneRestored) {
    Scene s = baseScene();
    s.effects.fog.enabled = true;
    s.effects.fog.density = 0.1;
    s.effects.fog.base = 30.0;
    s.effects.shading = true;
    s.lights = {{LightKind::Directional, {0, 0, -1}, {1, 1, 1}, 1.0}};
    s.skipping = false;
    s.earlyTermination = 1.0;
    LawRenderer r(s);
    const CostReport rep = measureEffectCosts(r, 1);
    // plain: 2 + 3 / 0.5 = 8; frame: 2 + 9 + 1 = 12; without fog 9, without shading 11.
    EXPECT_DOUBLE_EQ(rep.plainMs, 8.0);
    EXPECT_DOUBLE_EQ(rep.frameMs, 12.0);
    ASSERT_EQ(rep.effects.size(), 2u);
    EXPECT_EQ(rep.effects[0].effect, "shading");
    EXPECT_DOUBLE_EQ(rep.effects[0].addedMs, 1.0);
    EXPECT_EQ(rep.effects[1].effect, "fog");
    EXPECT_DOUBLE_EQ(rep.effects[1].addedMs, 3.0);
    EXPECT_TRUE(r.scene().effects.fog.enabled);
    EXPECT_TRUE(r.scene().effects.shading);
    EXPECT_NE(rep.text().find("fog: +3.00 ms = +0.38 plain frames"), std::string::npos) << rep.text();
}

} // namespace
