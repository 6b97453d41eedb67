// The grid's multiple-scattering path tracer: majorant grid, device accumulation (cl/render/pathtrace.cl) and the
// double-precision reference that draws the same random stream.
#pragma once

#include "cl/volcl_shared.h"
#include "core/runtime/ClRuntime.hpp"
#include "host/image/ImageIo.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/Scene.hpp"
#include "render/grid/GridDetail.hpp"

#include <vector>

namespace volcl {

class Volume;

/// Majorant of the extinction per macrocell: the largest tau over the cell's value range (0 where the TF
/// makes the whole cell transparent: delta tracking crosses it without a sample), widened by 1e-4 relative
/// for float rounding. `nanTau`: the NaN colour's extinction, the least majorant of a cell with a NaN/Inf voxel.
std::vector<float> majorantGrid(const grid_detail::MacrocellGrid& grid, const TransferFunction& tf,
                                double nanTau = 0.0);

/// The path tracer's launch parameters for a scene: seed, bounces, environment, emission.
VolclPathParams pathParams(const SceneEffects& fx);

/// Progressive Monte Carlo accumulation on the device: every accumulate() adds samples per pixel to a
/// running sum and writes the mean so far into `out` (what a viewer shows). Example:
/// ```
/// volcl::GridPathTracer pt(cc);
/// pt.setMajorants(volcl::majorantGrid(macro, tf));
/// pt.accumulate(kernel, voxels, knots, params, fx, 16, out); // 16 more samples per pixel
/// ```
class GridPathTracer {
public:
    explicit GridPathTracer(ComputeContext& cc) : cc_(cc) {}
    void setMajorants(const std::vector<float>& majorants);
    /// Drops the accumulated samples (camera, scene or TF changed).
    void reset() noexcept { done_ = 0; }
    /// Adds `samples` samples per pixel (in launches of at most `perLaunch`); returns the kernel milliseconds.
    double accumulate(cl::Kernel& kernel, const cl::Buffer& voxels, const DeviceBuffer<VolclTfKnot>& knots,
                      const VolclGridRenderParams& params, const SceneEffects& fx, int samples,
                      DeviceBuffer<cl_float4>& out, int perLaunch = 4);
    int samplesDone() const noexcept { return done_; }

private:
    ComputeContext& cc_;
    DeviceBuffer<float> majorant_;
    DeviceBuffer<cl_float4> accum_;
    int done_ = 0;
};

/// Options of the reference path tracer.
struct PathReferenceOptions {
    int samples = 0; ///< 0: the scene's effects.scattering.samples
    int threads = 0; ///< 0: hardware concurrency
};

/// The path tracer in double precision with the exact TF and the same random stream (seed, pixel, sample)
/// as the kernel: its images agree with the kernel's statistically (and mostly path for path). Channels R,
/// G, B, A. Throws UsageError when the scene does not ask for multiple scattering.
ImageBuffer pathTraceReference(const Volume& volume, const TransferFunction& tf, const Scene& scene,
                               const PathReferenceOptions& options = {});

} // namespace volcl
