// The grid's preview tiers as a renderer: shear-warp (cl/render/shearwarp.cl) and discrete ray casting
// (cl/render/drc.cl), chosen by render.method.
#pragma once

#include "render/RendererBase.hpp"

#include <memory>
#include <string>

namespace volcl {

class Volume;

/// Renders unshaded DVR of a grid with a preview tier (scene.gridMethod: ShearWarp or Drc), much cheaper than
/// the ray marcher and less exact (docs/rendering.md, "Preview tiers"). Shear-warp keeps one run-length-encoded
/// classified volume per principal axis, built on demand the first time a view needs that axis and dropped
/// when the TF changes. Refuses (UsageError) scenes it cannot draw: other modes, shading, iso-surfaces, clip
/// planes, pre-integration, fog, scattering, cubic filters, smoothing; shear-warp also refuses perspective
/// cameras. The volume must outlive the renderer. Example:
/// ```
/// scene.gridMethod = volcl::GridMethod::ShearWarp;
/// volcl::GridPreviewRenderer r(cc, volume, tf, scene);
/// volcl::ImageBuffer img = r.render();
/// ```
class GridPreviewRenderer final : public RendererBase {
public:
    /// Throws DataError for a volume with NaN/Inf voxels (the ray marcher draws those), UsageError as above.
    GridPreviewRenderer(ComputeContext& cc, const Volume& volume, const TransferFunction& tf,
                        const Scene& scene);
    ~GridPreviewRenderer() override;

    EffectPlan planEffects(const Scene& scene) const override;
    ImageBuffer render() override;
    /// "shear-warp: principal axis z, 2100 runs, 38.0% of cells visible, last encoding built in 310 ms" or
    /// "discrete ray casting: ...".
    std::string statistics() const override;
    /// Milliseconds of the last run-length encoding built (0 before any); lastTableMilliseconds() holds it for
    /// the frame that built it.
    double lastEncodingMilliseconds() const noexcept { return encodingMs_; }

private:
    struct Impl;
    void admitScene(const Scene& next) override;
    void rebuild(const Rebuild& change) override;
    bool stepNeedsRebuild() const override { return false; }
    ImageBuffer renderShearWarp();
    ImageBuffer renderDrc();
    const Volume& volume_;
    std::unique_ptr<Impl> impl_;
    double encodingMs_ = 0.0;
};

/// The reason `scene` cannot be drawn by render.method `method` (a preview tier), or empty when it can.
std::string previewRefusal(const Scene& scene, GridMethod method);

} // namespace volcl
