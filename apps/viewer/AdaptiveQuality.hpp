// Adaptive quality for interaction: sizes the next frame's work from the last frame's time (Callahan 5.1.1).
#pragma once

#include "render/Scene.hpp"

namespace volcl::viewer {

/// How much coarser than full quality one frame is rendered.
struct QualityLevel {
    double resolutionScale = 1.0; ///< image edge relative to the viewport, (0, 1]
    double stepScale = 1.0;       ///< ray step relative to the scene's step, >= 1
    /// The renderer: the ray marcher, or a grid's preview tier while the view moves (its step is fixed by the
    /// data: stepScale stays 1 and the work is all resolution).
    GridMethod tier = GridMethod::Raymarch;
    /// Fraction of a k-buffer mesh's internal faces drawn (KBufferRenderer::setLodFraction), (0, 1].
    double faceFraction = 1.0;
    /// Work relative to full quality: rays times samples per ray (times the faces drawn).
    double work() const noexcept { return resolutionScale * resolutionScale / stepScale * faceFraction; }
    bool full() const noexcept {
        return resolutionScale >= 1.0 && stepScale <= 1.0 && faceFraction >= 1.0 &&
               tier == GridMethod::Raymarch;
    }
};

struct AdaptiveQualityOptions {
    bool enabled = true;
    double targetMs = 100.0; ///< frame time to hold while the user interacts
    /// The controller aims at this fraction of the target. Frame times scatter by 10-20 % on a busy
    /// machine; aimed at the target itself, half the frames land above it and one in ten more than 20 %
    /// above. Aimed at 0.9, the median stays just under the target and overshoots past 20 % are rare.
    double aimFraction = 0.9;
    double minResolutionScale = 1.0 / 16.0;
    double maxStepScale = 4.0;
    /// Largest growth of the work per frame. Cuts are not limited (a frame far over the target is what
    /// interaction must never see twice); growth is, so one fast outlier cannot throw the next frame to an
    /// expensive extreme.
    double maxGrowth = 4.0;
    /// Step scales come from the ladder 2^(k/4): a pre-integration table is rebuilt per distinct step, so
    /// a few levels keep tables cached rather than rebuilt every frame.
    int stepLevelsPerOctave = 4;
    /// While the view moves, a grid scene the preview tiers can draw (unshaded DVR without effects) renders
    /// with shear-warp (orthographic cameras) or discrete ray casting (perspective), sized by a controller of
    /// its own; when the view stops, the ray marcher's frame is blended in over ViewerSession::kRefinePasses
    /// frames. Off: the ray marcher at a coarser step and resolution, as before.
    bool previewTiers = false;
    /// The renderer draws a subset of a mesh's faces (the k-buffer's level of detail, Callahan 5.1): the work
    /// goes to the face fraction first (the step is not used), down to minFaceFraction, then to resolution.
    bool faceLevels = false;
    double minFaceFraction = 0.01;
};

/// Frame-rate controller. While interacting, work_next = aim / cost, cost the frame time per unit of work
/// smoothed over frames (aim = aimFraction * target; after Callahan 2005,
/// section 5.1.1, which sizes the LOD face count the same way); the work is split between a coarser step
/// and a lower resolution, equally in log scale until the step reaches its limit, then by resolution alone
/// (with faceLevels: the face fraction alone until its limit, then resolution).
/// When the user is still, the viewer renders full quality and leaves the controller's state as it was, so
/// the next interaction starts from the level that held the target. Example:
/// ```
/// volcl::viewer::AdaptiveQuality aq({.targetMs = 100});
/// auto level = aq.next();            // level for the next interactive frame
/// double ms = renderAt(level);       // render + present, wall time
/// aq.report(level, ms);
/// ```
class AdaptiveQuality {
public:
    explicit AdaptiveQuality(const AdaptiveQualityOptions& options = {});
    const AdaptiveQualityOptions& options() const noexcept { return options_; }
    /// Off: every frame renders at full quality; the learnt work fraction is kept for when it is back on.
    void setEnabled(bool on) noexcept { options_.enabled = on; }
    /// Level for the next interactive frame (full quality when disabled).
    QualityLevel next() const;
    /// Records that a frame rendered at `used` took `frameMs`; non-finite or non-positive times are ignored.
    void report(const QualityLevel& used, double frameMs);
    /// A full-quality frame's time sets the starting work until the first interactive report, so the first
    /// interactive frame is already near the target instead of a full-quality one.
    void seed(double fullQualityMs);
    /// Work fraction the controller aims at for the next interactive frame.
    double work() const noexcept { return work_; }
    /// Splits a work fraction into step and resolution (exposed for tests and the benchmark).
    QualityLevel split(double work) const;
    /// Smallest work the limits allow (minimum resolution at the largest step, or the fewest faces).
    double minWork() const noexcept;

private:
    AdaptiveQualityOptions options_;
    double work_ = 1.0;
    double logCost_ = 0.0; ///< log of the smoothed frame time per unit of work
    bool reported_ = false, seeded_ = false;
};

} // namespace volcl::viewer
