// `volcl bench render --shading-sweep`: Blinn-Phong per gradient kind against the plain frame and the reference,
// an iso layer against the plain frame, and VTK's fixed-point ray caster shaded and unshaded.
#pragma once

#include "core/runtime/ClRuntime.hpp"
#include "host/image/ImageIo.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/RenderInput.hpp"
#include "render/Scene.hpp"

#include <filesystem>
#include <functional>
#include <utility>
#include <vector>

namespace volcl::cli {

struct ShadingBenchOptions {
    int runs = 5;               ///< interleaved rounds: every variant renders once per round (median)
    double referenceStep = 0.1; ///< world units of the double references (plain and shaded)
    std::filesystem::path csv;  ///< rows: variant, ms, ratio to plain, RMSE vs reference and vs central
    /// The shaded variants timed (central differences are rendered once anyway: the RMSE column is against them).
    std::vector<GradientKind> gradients = {GradientKind::Cache, GradientKind::CacheNearest,
                                           GradientKind::Central, GradientKind::Sobel};
    /// Runs the VTK peer on a scene (median ms, image); empty: no peer.
    std::function<std::pair<double, ImageBuffer>(const Scene&)> vtk;
};

/// The scene unlit ("plain"), shaded with each gradient kind (cache, cache-nearest, central, sobel; the
/// scene's lights and coefficients, or a head light with the default coefficients when it has none), and
/// with one iso layer mixed in, timed in interleaved rounds (kernel time), each against the double
/// reference (central differences). Prints a table with the load average on stdout.
void benchShading(ComputeContext& cc, const RenderInput& input, const TransferFunction& tf,
                  const Scene& scene, const ShadingBenchOptions& options);

} // namespace volcl::cli
