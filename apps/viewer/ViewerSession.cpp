// Viewer state: key actions, effect toggles, TF presets, and frames rendered at the adaptive level.
#include "apps/viewer/ViewerSession.hpp"

#include "core/Error.hpp"
#include "core/Format.hpp"
#include "core/Volume.hpp"
#include "core/runtime/Timing.hpp"
#include "render/VecMath.hpp"
#include "render/bricks/BrickRenderer.hpp"
#include "render/grid/GridDetail.hpp"
#include "render/grid/GridRenderer.hpp"
#include "render/grid/PreviewRenderer.hpp"
#include "render/mesh/KBufferRenderer.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <sstream>

namespace volcl::viewer {
namespace {

/// The preview tiers' controller: the same target, all of the work in resolution (a tier's step is the data's).
AdaptiveQualityOptions tierOptions(AdaptiveQualityOptions o) {
    o.maxStepScale = 1.0;
    return o;
}

/// (1 - w) a + w b per channel of two frames of the same size.
ImageBuffer blendFrames(const ImageBuffer& a, const ImageBuffer& b, double w) {
    if (a.width != b.width || a.height != b.height || a.channels != b.channels)
        throw Error("viewer: refinement frames differ in size or channels");
    ImageBuffer out = b;
    for (std::size_t i = 0; i < out.pixels.size(); ++i)
        out.pixels[i] = float((1.0 - w) * double(a.pixels[i]) + w * double(b.pixels[i]));
    return out;
}

/// The controller's options for what the session renders: a mesh drawn by the k-buffer spends the level on
/// its face subset (Callahan 5.1-5.2) before the resolution.
AdaptiveQualityOptions adaptiveFor(AdaptiveQualityOptions o, const RenderInput& input, const Scene& scene) {
    if (input.kind() == RenderInput::Kind::Mesh && scene.meshMethod == MeshMethod::KBuffer)
        o.faceLevels = true;
    return o;
}

struct KeyBinding {
    char key;
    ViewerAction action;
    const char* help;
};

constexpr KeyBinding kBindings[] = {
    {'m', ViewerAction::CycleMode, "switch mode: dvr, mip, iso, xray"},
    {'1', ViewerAction::ToggleShading, "toggle shading (adds a light if the scene has none)"},
    {'2', ViewerAction::ToggleShadows, "toggle shadows"},
    {'3', ViewerAction::ToggleScattering, "toggle single scattering"},
    {'4', ViewerAction::ToggleClipping, "toggle clip planes (the scene's, else one through the centre)"},
    {'5', ViewerAction::ToggleIsosurfaces, "toggle isosurfaces (the scene's, else one at mid-range)"},
    {'t', ViewerAction::CycleTfPreset, "next transfer-function preset"},
    {'r', ViewerAction::ReloadTf, "reload the transfer-function file"},
    {'a', ViewerAction::ToggleAdaptive, "toggle adaptive quality"},
    {'c', ViewerAction::ResetCamera, "reset the camera"},
    {'s', ViewerAction::Screenshot, "save a screenshot (PNG of the window)"},
    {'o', ViewerAction::ToggleOverlay, "toggle the text overlay (frame time, level, effects, transport)"},
    {'q', ViewerAction::Quit, "quit (also Escape)"},
};

/// The data range the presets span; a constant field gets a unit-wide range.
std::array<double, 2> presetRange(const ValueRange& r) {
    double lo = r.min, hi = r.max;
    if (!(hi > lo)) hi = lo + 1.0;
    return {lo, hi};
}

double boxDiagonal(const WorldBox& box) {
    return std::max(norm(box.extent), 1.0);
}

} // namespace

std::optional<ViewerAction> actionForKey(char key) {
    const char k = static_cast<char>(std::tolower(static_cast<unsigned char>(key)));
    for (const auto& b : kBindings)
        if (b.key == k) return b.action;
    return std::nullopt;
}

std::string keyBindingsHelp() {
    std::string s = "  left drag: orbit   right/middle drag or shift+left: pan   wheel: zoom\n";
    for (const auto& b : kBindings)
        s += std::string("  ") + b.key + ": " + b.help + '\n';
    return s;
}

std::vector<TfPreset> transferFunctionPresets(const Volume& volume,
                                              const std::optional<TransferFunction>& sceneTf) {
    return transferFunctionPresets(RenderInput::borrow(volume).valueRange(), gridBounds(volume), sceneTf);
}

std::vector<TfPreset> transferFunctionPresets(const ValueRange& range, const WorldBox& box,
                                              const std::optional<TransferFunction>& sceneTf) {
    std::vector<TfPreset> out;
    if (sceneTf) out.push_back({"scene", *sceneTf});
    // Named doubles, not a structured binding: clang 14 (the fuzz build's compiler) cannot capture those.
    const std::array<double, 2> span = presetRange(range);
    const double lo = span[0], hi = span[1];
    const double r = hi - lo;
    const double tauMax = 8.0 / boxDiagonal(box);
    const auto at = [&](double f) { return lo + f * r; };

    TransferFunction grey;
    grey.domain = {lo, hi};
    grey.color = {{lo, {0, 0, 0}}, {hi, {1, 1, 1}}};
    grey.extinction = {{lo, 0.0}, {hi, tauMax}};
    out.push_back({"grey ramp", grey});

    TransferFunction hot;
    hot.domain = {lo, hi};
    hot.color = {
        {lo, {0, 0, 0}}, {at(0.3), {0.5, 0.0, 0.0}}, {at(0.6), {1.0, 0.5, 0.0}}, {hi, {1.0, 1.0, 0.8}}};
    hot.extinction = {{lo, 0.0}, {at(0.3), 0.0}, {hi, tauMax}};
    out.push_back({"hot above 30%", hot});

    // Narrow opaque bands pick out three value ranges, like translucent isosurfaces.
    TransferFunction bands;
    bands.domain = {lo, hi};
    bands.color = {{lo, {0.2, 0.4, 1.0}},
                   {at(0.375), {0.2, 0.4, 1.0}},
                   {at(0.5), {0.3, 1.0, 0.4}},
                   {at(0.625), {1.0, 0.6, 0.2}},
                   {hi, {1.0, 0.6, 0.2}}};
    const double w = 0.03;
    for (double c : {0.25, 0.5, 0.75}) {
        bands.extinction.push_back({at(c - w), 0.0});
        bands.extinction.push_back({at(c), 6.0 * tauMax});
        bands.extinction.push_back({at(c + w), 0.0});
    }
    out.push_back({"three bands", bands});
    for (auto& p : out)
        p.tf.validate();
    return out;
}

ViewerSession::ViewerSession(ComputeContext& cc, RenderInput input, const Scene& scene,
                             const std::optional<TransferFunction>& tf, std::filesystem::path tfPath,
                             const AdaptiveQualityOptions& adaptive)
    : cc_(cc), input_(std::move(input)), range_(input_.valueRange()), base_(scene), original_(scene),
      tfPath_(std::move(tfPath)), presets_(transferFunctionPresets(range_, input_.bounds(), tf)),
      camera_(scene.camera ? *scene.camera : defaultCamera(input_.bounds())),
      adaptive_(adaptiveFor(adaptive, input_, scene)), tierAdaptive_(tierOptions(adaptive)) {
    base_.validate();
    original_.camera = camera_.camera();
    Scene first = base_;
    first.camera = camera_.camera();
    renderer_ = input_.makeRenderer(cc_, presets_[0].tf, first);
    finite_ = !input_.grid() || grid_detail::nonFiniteCount(*input_.grid()) == 0;
}

ViewerSession::ViewerSession(ComputeContext& cc, const Volume& volume, const Scene& scene,
                             const std::optional<TransferFunction>& tf, std::filesystem::path tfPath,
                             const AdaptiveQualityOptions& adaptive)
    : ViewerSession(cc, RenderInput::borrow(volume), scene, tf, std::move(tfPath), adaptive) {}

ViewerSession::~ViewerSession() = default;

Scene ViewerSession::currentScene() const {
    Scene s = base_;
    s.camera = camera_.camera();
    return s;
}

std::string ViewerSession::apply(ViewerAction action) {
    SceneEffects& fx = base_.effects;
    // Effects that need light get one from the viewer's upper left when the scene brings none.
    const auto ensureLight = [&]() -> std::string {
        if (!base_.lights.empty()) return "";
        const Camera& c = camera_.camera();
        const Vec3 f = normalized(sub(c.target, c.eye));
        const Vec3 r = normalized(cross(f, c.up));
        Light l;
        l.kind = LightKind::Directional;
        l.vector = normalized(add(scale(f, -1.0), add(c.up, scale(r, -0.5))));
        base_.lights.push_back(l);
        return " (added a directional light from the upper left)";
    };
    std::string what;
    bool structural = true; // the next frame re-plans the renderer's effects
    switch (action) {
    case ViewerAction::CycleMode: {
        if (base_.labels) return "labels draw in mode dvr only: the mode stays dvr";
        static constexpr RenderMode order[] = {RenderMode::Dvr, RenderMode::Mip, RenderMode::Iso,
                                               RenderMode::Xray, RenderMode::Emission};
        std::size_t i = 0;
        while (order[i] != base_.mode)
            ++i;
        base_.mode = order[(i + 1) % 4];
        what = "mode " + std::string(renderModeName(base_.mode));
        if (base_.mode == RenderMode::Iso && fx.isosurfaces.empty())
            what += "; " + apply(ViewerAction::ToggleIsosurfaces);
        break;
    }
    case ViewerAction::ToggleShading:
        fx.shading = !fx.shading;
        what = std::string("shading ") + (fx.shading ? "on" : "off") + (fx.shading ? ensureLight() : "");
        break;
    case ViewerAction::ToggleShadows:
        fx.shadows = !fx.shadows;
        what = std::string("shadows ") + (fx.shadows ? "on" : "off") + (fx.shadows ? ensureLight() : "");
        break;
    case ViewerAction::ToggleScattering:
        fx.scattering = !fx.scattering;
        if (fx.scattering && fx.albedo <= 0.0) {
            fx.albedo = 0.8;
            fx.phaseG = 0.3;
        }
        what = std::string("scattering ") +
               (fx.scattering ? "on (albedo " + formatNumber(fx.albedo, 3) + ")" : "off") +
               (fx.scattering ? ensureLight() : "");
        break;
    case ViewerAction::ToggleClipping:
        if (!fx.clipPlanes.empty() || fx.cropBox) {
            fx.clipPlanes.clear();
            fx.cropBox.reset();
            what = "clipping off";
        } else if (!original_.effects.clipPlanes.empty() || original_.effects.cropBox) {
            fx.clipPlanes = original_.effects.clipPlanes;
            fx.cropBox = original_.effects.cropBox;
            what = "clipping on (the scene's planes and crop box)";
        } else {
            const Vec3 centre = camera_.camera().target;
            fx.clipPlanes.push_back({{1, 0, 0}, -centre[0]});
            what = "clipping on (keeps x >= " + formatNumber(centre[0], 3) + ")";
        }
        break;
    case ViewerAction::ToggleIsosurfaces:
        if (!fx.isosurfaces.empty()) {
            fx.isosurfaces.clear();
            what = "isosurfaces off";
        } else if (!original_.effects.isosurfaces.empty()) {
            fx.isosurfaces = original_.effects.isosurfaces;
            what = "isosurfaces on (the scene's)";
        } else {
            const auto [lo, hi] = presetRange(range_);
            fx.isosurfaces.push_back({0.5 * (lo + hi), {0.9, 0.85, 0.75, 1.0}});
            what = "isosurfaces on (value " + formatNumber(0.5 * (lo + hi), 3) + ")";
        }
        break;
    case ViewerAction::CycleTfPreset:
        presetIndex_ = (presetIndex_ + 1) % presets_.size();
        renderer_->setTransferFunction(presets_[presetIndex_].tf);
        if (preview_) preview_->setTransferFunction(presets_[presetIndex_].tf);
        what = "transfer function: " + presets_[presetIndex_].name;
        break;
    case ViewerAction::ReloadTf: {
        if (tfPath_.empty()) {
            return "no transfer-function file to reload";
        }
        try {
            TransferFunction tf = TransferFunction::fromFile(tfPath_);
            if (presets_.front().name == "scene")
                presets_.front().tf = tf;
            else
                presets_.insert(presets_.begin(), {"scene", tf});
            presetIndex_ = 0;
            renderer_->setTransferFunction(tf);
            if (preview_) preview_->setTransferFunction(tf);
            what = "reloaded " + tfPath_.string();
        } catch (const Error& e) {
            // A file half-way through an edit must not end the session: keep the TF in use.
            return std::string("reload failed, keeping the current transfer function: ") + e.what();
        }
        break;
    }
    case ViewerAction::ToggleAdaptive:
        adaptive_.setEnabled(!adaptive_.options().enabled);
        tierAdaptive_.setEnabled(adaptive_.options().enabled);
        structural = false;
        what = std::string("adaptive quality ") + (adaptive_.options().enabled ? "on" : "off");
        break;
    case ViewerAction::ResetCamera:
        camera_ = CameraController(*original_.camera);
        structural = false;
        what = "camera reset";
        break;
    case ViewerAction::Screenshot:
    case ViewerAction::ToggleOverlay:
    case ViewerAction::Quit:
        return {};
    }
    structureChanged_ = structureChanged_ || structural;
    previewStale_ = previewStale_ || structural;
    // The view or scene changed under a refinement: the next still frame is the ray marcher's own.
    previewShown_ = false;
    refinePass_ = 0;
    return what;
}

GridMethod ViewerSession::previewTier() const {
    if (!adaptive_.options().previewTiers || !adaptive_.options().enabled || !input_.grid())
        return GridMethod::Raymarch;
    // The preview tiers classify by value alone: a gradient TF stays with the ray marcher.
    if (!finite_ || presets_[presetIndex_].tf.usesGradient()) return GridMethod::Raymarch;
    const Scene s = currentScene();
    const GridMethod m =
        s.camera->projection == Projection::Orthographic ? GridMethod::ShearWarp : GridMethod::Drc;
    return previewRefusal(s, m).empty() ? m : GridMethod::Raymarch;
}

ViewerFrame ViewerSession::renderFrame(int width, int height, bool interactive) {
    if (width <= 0 || height <= 0) throw UsageError("viewer: viewport size must be positive");
    const GridMethod tier = previewTier();
    if (tier != GridMethod::Raymarch) {
        if (interactive)
            return renderPreview(currentScene(), tier, tierAdaptive_.next().resolutionScale, width, height,
                                 true);
        if (previewShown_ || refinePass_ > 0) return refine(currentScene(), tier, width, height);
    }
    previewShown_ = false;
    return renderRaymarch(currentScene(), interactive ? adaptive_.next() : QualityLevel{}, width, height,
                          interactive);
}

namespace {

/// The image edge at `scale` of `full`, never below 16 pixels (or the viewport, if smaller): tiny frames are
/// all overhead.
int scaledEdge(int full, double scale) {
    return std::min(full, std::max(std::min(full, 16), int(std::lround(full * scale))));
}

} // namespace

ViewerFrame ViewerSession::renderRaymarch(Scene s, const QualityLevel& want, int width, int height,
                                          bool interactive) {
    ViewerFrame f;
    f.interactive = interactive;
    s.width = scaledEdge(width, want.resolutionScale);
    s.height = scaledEdge(height, want.resolutionScale);
    s.step = base_.step * want.stepScale;
    f.level.stepScale = want.stepScale;
    f.level.resolutionScale = std::sqrt(double(s.width) * s.height / (double(width) * height));

    // A k-buffer mesh drops internal faces for the level (the boundary always stays).
    auto* kbuffer = dynamic_cast<KBufferRenderer*>(renderer_.get());
    // Compressed bricks refine a view over frames instead of waiting for its whole working set.
    if (auto* bricks = dynamic_cast<BrickRenderer*>(renderer_.get()))
        bricks->setRefineBudget(base_.refineBricks.value_or(cc_.profile().rayMarch.refineBricksPerFrame),
                                base_.refineBricks ? 0.0 : cc_.profile().rayMarch.refineKernelShare);
    if (kbuffer) kbuffer->setLodFraction(want.faceFraction);
    f.level.faceFraction = kbuffer ? want.faceFraction : 1.0;

    const KernelDefines before = renderer_->plan().defines;
    Stopwatch sw;
    // Camera, size and step alone take the renderer's cheap path; effect or mode changes re-plan.
    if (structureChanged_)
        renderer_->setScene(s);
    else
        renderer_->setView(*s.camera, s.width, s.height, s.step);
    f.setupMs = sw.milliseconds();
    // A table rebuilt for a new step is a one-off cost: the frame still tells the controller what the
    // level costs once tableMs is taken out (with pre-integration every step change rebuilds one).
    f.tableMs = renderer_->lastTableMilliseconds();
    f.structureChanged = structureChanged_ || !(renderer_->plan().defines == before);
    structureChanged_ = false;
    sw.restart();
    // Multiple scattering converges over frames: one sample per pixel while the view moves, four more per
    // frame while it stands still.
    f.image = renderer_->plan().pathTracing ? renderer_->renderProgressive(interactive ? 1 : 4)
                                            : renderer_->render();
    f.renderMs = sw.milliseconds();
    f.kernelMs = renderer_->lastKernelMilliseconds();
    return f;
}

ViewerFrame ViewerSession::renderPreview(Scene s, GridMethod tier, double resolutionScale, int width,
                                         int height, bool interactive) {
    ViewerFrame f;
    f.interactive = interactive;
    s.gridMethod = tier;
    s.width = scaledEdge(width, resolutionScale);
    s.height = scaledEdge(height, resolutionScale);
    f.level.tier = tier;
    f.level.resolutionScale = std::sqrt(double(s.width) * s.height / (double(width) * height));
    Stopwatch sw;
    if (!preview_ || preview_->scene().gridMethod != tier) {
        preview_ = input_.makeRenderer(cc_, presets_[presetIndex_].tf, s);
        f.structureChanged = true;
    } else if (previewStale_) {
        preview_->setScene(s);
        f.structureChanged = true;
    } else {
        preview_->setView(*s.camera, s.width, s.height, s.step);
    }
    previewStale_ = false;
    f.setupMs = sw.milliseconds();
    sw.restart();
    f.image = preview_->render();
    f.renderMs = sw.milliseconds();
    // A run-length encoding built for a new principal axis is a one-off cost, as a table.
    f.tableMs = preview_->lastTableMilliseconds();
    f.kernelMs = preview_->lastKernelMilliseconds();
    previewShown_ = interactive;
    refinePass_ = 0;
    return f;
}

ViewerFrame ViewerSession::refine(const Scene& s, GridMethod tier, int width, int height) {
    ViewerFrame f;
    if (refinePass_ == 0) {
        // The first still frame renders both ends of the blend: the ray marcher's frame and the preview at
        // full resolution (the moving frames were smaller).
        f = renderRaymarch(s, QualityLevel{}, width, height, false);
        const ViewerFrame from = renderPreview(s, tier, 1.0, width, height, false);
        refineTo_ = f.image;
        refineFrom_ = from.image;
        f.setupMs += from.setupMs;
        f.renderMs += from.renderMs;
        f.kernelMs += from.kernelMs;
        f.structureChanged = f.structureChanged || from.structureChanged;
    }
    previewShown_ = false;
    ++refinePass_;
    f.refinePass = refinePass_;
    f.interactive = false;
    const double w = double(refinePass_) / double(kRefinePasses);
    f.image = w >= 1.0 ? refineTo_ : blendFrames(refineFrom_, refineTo_, w);
    f.level = QualityLevel{};
    if (refinePass_ < kRefinePasses)
        f.level.tier = tier;
    else {
        refinePass_ = 0;
        refineFrom_ = {};
        refineTo_ = {};
    }
    return f;
}

void ViewerSession::frameDone(const ViewerFrame& frame, double frameMs) {
    // Refinement frames render two images (or blend): they say nothing about either controller's cost.
    if (frame.structureChanged || frame.refinePass > 0) return;
    const double levelMs = frameMs - frame.tableMs;
    if (frame.level.tier != GridMethod::Raymarch) {
        if (frame.interactive) tierAdaptive_.report(frame.level, levelMs);
        return;
    }
    if (frame.interactive)
        adaptive_.report(frame.level, levelMs);
    else
        adaptive_.seed(levelMs);
}

std::string ViewerSession::compiledSummary() const {
    const EffectPlan& p = renderer_->plan();
    std::vector<std::string> parts;
    if (p.shading) parts.push_back(p.sobel ? "shading (sobel)" : "shading");
    if (p.shadows) parts.push_back("shadows");
    if (p.scattering) parts.push_back("scattering");
    if (p.clipping) parts.push_back("clipping");
    if (!p.isosurfaces.empty()) parts.push_back("isosurfaces " + std::to_string(p.isosurfaces.size()));
    if (base_.mode == RenderMode::Dvr && base_.preintegration != Preintegration::None)
        parts.push_back("preint " + std::string(preintegrationName(base_.preintegration)));
    if (p.skipping) parts.push_back("skipping");
    if (p.earlyTermination) parts.push_back("early termination");
    std::string s;
    for (const auto& x : parts)
        s += (s.empty() ? "" : ", ") + x;
    return s.empty() ? "no effects" : s;
}

std::string ViewerSession::title(const ViewerFrame& last, double frameMs) const {
    std::ostringstream os;
    os << "volcl view | " << renderModeName(base_.mode) << " | " << compiledSummary() << " | TF "
       << tfPresetName() << " | " << last.image.width << 'x' << last.image.height << " step "
       << formatNumber(base_.step * last.level.stepScale, 3) << " | ";
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.0f ms (%.1f fps)", frameMs, frameMs > 0 ? 1000.0 / frameMs : 0.0);
    os << buf;
    if (adaptive_.options().enabled)
        os << " | adaptive " << formatNumber(adaptive_.options().targetMs, 3) << " ms";
    if (last.level.faceFraction < 1.0)
        os << " | faces " << formatNumber(100.0 * last.level.faceFraction, 3) << " %";
    if (last.level.tier != GridMethod::Raymarch)
        os << " [" << gridMethodName(last.level.tier)
           << (last.refinePass > 0
                   ? ", refining " + std::to_string(last.refinePass) + "/" + std::to_string(kRefinePasses)
                   : std::string())
           << "]";
    else if (!last.level.full())
        os << " [interactive]";
    return os.str();
}

} // namespace volcl::viewer
