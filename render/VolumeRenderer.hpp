// The rendering interface every renderer implements (grids today; tetrahedral meshes and compressed bricks
// plug in as peers): what its data spans, what a scene would compile, and frames into an image.
#pragma once

#include "core/runtime/ClRuntime.hpp"
#include "host/image/ImageIo.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/Bounds.hpp"
#include "render/EffectPlan.hpp"
#include "render/Scene.hpp"

#include <string>

namespace volcl {

/// A renderer owns the device copy of its data and draws scenes of it with OpenCL. The scene, the CLI and
/// the viewer use only this interface; makeRenderer() (RenderInput.hpp) picks the implementation from the
/// input. Output of render(): width x height pixels, channels R, G, B, A (linear, associated alpha) plus Z
/// (ray distance to the first surface) when the plan has iso-surfaces. Example:
/// ```
/// std::unique_ptr<volcl::VolumeRenderer> r = input.makeRenderer(cc, tf, scene);
/// volcl::ImageBuffer img = r->render();
/// std::cerr << r->plan().explain();
/// ```
class VolumeRenderer {
public:
    virtual ~VolumeRenderer() = default;

    /// World box of the data (the default camera frames it, clip planes are planned against it).
    virtual WorldBox bounds() const = 0;
    /// Finite data values span this range (iso-values outside it are dropped).
    virtual ValueRange valueRange() const = 0;
    /// What `scene` would compile on this data, without changing the renderer.
    virtual EffectPlan planEffects(const Scene& scene) const = 0;

    /// Replaces the scene (camera, mode, effects); rebuilds kernels and tables only when needed.
    virtual void setScene(const Scene& scene) = 0;
    virtual void setTransferFunction(const TransferFunction& tf) = 0;
    /// Moves the camera and resizes the image without re-planning effects, for interactive viewers; a new
    /// step goes through setScene.
    virtual void setView(const Camera& camera, int width, int height, double step) = 0;
    /// Renders the current scene.
    virtual ImageBuffer render() = 0;
    /// Multiple scattering, progressively: adds `samples` path-tracer samples per pixel to the running mean
    /// of the current view and returns it (a viewer calls it every frame; a view change starts over).
    /// Renderers or plans without a path tracer render().
    virtual ImageBuffer renderProgressive(int samples) {
        (void)samples;
        return render();
    }
    /// The effect-free baseline kernel on the current scene (`volcl bench render --effects`); renderers
    /// without one throw UsageError.
    virtual ImageBuffer renderPlainBaseline();

    /// The device buffer the last render() wrote: width x height float4 (linear associated R, G, B, A),
    /// row 0 at the top. Lets a viewer copy the frame into an OpenGL buffer through cl_khr_gl_sharing.
    virtual const cl::Buffer& outputBuffer() const noexcept = 0;
    virtual const EffectPlan& plan() const noexcept = 0;
    virtual const Scene& scene() const noexcept = 0;
    /// The camera in use: the scene's, else defaultCamera(bounds()).
    virtual const Camera& camera() const noexcept = 0;
    /// The last frame's kernel time (profiling event), milliseconds.
    virtual double lastKernelMilliseconds() const noexcept = 0;
    /// Milliseconds spent building the last pre-integration table (0 when none was needed).
    virtual double lastTableMilliseconds() const noexcept = 0;
    /// One line on the renderer's acceleration structures for `--explain` ("macrocells: 512, 40.0% empty").
    virtual std::string statistics() const = 0;
    /// True while the last render() drew the current view from data it is still refining (compressed bricks
    /// decoded a few per frame): a viewer keeps rendering the still view until it is false.
    virtual bool refining() const noexcept { return false; }

protected:
    /// `scene` with a setView() call's camera, image size and step: what every renderer's setView starts from.
    static Scene withView(Scene scene, const Camera& camera, int width, int height, double step);
};

} // namespace volcl
