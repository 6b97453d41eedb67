// `volcl bench render --scatter-sweep`: single and multiple scattering against a converged path-traced
// reference: time per frame, cost relative to the plain frame, error against samples.
#pragma once

#include "core/runtime/ClRuntime.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/RenderInput.hpp"
#include "render/Scene.hpp"

#include <filesystem>

namespace volcl::cli {

struct ScatterBenchOptions {
    int runs = 3;                   ///< timed frames per configuration (median)
    int referenceSamples = 1024;    ///< samples per pixel of the converged reference
    int maxSamples = 256;           ///< largest sample count of the convergence sweep (powers of 2 from 1)
    std::filesystem::path csv;      ///< rows: variant, samples, ms, cost, rmse (empty: none)
    std::filesystem::path imageDir; ///< EXR and PNG (over the background) of every variant (empty: none)
};

/// The scene's scattering (or, when it asks for none, a cloud-like medium: albedo 0.95, g 0.6, no emission,
/// a sun and a faint sky) rendered as a plain frame, single scattering with shadow rays, and the path tracer
/// at 1, 2, 4, ... samples per pixel, each against the path tracer at `referenceSamples` with another seed.
/// Prints a table on stdout.
void benchScattering(ComputeContext& cc, const RenderInput& input, const TransferFunction& tf,
                     const Scene& scene, const ScatterBenchOptions& options);

} // namespace volcl::cli
