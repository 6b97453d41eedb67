// The grid renderer: ray marching of a node-centred scalar grid (a Volume) with OpenCL, and its reference.
#pragma once

#include "render/Reference.hpp"
#include "render/VolumeRenderer.hpp"

#include <memory>
#include <string>

namespace volcl {

class Volume;

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
class GridRenderer final : public VolumeRenderer {
public:
    /// Throws DataError for a volume with NaN/Inf voxels, UsageError for an invalid scene.
    GridRenderer(ComputeContext& cc, const Volume& volume, const TransferFunction& tf, const Scene& scene);
    ~GridRenderer() override;
    GridRenderer(const GridRenderer&) = delete;
    GridRenderer& operator=(const GridRenderer&) = delete;

    WorldBox bounds() const override;
    ValueRange valueRange() const override;
    EffectPlan planEffects(const Scene& scene) const override;

    void setScene(const Scene& scene) override;
    void setTransferFunction(const TransferFunction& tf) override;
    /// Moves the camera and resizes the image without re-planning effects or re-scanning the volume, for
    /// interactive viewers (setScene re-plans: tens of milliseconds on large volumes). A new step goes
    /// through setScene, since tables and guards depend on it.
    void setView(const Camera& camera, int width, int height, double step) override;
    ImageBuffer render() override;
    ImageBuffer renderProgressive(int samples) override;
    /// Renders with the effect-free baseline kernel (raymarch_plain.cl); DVR, point sampling only.
    ImageBuffer renderPlainBaseline() override;

    const cl::Buffer& outputBuffer() const noexcept override;
    const EffectPlan& plan() const noexcept override { return plan_; }
    const Scene& scene() const noexcept override { return scene_; }
    const Camera& camera() const noexcept override { return camera_; }
    double lastKernelMilliseconds() const noexcept override { return lastMs_; }
    double lastTableMilliseconds() const noexcept override { return tableMs_; }
    /// "macrocells: N, x% empty".
    std::string statistics() const override;

    /// Multiple scattering, progressively: adds `samples` path-tracer samples per pixel to the running mean
    /// (outputBuffer() holds it; a camera, scene or TF change starts over) and returns the samples so far.
    /// Throws UsageError when the plan has no path tracer.
    int accumulateSamples(int samples);
    /// The running mean of accumulateSamples() as an image (R, G, B, A).
    ImageBuffer accumulatedImage();

    const Volume& volume() const noexcept { return volume_; }
    std::size_t macrocellCount() const noexcept;
    double emptyMacrocellFraction() const noexcept { return emptyFraction_; }

private:
    struct Impl;
    void rebuild(bool tfChanged);
    ImageBuffer launch(cl::Kernel& kernel, const cl::Buffer& voxels, bool depth, bool packet);
    ImageBuffer readImage(bool withDepth); ///< the output buffer (and depth) as an image with attributes
    /// d plus the volume layout the packet kernels read (uploads the corner copy on first use);
    /// `floatCopy`: they read a float copy instead (the cubic filter's coefficients, or smoothed voxels).
    KernelDefines packetDefines(KernelDefines d, bool floatCopy);
    ComputeContext& cc_;
    const Volume& volume_;
    TransferFunction tf_;
    Scene scene_;
    Camera camera_;
    EffectPlan plan_;
    std::unique_ptr<Impl> impl_;
    double lastMs_ = 0.0, tableMs_ = 0.0, emptyFraction_ = 0.0;
};

/// The grid's ray integral in double precision with fine steps and the exact TF, for every mode and effect
/// (no early termination, no skipping). Output channels as GridRenderer::render().
ImageBuffer referenceRender(const Volume& volume, const TransferFunction& tf, const Scene& scene,
                            const ReferenceOptions& options = {});

} // namespace volcl
