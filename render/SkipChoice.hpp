// Empty-space skipping chosen by measurement: "off" and candidate macrocell edges timed on a probe frame in
// interleaved rounds; the lowest median wins.
#pragma once

#include "core/runtime/Timing.hpp"

#include <functional>
#include <string>
#include <vector>

namespace volcl {

/// One way to run a frame: skipping off (edge 0) or on with macrocells of `edge` voxels, `emptyFraction` of
/// them empty for the scene's TF.
struct SkipCandidate {
    unsigned edge = 0;
    double emptyFraction = 0.0;
};

/// A candidate and its probe frame times (kernel ms).
struct SkipTiming {
    SkipCandidate candidate;
    MedianInterval ms;
};

/// The chosen way and what it was chosen on.
struct SkipDecision {
    unsigned edge = 0;               ///< voxels per macrocell edge; 0: skipping off
    int width = 0, height = 0;       ///< the probe frame (0: nothing was measured)
    int rounds = 0;                  ///< interleaved rounds per candidate
    std::vector<SkipTiming> timings; ///< off first, then the candidates measured
    std::string unmeasured;          ///< why nothing was measured ("auto: no macrocell is empty, ...")
    /// "16^3-voxel macrocells (auto: 96x96 probe, medians of 5 interleaved rounds, kernel ms: off 4.10,
    /// 8^3 4.52 (35% empty), ...)".
    std::string text() const;
};

/// Times one probe frame of skipping with macrocells of `edge` voxels (0: off), in kernel ms. The renderer
/// launches the probe; tests inject timings here.
using SkipProbeTimer = std::function<double(unsigned edge)>;

/// Measures off and every candidate that has an empty macrocell (one without any can only cost): a warm-up
/// frame each (kernel builds excluded), then `rounds` interleaved rounds; the lowest median wins, off and then
/// the smaller edge on ties. No candidate with an empty cell: off, unmeasured. The probe size is the caller's
/// to fill in.
SkipDecision chooseSkipping(const std::vector<SkipCandidate>& candidates, int rounds,
                            const SkipProbeTimer& time);

} // namespace volcl
