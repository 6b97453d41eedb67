// `volcl bench render --filters`: what each reconstruction filter costs in time and buys in accuracy.
#pragma once

#include "core/runtime/ClRuntime.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/RenderInput.hpp"
#include "render/Scene.hpp"

#include <filesystem>

namespace volcl::cli {

/// Times linear (central differences and Sobel), cubic and bspline filters (the latter also on data
/// smoothed by sigma 0.7, 1 and 1.5 voxels), interleaved, as medians of
/// `runs` frames: on an 8-bit quantised sphere (normal and depth error against the analytic sphere) and on
/// `scene` over `input` (shading roughness, the terrace measure, against linear). Prints a table on stdout
/// and, when `csv` is not empty, writes its rows there.
void benchFilters(ComputeContext& cc, const RenderInput& input, const TransferFunction& tf,
                  const Scene& scene, int runs, const std::filesystem::path& csv);

} // namespace volcl::cli
