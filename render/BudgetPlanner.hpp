// The frame-time budget planner: probe frames calibrate each knob's time and error laws (and each route's
// bias against the Monte Carlo route), the knob and value that fit the budget at the lowest expected error
// are chosen, measured and corrected.
#pragma once

#include "render/BudgetKnob.hpp"

#include <cmath>
#include <cstddef>
#include <string>
#include <vector>

namespace volcl {

/// A knob's fitted laws: frame time A + B v^costExponent (ms); error sqrt(bias^2 + (C v^errorExponent)^2)
/// (RMSE of RGBA against the converged reference image).
struct KnobModel {
    double A = 0.0, B = 0.0;
    double C = 0.0;            ///< the knob's own error at value 1
    double bias = 0.0;         ///< the route's error that no value of the knob removes
    bool biasMeasured = false; ///< bias measured against a Monte Carlo route (else 0 and unknown)
    double timeMs(const BudgetKnob& k, double v) const { return A + B * std::pow(v, k.costExponent); }
    double knobError(const BudgetKnob& k, double v) const { return C * std::pow(v, k.errorExponent); }
    /// Capped at 1: RGBA lies in [0, 1], so more only says a law was extrapolated past its range.
    double error(const BudgetKnob& k, double v) const;
};

/// A value of one knob with its predicted frame time and expected error.
struct KnobPick {
    std::size_t knob = 0;
    double value = 0.0, predictedMs = 0.0, expectedError = 0.0;
};

/// The knob's value whose predicted time is nearest the budget, within [lo, hi] (integer knobs: the nearer
/// in time of the two whole neighbours).
KnobPick fitKnob(const BudgetKnob& knob, const KnobModel& model, double budgetMs);

/// How far off the budget a frame may be and still count as meeting it (a fraction of the budget).
inline constexpr double kBudgetTolerance = 0.2;

/// Each knob's fitted value; the choice is, among those predicted within `aim` of the budget, the one with
/// the lowest expected error, else the one nearest the budget. Throws UsageError for a budget that is not a
/// finite number > 0, for no knobs, and when no knob comes within `tolerance` of the budget (the message
/// gives the frame times each knob spans).
KnobPick chooseKnob(const std::vector<BudgetKnob>& knobs, const std::vector<KnobModel>& models,
                    double budgetMs, double aim = 0.1, double tolerance = kBudgetTolerance);

/// What the planner chose, the prediction, the measured frame and the expected error with its parts.
struct BudgetChoice {
    double budgetMs = 0.0;
    std::string knob, route;
    double value = 0.0;
    double predictedMs = 0.0, measuredMs = 0.0;
    double expectedError = 0.0, biasError = 0.0, knobError = 0.0;
    bool biasMeasured = false;
    std::string reference;           ///< the image the error is against
    std::vector<std::string> others; ///< what every other knob would have given
    struct Frame {
        std::string knob;
        double value = 0.0, ms = 0.0;
    };
    std::vector<Frame> probes;      ///< the calibration frames, knob by knob
    std::vector<std::string> notes; ///< the probes, fits and corrective frames, in order
    bool met(double tolerance = kBudgetTolerance) const {
        return std::abs(measuredMs - budgetMs) <= tolerance * budgetMs;
    }
    std::string text() const;
};

/// Calibrates every knob (two probe frames each, medians of `runs`), chooses (chooseKnob), then measures the
/// choice and, while it is more than 5% off, refits the knob's time law to all its frames by weighted least
/// squares and chooses again (at most three corrections, then the final fit measured once more; frames the
/// machine's load slowed are left out of the refit); the last measured choice is kept and the renderer is
/// left on it. Throws as chooseKnob does, and when the kept frame is over the tolerance and so is every
/// knob's fastest frame, measured.
BudgetChoice fitBudget(VolumeRenderer& renderer, double budgetMs, const std::vector<BudgetKnob>& knobs,
                       int runs = 3);

} // namespace volcl
