// Majorant grid, launch parameters and progressive device accumulation of the grid path tracer.
#include "render/grid/PathTracer.hpp"

#include "core/Error.hpp"

#include <algorithm>
#include <cmath>

namespace volcl {

std::vector<float> majorantGrid(const grid_detail::MacrocellGrid& grid, const TransferFunction& tf,
                                double nanTau) {
    std::vector<float> m(grid.min.size(), 0.0f);
    for (std::size_t c = 0; c < m.size(); ++c) {
        // Trilinear interpolation stays within the corner values (up to float rounding, which the relative
        // widening below covers), so a cell of constant zero-tau data keeps majorant 0. A cell with a
        // NaN/Inf voxel can also sample the NaN colour.
        const bool nonFinite = c < grid.nonFinite.size() && grid.nonFinite[c];
        double tau =
            grid.min[c] <= grid.max[c] ? grid_detail::maxExtinctionOver(tf, grid.min[c], grid.max[c]) : 0.0;
        if (nonFinite) tau = std::max(tau, nanTau);
        m[c] = tau > 0.0 ? float(tau * (1.0 + 1e-4)) : 0.0f;
    }
    return m;
}

VolclPathParams pathParams(const SceneEffects& fx) {
    VolclPathParams p{};
    p.seed = fx.seed;
    p.maxBounces = volcl_uint(fx.maxBounces);
    for (int c = 0; c < 3; ++c)
        p.environment[c] = float(fx.environment[std::size_t(c)]);
    p.emission = fx.emission ? 1.0f : 0.0f;
    return p;
}

void GridPathTracer::setMajorants(const std::vector<float>& majorants) {
    majorant_ = cc_.upload(majorants, CL_MEM_READ_ONLY);
    done_ = 0;
}

double GridPathTracer::accumulate(cl::Kernel& kernel, const cl::Buffer& voxels,
                                  const DeviceBuffer<VolclTfKnot>& knots, const VolclGridRenderParams& params,
                                  const SceneEffects& fx, int samples, DeviceBuffer<cl_float4>& out,
                                  int perLaunch) {
    if (majorant_.size() == 0) throw Error("internal: path tracer has no majorant grid");
    const std::size_t w = params.camera.width, h = params.camera.height, pixels = w * h;
    if (accum_.size() != pixels) {
        accum_ = cc_.allocate<cl_float4>(pixels);
        done_ = 0;
    }
    VolclPathParams p = pathParams(fx);
    double ms = 0.0;
    while (samples > 0) {
        const int n = std::min(samples, std::max(perLaunch, 1));
        p.firstSample = volcl_uint(done_);
        p.sampleCount = volcl_uint(n);
        p.invTotal = 1.0f / float(done_ + n);
        clCheck(kernel.setArg(0, voxels), "clSetKernelArg");
        clCheck(kernel.setArg(1, knots.get()), "clSetKernelArg");
        clCheck(kernel.setArg(2, majorant_.get()), "clSetKernelArg");
        clCheck(kernel.setArg(3, params), "clSetKernelArg");
        clCheck(kernel.setArg(4, p), "clSetKernelArg");
        clCheck(kernel.setArg(5, accum_.get()), "clSetKernelArg");
        clCheck(kernel.setArg(6, out.get()), "clSetKernelArg");
        ms += eventMilliseconds(cc_.launch2d(kernel, w, h, cc_.profile().rayMarch.pathTrace));
        done_ += n;
        samples -= n;
    }
    return ms;
}

} // namespace volcl
