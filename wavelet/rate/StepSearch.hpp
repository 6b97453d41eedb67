// The search on the base quantiser step shared by the psnr and bpv strategies: secant steps on log2(step)
// inside a shrinking bracket until the measured quantity falls into the target window.
#pragma once

#include "wavelet/rate/LossyFrame.hpp"

#include <functional>
#include <vector>

namespace volcl::codec {

/// What a search looks for. The measured quantity q (PSNR, or bits per voxel) falls as x = log2(step)
/// grows; the search ends once wlo <= q <= whi.
struct StepSearch {
    double guess = 0;        ///< first x
    double wlo = 0, whi = 0; ///< window of q that ends the search
    bool logScale = false;   ///< interpolate on log(q) (sizes, closer to linear in x) instead of q
    double slope = 0;        ///< change of the interpolated q per unit x, for the first step
    bool keepLargest =
        false; ///< among the trials that meet the target keep the largest x (else the smallest)
    /// Runs a trial at the frame's current steps: its q, whether it meets the target, and (optionally)
    /// the payloads it coded.
    std::function<bool(Trial& tr, BrickPayloads& payloads, double& q)> measure;
};

/// The kept trial, its steps and base step, and its payloads if the measure coded them.
struct SearchOutcome {
    bool found = false;
    Trial best;
    std::vector<double> steps;
    double delta = 0;
    BrickPayloads payloads;
};

SearchOutcome runStepSearch(LossyFrame& f, const StepSearch& s);

} // namespace volcl::codec
