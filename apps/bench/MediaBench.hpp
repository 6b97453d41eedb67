// `volcl bench render --tables`, `--fog` and `--gradient-tf`: the table paths against the per-sample paths, the
// fog's and a gradient TF's cost against the plain frame, in accuracy and time.
#pragma once

#include "core/runtime/ClRuntime.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/RenderInput.hpp"
#include "render/Scene.hpp"

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace volcl::cli {

/// For each step (world units): shaded dvr per sample (point sampling), 2D pre-integration lit at the segment
/// midpoint, and 2D pre-integration through the pre-integrated lighting table; then iso mode with the
/// scene's first iso-value (or the middle of the data range) by exact roots and by the iso-surface table.
/// Each against the double reference at `referenceStep` (RMSE over RGBA), median of `runs` frames, frames
/// interleaved. Prints a table and writes CSV rows when `csv` is not empty.
void benchTables(ComputeContext& cc, const RenderInput& input, const TransferFunction& tf, const Scene& scene,
                 const std::vector<double>& steps, double referenceStep, int runs,
                 const std::filesystem::path& csv);

/// The plain frame, and the scene with a constant and an exponential fog layer over the data's lower half
/// (point sampled and 2D pre-integrated), interleaved, median of `runs` frames; the fog's RMSE against the
/// double reference with fog. Prints a table and writes CSV rows when `csv` is not empty.
void benchFog(ComputeContext& cc, const RenderInput& input, const TransferFunction& tf, const Scene& scene,
              double referenceStep, int runs, const std::filesystem::path& csv);

/// A gradient TF's cost (`bench render --gradient-tf`): a 1D peer (`peer`, else the TF's value axis alone) at
/// the scene's step against the gradient TF at each of `steps` (world units), point sampled, no skipping,
/// interleaved, median of `runs` frames; each against the double reference of its own TF at `referenceStep`.
/// Prints a table with the load and writes CSV rows when `csv` is not empty.
void benchGradientTf(ComputeContext& cc, const RenderInput& input, const TransferFunction& tf,
                     const std::optional<TransferFunction>& peer, const Scene& scene,
                     const std::vector<double>& steps, double referenceStep, int runs,
                     const std::filesystem::path& csv);

} // namespace volcl::cli
