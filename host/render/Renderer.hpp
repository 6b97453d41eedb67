// Ray marcher: effect planning (what gets compiled and why), the OpenCL renderer and the double reference.
#pragma once

#include "host/image/ImageIo.hpp"
#include "host/render/Scene.hpp"
#include "host/runtime/ClRuntime.hpp"
#include "host/tf/TransferFunction.hpp"

#include <memory>
#include <string>
#include <vector>

namespace volcl {

class Volume;
class PreintegrationTable;

/// The kernel features a scene needs, with the reason each requested feature was kept or dropped.
struct EffectPlan {
    KernelDefines defines;
    std::vector<std::string> compiled; ///< "shading: 2 lights, ambient 0.2 ..."
    std::vector<std::string> dropped;  ///< "shadows: no light in the scene"
    bool shading = false, shadows = false, scattering = false, clipping = false, skipping = false;
    bool earlyTermination = false, sobel = false;
    double colorScale = 1.0; ///< ambient-only shading folded into the TF colours
    int voxelType = 0;       ///< VOXEL_TYPE: 0 float, 1 uint8, 2 uint16, 3 int16 (stored type on the device)
    std::vector<IsoLayer> isosurfaces; ///< the ones that can appear
    std::vector<ClipPlane> clipPlanes; ///< the ones that cut the volume box
    std::string explain() const;       ///< multi-line report for `volcl render --explain`
};

/// Decides the compiled features from the scene, the volume's value range and box, and the TF.
EffectPlan planEffects(const Scene& scene, const Volume& volume, const TransferFunction& tf);

/// Renders scenes with OpenCL. Keeps the volume, macrocell min/max, TF knots and tables on the device;
/// setTransferFunction() rebuilds only what depends on the TF. Example:
/// ```
/// volcl::ComputeContext cc;
/// volcl::Renderer r(cc, volume, tf, scene);
/// volcl::ImageBuffer img = r.render();         // R, G, B, A (+ Z in iso mode), linear associated
/// std::cerr << r.plan().explain();
/// ```
class Renderer {
public:
    /// Throws DataError for a volume with NaN/Inf voxels, UsageError for an invalid scene.
    Renderer(ComputeContext& cc, const Volume& volume, const TransferFunction& tf, const Scene& scene);
    ~Renderer();
    Renderer(const Renderer&) = delete;
    Renderer& operator=(const Renderer&) = delete;

    /// Replaces the scene (camera, mode, effects); rebuilds kernels and tables only when needed.
    void setScene(const Scene& scene);
    void setTransferFunction(const TransferFunction& tf);
    /// Moves the camera and resizes the image without re-planning effects or re-scanning the volume, for
    /// interactive viewers (setScene re-plans: tens of milliseconds on large volumes). A new step goes
    /// through setScene, since tables and guards depend on it.
    void setView(const Camera& camera, int width, int height, double step);
    ImageBuffer render();
    /// Renders with the effect-free baseline kernel (raymarch_plain.cl); DVR, point sampling only.
    ImageBuffer renderPlainBaseline();
    double lastKernelMilliseconds() const noexcept { return lastMs_; }
    /// The device buffer the last render() wrote: width x height float4 (linear associated R, G, B, A), row 0
    /// at the top. Lets a viewer copy the frame into an OpenGL buffer shared through cl_khr_gl_sharing.
    const cl::Buffer& outputBuffer() const noexcept;
    const EffectPlan& plan() const noexcept { return plan_; }
    const Scene& scene() const noexcept { return scene_; }
    const Camera& camera() const noexcept { return camera_; }
    /// Milliseconds spent building the last pre-integration table (0 when none was needed).
    double lastTableMilliseconds() const noexcept { return tableMs_; }
    std::size_t macrocellCount() const noexcept;
    double emptyMacrocellFraction() const noexcept { return emptyFraction_; }

private:
    struct Impl;
    void rebuild(bool tfChanged);
    ImageBuffer launch(cl::Kernel& kernel, bool depth, bool packet);
    /// d plus the volume layout the packet kernels read (uploads the corner copy on first use).
    KernelDefines packetDefines(KernelDefines d);
    ComputeContext& cc_;
    const Volume& volume_;
    TransferFunction tf_;
    Scene scene_;
    Camera camera_;
    EffectPlan plan_;
    std::unique_ptr<Impl> impl_;
    double lastMs_ = 0.0, tableMs_ = 0.0, emptyFraction_ = 0.0;
};

/// Options of the double-precision reference renderer.
struct ReferenceOptions {
    double step = 0.02; ///< world units; midpoint rule, so errors fall as step^2
    int threads = 0;    ///< 0 = hardware concurrency
};

/// The ray integral of CONTRACT section 4 in double precision with fine steps and the exact TF, for every
/// mode and effect (no early termination, no skipping). Output channels as Renderer::render().
ImageBuffer referenceRender(const Volume& volume, const TransferFunction& tf, const Scene& scene,
                            const ReferenceOptions& options = {});

/// Root-mean-square difference over the channels R, G, B, A of two images of one size.
double imageRmse(const ImageBuffer& a, const ImageBuffer& b);

} // namespace volcl
