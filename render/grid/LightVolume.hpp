// Light-attenuation volumes for the grid renderer's shadows: built on the device by sweeping slices away from
// each light (cl/render/light_volume.cl), kept while the light, TF, field and knobs stay; and their C++ reference.
#pragma once

#include "cl/volcl_shared.h"
#include "core/runtime/ClRuntime.hpp"
#include "render/VecMath.hpp"

#include <array>
#include <cstddef>
#include <string>
#include <vector>

namespace volcl {

class TransferFunction;
struct Camera;

/// A light as its volume sees it: directional (`vector`: unit world direction toward the light) or point
/// (`vector`: world position). `head`: a head light resolved for the current camera.
struct SweptLight {
    bool point = false;
    Vec3 vector{0, 0, 1};
    bool head = false;
    bool operator==(const SweptLight&) const = default;
};

/// The lit lights of the kernel parameters as swept lights: a head light of an orthographic camera is
/// directional toward the eye (the kernels light along the view), of a perspective camera a point at the eye.
std::vector<SweptLight> sweptLights(const VolclLightingParams& lighting, const Camera& camera);

/// The light grid over a volume of `voxels` nodes per axis: ceil((n - 1) / cell) + 1 nodes per axis spanning
/// the same box, for `lights` lights.
VolclLightVolumeParams lightVolumeGeometry(const std::array<std::size_t, 3>& voxels, int cell,
                                           std::size_t lights);

/// The slice sweeps of one light, in launch order: axis, direction (+1: the light lies toward lower slices),
/// first and last slice, and whether it is a point light's pyramid.
struct LightSweep {
    unsigned axis = 0;
    int dir = 1;
    int first = 0, last = 0;
    bool cone = false;
};
/// One sweep for a directional light (along the axis the light crosses most light cells per unit length),
/// up to six pyramids for a point light (each axis, each side of the light that holds nodes).
std::vector<LightSweep> lightSweeps(const SweptLight& light, const VolclGridParams& grid,
                                    const VolclLightVolumeParams& lv);

/// The C++ reference of light_volume.cl in double: the same sweeps on a float field (trilinear, `values` x
/// fastest on the grid of `grid`) with the exact TF's extinction. Returns every light's nodes' optical depth
/// toward the light, light after light (as the device buffer).
std::vector<double> lightVolumeReference(const std::vector<float>& values, const VolclGridParams& grid,
                                         const TransferFunction& tf, const std::vector<SweptLight>& lights,
                                         int cell, double step);

/// The device's light volumes. Example (GridRenderer::render):
/// ```
/// LightVolume lv;
/// if (lv.update(cc, inputs)) std::cerr << lv.lastBuildMilliseconds() << " ms\n";
/// setArgs(kernel, ..., lv.buffer());
/// ```
class LightVolume {
public:
    /// What a build depends on. `fieldKey` names the sampled field and the TF (any change rebuilds).
    struct Inputs {
        const cl::Buffer* voxels = nullptr;
        const cl::Buffer* knots = nullptr;
        std::size_t knotCount = 0;
        KernelDefines defines; ///< VOXEL_TYPE, FILTER_BSPLINE, NAN_*: how light_volume.cl reads the field
        /// The sweep kernel's file: a whole grid, or render/light_volume_bricks.cl for a pool of decoded bricks.
        std::string source = "render/light_volume.cl";
        VolclGridParams grid{};
        std::vector<SweptLight> lights;
        int cell = 1;
        double step = 1.0;
        std::string fieldKey;
        double headToleranceDeg = 1.0; ///< a head light turning less than this keeps its volume
        Vec3 centre{0, 0, 0};          ///< the volume's centre, where a head light's turn is seen from
    };

    /// Makes the volumes current for `in`; true when they were rebuilt (lastBuildMilliseconds() then
    /// holds the build's wall time, kernels and all).
    bool update(ComputeContext& cc, const Inputs& in);
    /// Optical depth toward the light, one float per node per light; before the first build a one-float
    /// buffer (a kernel argument must be bound).
    const DeviceBuffer<float>& buffer(ComputeContext& cc);
    const VolclLightVolumeParams& params() const noexcept { return params_; }
    double lastBuildMilliseconds() const noexcept { return buildMs_; }
    /// Builds since construction (tests check that a camera move alone does not rebuild).
    int builds() const noexcept { return builds_; }

private:
    bool current(const Inputs& in) const;
    void build(ComputeContext& cc, const Inputs& in);
    DeviceBuffer<float> volume_, sliceA_, sliceB_;
    VolclLightVolumeParams params_{};
    Inputs built_;
    bool valid_ = false;
    double buildMs_ = 0.0;
    int builds_ = 0;
};

} // namespace volcl
