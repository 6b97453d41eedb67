// The viewer's state without any OpenGL: scene, camera, effect toggles, TF presets, adaptive quality,
// and the renderer (any VolumeRenderer) that draws each frame. The window and headless front ends both
// drive it.
#pragma once

#include "apps/viewer/AdaptiveQuality.hpp"
#include "apps/viewer/ViewerCamera.hpp"
#include "host/image/ImageIo.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/RenderInput.hpp"
#include "render/VolumeRenderer.hpp"

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace volcl {
class ComputeContext;
class Volume;
} // namespace volcl

namespace volcl::viewer {

/// What a key does; the same table serves GLFW keys and `--keys` in headless runs.
enum class ViewerAction {
    CycleMode,         ///< m: dvr -> mip -> iso -> xray
    ToggleShading,     ///< 1
    ToggleShadows,     ///< 2
    ToggleScattering,  ///< 3
    ToggleClipping,    ///< 4
    ToggleIsosurfaces, ///< 5
    CycleTfPreset,     ///< t
    ReloadTf,          ///< r: re-read the TF file
    ToggleAdaptive,    ///< a
    ResetCamera,       ///< c
    Screenshot,        ///< s (handled by the front end: it owns the framebuffer)
    ToggleOverlay,     ///< o (the front end's: text over the frame)
    Quit,              ///< q, Escape
};

/// The action of a key character, or nothing for an unbound key.
std::optional<ViewerAction> actionForKey(char key);
/// One line per binding, for --help and the window's start-up message.
std::string keyBindingsHelp();

/// A named transfer function the `t` key cycles through.
struct TfPreset {
    std::string name;
    TransferFunction tf;
};

/// The presets for data with value range `range` in world box `box`: the scene's own TF first (when there
/// is one), then ramps and bands laid over the value range, with extinction scaled so a ray through the
/// whole box reaches optical depth about 8 at the strongest value.
std::vector<TfPreset> transferFunctionPresets(const ValueRange& range, const WorldBox& box,
                                              const std::optional<TransferFunction>& sceneTf);
/// transferFunctionPresets() for a grid's range and box.
std::vector<TfPreset> transferFunctionPresets(const Volume& volume,
                                              const std::optional<TransferFunction>& sceneTf);

/// One rendered frame with the level it was rendered at and where its time went.
struct ViewerFrame {
    ImageBuffer image;  ///< linear associated RGBA (+Z in iso mode), at level.resolutionScale of the viewport
    QualityLevel level; ///< actual level (from the rounded pixel counts)
    bool interactive = false;
    bool structureChanged = false; ///< the kernel may have been rebuilt for this frame (a table alone is not)
    double setupMs = 0.0;          ///< VolumeRenderer::setScene (planning, tables, kernel lookup or build)
    double tableMs = 0.0;          ///< pre-integration table built for this frame's step (part of setupMs)
    double renderMs = 0.0;         ///< VolumeRenderer::render wall time (kernel + read-back)
    double kernelMs = 0.0;         ///< the ray-marching kernel alone (profiling event)
    /// Refinement after the view stopped: pass 1 .. ViewerSession::kRefinePasses (the last is the ray marcher's
    /// frame itself); 0 for frames that are not refining.
    int refinePass = 0;
};

/// Example:
/// ```
/// volcl::viewer::ViewerSession s(cc, volume, scene, tf, "tf.json", {});
/// s.camera().orbit(0.2, 0.0);
/// volcl::viewer::ViewerFrame f = s.renderFrame(512, 512, /*interactive=*/true);
/// s.frameDone(f, measuredFrameMs);       // feeds the adaptive-quality controller
/// ```
class ViewerSession {
public:
    /// `scene.camera` absent: the default camera of the data's box. `tf` absent: the first preset. `tfPath`
    /// empty: nothing to reload. The renderer comes from input.makeRenderer().
    ViewerSession(ComputeContext& cc, RenderInput input, const Scene& scene,
                  const std::optional<TransferFunction>& tf, std::filesystem::path tfPath,
                  const AdaptiveQualityOptions& adaptive);
    /// A session on a grid the caller keeps alive.
    ViewerSession(ComputeContext& cc, const Volume& volume, const Scene& scene,
                  const std::optional<TransferFunction>& tf, std::filesystem::path tfPath,
                  const AdaptiveQualityOptions& adaptive);
    ~ViewerSession();

    CameraController& camera() noexcept { return camera_; }
    /// Applies a key action (Screenshot and Quit are the front end's); returns one line saying what changed.
    std::string apply(ViewerAction action);
    /// Renders for a viewport of width x height: full quality when not interactive, else at the adaptive
    /// controller's level.
    ViewerFrame renderFrame(int width, int height, bool interactive);
    /// Still frames after a preview-tier frame that blend the ray marcher's frame in: pass p shows
    /// (1 - p / kRefinePasses) of the preview at full resolution plus p / kRefinePasses of the ray marcher's
    /// frame, so the image improves without a jump and is the ray marcher's own from pass kRefinePasses.
    static constexpr int kRefinePasses = 4;
    /// The view stopped after preview-tier frames and the ray marcher's frame is not fully shown yet, or the
    /// renderer still refines it (compressed bricks decoded a few per frame).
    bool refining() const noexcept { return refinePass_ > 0 || previewShown_ || renderer_->refining(); }
    /// The preview tier a moving view of the current scene renders with (Raymarch: none; see
    /// AdaptiveQualityOptions::previewTiers).
    GridMethod previewTier() const;
    /// Reports the whole frame's wall time (render + upload + draw) to the controller; a full-quality frame
    /// seeds it. Frames after a structural change (kernel rebuild) are skipped: build time says nothing
    /// about the next frame.
    void frameDone(const ViewerFrame& frame, double frameMs);

    /// The scene as the next frame will render it at full quality (camera included).
    Scene currentScene() const;
    const VolumeRenderer& renderer() const noexcept { return *renderer_; }
    ComputeContext& compute() const noexcept { return cc_; }
    const AdaptiveQuality& adaptive() const noexcept { return adaptive_; }
    /// The controller of preview-tier frames (resolution only).
    const AdaptiveQuality& tierAdaptive() const noexcept { return tierAdaptive_; }
    const std::string& tfPresetName() const noexcept { return presets_[presetIndex_].name; }
    /// Short names of what the current kernel compiles in, e.g. "shading, shadows, skipping".
    std::string compiledSummary() const;
    /// Window title: mode, compiled effects, TF preset, frame size, step, frame time and fps.
    std::string title(const ViewerFrame& last, double frameMs) const;

private:
    ComputeContext& cc_;
    RenderInput input_;
    ValueRange range_; ///< of the data, for presets and the default iso-value
    Scene base_;       ///< the scene with the viewer's toggles applied, full quality; camera kept in camera_
    Scene original_;
    std::filesystem::path tfPath_;
    std::vector<TfPreset> presets_;
    std::size_t presetIndex_ = 0;
    CameraController camera_;
    AdaptiveQuality adaptive_;
    std::unique_ptr<VolumeRenderer> renderer_;
    bool structureChanged_ = false; // the constructor planned and built the first kernel
    AdaptiveQuality tierAdaptive_;
    bool finite_ = true; ///< the grid has no NaN/Inf voxels (the preview tiers refuse those)
    std::unique_ptr<VolumeRenderer> preview_; ///< the preview tier's renderer, made on first use
    bool previewStale_ = false;               ///< its scene needs setScene (effects or mode changed)
    bool previewShown_ = false;               ///< the last frame was a preview frame: refine when still
    int refinePass_ = 0;                      ///< the refinement pass the last still frame showed
    ImageBuffer refineFrom_, refineTo_;       ///< preview at full resolution and the ray marcher's frame
    /// The ray marcher's frame at `want` (full quality when want.full()).
    ViewerFrame renderRaymarch(Scene s, const QualityLevel& want, int width, int height, bool interactive);
    /// A preview-tier frame of `s` at resolution `resolutionScale`.
    ViewerFrame renderPreview(Scene s, GridMethod tier, double resolutionScale, int width, int height,
                              bool interactive);
    /// The next refinement pass after the view stopped.
    ViewerFrame refine(const Scene& s, GridMethod tier, int width, int height);
};

} // namespace volcl::viewer
