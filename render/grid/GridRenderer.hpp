// The grid renderer: ray marching of a node-centred scalar grid (a Volume) with OpenCL, and its reference.
#pragma once

#include "render/Reference.hpp"
#include "render/RendererBase.hpp"
#include "render/SkipChoice.hpp"

#include <memory>
#include <string>

namespace volcl {

class Volume;
namespace grid_detail {
struct MacrocellGrid;
}

/// World box of the node-centred grid: origin and (n - 1) * spacing per axis.
WorldBox gridBounds(const Volume& volume);

/// planEffects for a grid: the shared planner on the grid's box and value range, plus the voxel type the
/// kernels read (VOXEL_TYPE).
EffectPlan planEffects(const Scene& scene, const Volume& volume, const TransferFunction& tf);

/// defaultCamera() framing the grid's box.
Camera defaultCamera(const Volume& volume);

/// Renders scenes of a grid with OpenCL (cl/render/raymarch.cl). Keeps the volume, macrocell min/max, TF knots
/// and tables on the device; setTransferFunction() rebuilds only what depends on the TF. The volume must
/// outlive the renderer. Example:
/// ```
/// volcl::ComputeContext cc;
/// volcl::GridRenderer r(cc, volume, tf, scene);
/// volcl::ImageBuffer img = r.render();         // R, G, B, A (+ Z in iso mode), linear associated
/// std::cerr << r.plan().explain();
/// ```
class GridRenderer final : public RendererBase {
public:
    /// Throws DataError for a volume with NaN/Inf voxels, UsageError for an invalid scene.
    GridRenderer(ComputeContext& cc, const Volume& volume, const TransferFunction& tf, const Scene& scene);
    ~GridRenderer() override;

    EffectPlan planEffects(const Scene& scene) const override;
    /// setView() moves the camera and resizes the image without re-planning effects or re-scanning the
    /// volume, for interactive viewers (setScene re-plans: tens of milliseconds on large volumes).
    ImageBuffer render() override;
    ImageBuffer renderProgressive(int samples) override;
    /// Renders with the effect-free baseline kernel (raymarch_plain.cl); DVR, point sampling only.
    ImageBuffer renderPlainBaseline() override;
    /// "macrocells: N, x% empty".
    std::string statistics() const override;

    /// Multiple scattering, progressively: adds `samples` path-tracer samples per pixel to the running mean
    /// (outputBuffer() holds it; a camera, scene or TF change starts over) and returns the samples so far.
    /// Throws UsageError when the plan has no path tracer.
    int accumulateSamples(int samples);
    /// The running mean of accumulateSamples() as an image (R, G, B, A).
    ImageBuffer accumulatedImage();

    /// SHADOW_VOLUME: wall time of the last light-volume build (0 before one), and the builds so far; a
    /// frame rebuilds them only when a light, the TF, the field or a light-volume knob changed.
    double lastLightVolumeMilliseconds() const noexcept { return lightVolumeMs_; }
    int lightVolumeBuilds() const noexcept;
    /// render.skipping auto: how the current scene skips (or does not) and the measurement it was chosen on
    /// (unmeasured for on and off; cached per TF, effects and step octave until the TF or scene changes).
    const SkipDecision& skipDecision() const noexcept;
    /// Replaces the probe frame's kernel timing for render.skipping auto (empty: launch the probe) and
    /// forgets the cached choices; the next committed scene or TF decides with it. For tests.
    void setSkipProbeTimer(SkipProbeTimer timer);

    const Volume& volume() const noexcept { return volume_; }
    std::size_t macrocellCount() const noexcept;
    double emptyMacrocellFraction() const noexcept { return emptyFraction_; }
    /// Kernel time of the gradient cache's build (once per volume, on the first scene shaded from it); -1
    /// while none is built.
    double gradientCacheBuildMs() const noexcept;

private:
    struct Impl;
    void admitScene(const Scene& next) override;
    bool drawsGradientTf() const override { return true; }
    bool drawsLabels() const override { return true; }
    void rebuild(const Rebuild& change) override;
    void viewChanged(bool sameView) override;
    /// The pre-integration (or lighting, or iso-surface) table the plan reads.
    void selectTables(const TransferFunction& shaded);
    /// The cubic filter's coefficients or the smoothed voxels when the scene asks for them, built once per
    /// filter (or sigma); returns the macrocells of what the kernel samples.
    const grid_detail::MacrocellGrid& prepareSampledField();
    /// Macrocell emptiness of `macro` from the shaded TF and the iso-values, for the sampling the kernel will use.
    std::vector<unsigned char> emptiness(const grid_detail::MacrocellGrid& macro,
                                         const TransferFunction& shaded) const;
    /// Makes `empty` the macrocell flags the kernel reads (and emptyMacrocellFraction() theirs).
    void useEmptiness(std::vector<unsigned char> empty);
    /// The macrocells the frame skips with: `macro` for skipping on (or off), else (auto) the fastest of off
    /// and the candidate edges on a probe frame; a choice of off drops SKIPPING from plan_ and says why.
    /// `base`: the frame's parameters on `macro`; `floatCopy`: as packetDefines.
    const grid_detail::MacrocellGrid& selectSkipping(const grid_detail::MacrocellGrid& macro,
                                                     const TransferFunction& shaded,
                                                     const VolclGridRenderParams& base, bool floatCopy);
    /// The voxels (or float copy) the kernels sample for the current scene.
    const cl::Buffer& sampledVoxels() const;
    /// Launches `kernel` into `out`/`depth` of w x h pixels; returns the kernel's event.
    cl::Event enqueueFrame(cl::Kernel& kernel, const cl::Buffer& voxels, const cl::Buffer& empty,
                           const VolclGridRenderParams& params, const DeviceBuffer<cl_float4>& out,
                           const DeviceBuffer<float>& depth, std::size_t w, std::size_t h, bool packet);
    /// The path tracer's kernel, majorants and parameters (plans with multiple scattering).
    void preparePathTracer(const TransferFunction& shaded);
    /// SHADOW_VOLUME: the light volumes for the current lights, TF and field (rebuilt only when they changed).
    void updateLightVolume(const cl::Buffer& voxels);
    ImageBuffer launch(cl::Kernel& kernel, const cl::Buffer& voxels, bool depth, bool packet);
    ImageBuffer readImage(bool withDepth); ///< the output buffer (and depth) as an image with attributes
    /// d plus the volume layout the packet kernels read (uploads the corner copy on first use);
    /// `floatCopy`: they read a float copy instead (the cubic filter's coefficients, or smoothed voxels).
    KernelDefines packetDefines(KernelDefines d, bool floatCopy);
    const Volume& volume_;
    std::unique_ptr<Impl> impl_;
    double emptyFraction_ = 0.0;
    double lightVolumeMs_ = 0.0;
};

/// The grid's ray integral in double precision with fine steps and the exact TF, for every mode and effect
/// (no early termination, no skipping). Output channels as GridRenderer::render().
ImageBuffer referenceRender(const Volume& volume, const TransferFunction& tf, const Scene& scene,
                            const ReferenceOptions& options = {});

} // namespace volcl
