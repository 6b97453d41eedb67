// The viewer's frame-time controller: proportional work update and the step/resolution split.
#include "apps/viewer/AdaptiveQuality.hpp"

#include "core/Error.hpp"

#include <algorithm>
#include <cmath>

namespace volcl::viewer {

AdaptiveQuality::AdaptiveQuality(const AdaptiveQualityOptions& options) : options_(options) {
    if (!(options_.targetMs > 0.0) || !std::isfinite(options_.targetMs))
        throw UsageError("adaptive quality: target frame time must be a positive number of milliseconds");
    if (!(options_.aimFraction > 0.0 && options_.aimFraction <= 1.0))
        throw UsageError("adaptive quality: aim fraction must be in (0, 1]");
    if (!(options_.minResolutionScale > 0.0 && options_.minResolutionScale <= 1.0))
        throw UsageError("adaptive quality: minimum resolution scale must be in (0, 1]");
    if (!(options_.maxStepScale >= 1.0) || !std::isfinite(options_.maxStepScale))
        throw UsageError("adaptive quality: maximum step scale must be >= 1");
    if (!(options_.maxGrowth > 1.0))
        throw UsageError("adaptive quality: maximum growth per frame must exceed 1");
    if (!(options_.minFaceFraction > 0.0 && options_.minFaceFraction <= 1.0))
        throw UsageError("adaptive quality: minimum face fraction must be in (0, 1]");
    if (options_.stepLevelsPerOctave < 1)
        throw UsageError("adaptive quality: step levels per octave must be >= 1");
}

double AdaptiveQuality::minWork() const noexcept {
    const double r2 = options_.minResolutionScale * options_.minResolutionScale;
    return options_.faceLevels ? r2 * options_.minFaceFraction : r2 / options_.maxStepScale;
}

QualityLevel AdaptiveQuality::split(double work) const {
    work = std::clamp(work, minWork(), 1.0);
    QualityLevel q;
    if (options_.faceLevels) {
        // Faces first: dropping internal faces keeps every pixel (the boundary is always drawn), a lower
        // resolution loses them all.
        q.faceFraction = std::clamp(work, options_.minFaceFraction, 1.0);
        q.resolutionScale = std::clamp(std::sqrt(work / q.faceFraction), options_.minResolutionScale, 1.0);
        return q;
    }
    // Equal shares in log scale: r^2 / s = w with s = w^-1/2 gives r = w^1/4.
    const double levels = options_.stepLevelsPerOctave;
    const double wantStep = std::clamp(1.0 / std::sqrt(work), 1.0, options_.maxStepScale);
    // Round the step down to the ladder so the resolution, which is continuous, absorbs the remainder.
    q.stepScale =
        std::min(options_.maxStepScale, std::exp2(std::floor(std::log2(wantStep) * levels + 1e-9) / levels));
    q.resolutionScale = std::clamp(std::sqrt(work * q.stepScale), options_.minResolutionScale, 1.0);
    return q;
}

QualityLevel AdaptiveQuality::next() const {
    if (!options_.enabled) return {};
    return split(work_);
}

void AdaptiveQuality::report(const QualityLevel& used, double frameMs) {
    if (!options_.enabled || !(frameMs > 0.0) || !std::isfinite(frameMs)) return;
    // Cost of the whole frame per unit of work, smoothed over frames (geometric mean, weight 1/2): sizing
    // from the last frame alone feeds its noise straight into the next level, so a frame's time became
    // the ratio of two noisy samples and overshot by 20 % three times as often. A frame over twice the
    // target is not noise: its cost replaces the estimate, so a jump in cost is cut at once.
    const double cost = frameMs / used.work();
    const bool jump = (!reported_ && !seeded_) || frameMs > 2.0 * options_.targetMs;
    logCost_ = jump ? std::log(cost) : 0.5 * logCost_ + 0.5 * std::log(cost);
    const double wanted = options_.aimFraction * options_.targetMs / std::exp(logCost_);
    work_ = std::clamp(std::min(wanted, used.work() * options_.maxGrowth), minWork(), 1.0);
    reported_ = true;
}

void AdaptiveQuality::seed(double fullQualityMs) {
    if (reported_ || !(fullQualityMs > 0.0) || !std::isfinite(fullQualityMs)) return;
    logCost_ = std::log(fullQualityMs);
    seeded_ = true;
    work_ = std::clamp(options_.aimFraction * options_.targetMs / fullQualityMs, minWork(), 1.0);
}

} // namespace volcl::viewer
