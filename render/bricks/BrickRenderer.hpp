// The compressed-brick renderer: ray marching straight from a .vcz, decoding only the bricks a frame needs
// at the level it needs, into a device brick pool with an LRU budget.
#pragma once

#include "render/RendererBase.hpp"
#include "render/bricks/BrickLightField.hpp"
#include "render/bricks/BrickLod.hpp"

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

namespace volcl {

class VczReader;

/// Counters of the brick cache (`volcl render --stats`).
struct BrickStats {
    std::size_t frames = 0;
    std::size_t visited = 0;       ///< bricks in the working set (decoded or found in the pool)
    std::size_t reachable = 0;     ///< bricks some ray can reach
    std::size_t hidden = 0;        ///< reachable bricks the transfer function hides (never decoded)
    std::size_t decoded = 0;       ///< cache misses: bricks decoded
    std::size_t hits = 0;          ///< bricks found in the pool at the wanted level
    std::size_t bytesDecoded = 0;  ///< compressed payload bytes read by the decodes
    std::size_t voxelsDecoded = 0; ///< samples the decodes produced
    std::size_t coarsened = 0; ///< bricks drawn coarser than chosen so that the working set fits the budget
    std::size_t evictions = 0;
    std::size_t repacks = 0; ///< frames whose pool, fragmented by earlier frames' bricks, was placed afresh
    std::size_t moved = 0;   ///< bricks those repacks moved inside the pool instead of decoding them again
    std::size_t peakPoolBytes = 0; ///< most pool bytes in use
    /// Progressive frames: bricks drawn coarser than their chosen level (refined by later frames), and of
    /// those, bricks decoded at their coarsest level because no level of them was resident.
    std::size_t pending = 0, coarseFirst = 0;
    double decodeMs = 0;
    std::size_t gradientBricks = 0; ///< bricks whose gradient-cache words were (re)built
    double gradientMs = 0;          ///< kernel time of those builds
    void add(const BrickStats& f);
    /// "bricks visited 12, decoded 12, ..." on one line.
    std::string summary() const;
};

/// Renders scenes of one frame of a .vcz (cl/render/raymarch_bricks.cl: the grid ray marcher's modes and effects,
/// samples read through a page table). Each render() computes the frame's working set and levels
/// (selectBricks), decodes what the pool lacks on the host, uploads it and marches. The reader must outlive
/// the renderer. Cubic filters and smoothing are refused (they need the whole grid). Example:
/// ```
/// auto reader = std::make_shared<const volcl::VczReader>(volcl::readFileBytes("head.vcz"), "head.vcz");
/// volcl::BrickRenderer r(cc, reader, 0, tf, scene);
/// volcl::ImageBuffer img = r.render();
/// std::cerr << r.lastStats().summary() << '\n';
/// ```
class BrickRenderer final : public RendererBase {
public:
    /// Throws UsageError for a scene the brick renderer cannot draw or a budget too small for one brick at
    /// its coarsest level, IoError for a corrupted brick met while rendering (naming the brick).
    BrickRenderer(ComputeContext& cc, std::shared_ptr<const VczReader> reader, std::size_t frame,
                  const TransferFunction& tf, const Scene& scene);
    ~BrickRenderer() override;

    EffectPlan planEffects(const Scene& scene) const override;
    ImageBuffer render() override;
    /// The cache counters of the last frame and of all frames so far.
    std::string statistics() const override;

    const BrickStats& lastStats() const noexcept { return last_; }
    const BrickSelection& lastSelection() const noexcept { return selection_; }
    /// Draws brick b at `levels[b]` (capped at the file's levels) instead of choosing levels (tests,
    /// benchmarks); an empty vector returns to render.lod. Reachability and the TF still decide what is
    /// decoded.
    void setForcedLevels(std::vector<int> levels) { forced_ = std::move(levels); }
    /// Progressive refinement (the viewer): each render() decodes `bricks` bricks at their chosen level,
    /// largest on screen first, and more while their predicted decode time (the payload bytes at the rate
    /// measured so far) stays within `kernelShare` times the last frame's kernel time; it draws the others
    /// from a coarser level already in the pool, or decodes their coarsest level first, and later frames of
    /// the view refine them. 0 bricks (the default): every brick at its chosen level before the launch.
    void setRefineBudget(std::size_t bricks, double kernelShare = 0.0) noexcept {
        refinePerFrame_ = bricks;
        refineKernelShare_ = kernelShare;
    }
    /// The last frame drew some brick coarser than chosen.
    bool refining() const noexcept override { return last_.pending > 0; }
    /// Light-volume builds since construction (a camera move alone rebuilds none for directional lights).
    int lightVolumeBuilds() const noexcept;
    /// The last light-volume build's wall time, with the decode of every brick into its field when that build
    /// needed it (the first, and after a change of level).
    double lastLightVolumeMilliseconds() const noexcept;
    /// The gradient-cache words of resident brick b as the device holds them (cl/common/brick_gradient_cache.h),
    /// one per sample at its drawn level; empty when the brick is absent or the pool has no words.
    std::vector<std::uint32_t> gradientWords(std::size_t b) const;
    /// Kernel time of the gradient-cache builds of all frames so far (-1: no frame used the cache).
    double gradientCacheBuildMs() const noexcept;

private:
    struct Impl;
    /// Refuses cubic filters and smoothing (they need the whole grid) and steps too small for the box.
    void admitScene(const Scene& next) override;
    bool drawsGradientTf() const override { return true; }
    void rebuild(const Rebuild& change) override;
    void viewChanged(bool sameView) override;
    /// A pool for the budget, with a gradient word region after the samples when `words`.
    void makePool(bool words);
    /// The light volumes' level, cell and memory for `scene` (effects.shadow_method volume).
    BrickLightPlan lightPlan(const Scene& scene) const;
    /// SHADOW_VOLUME: the field at the plan's level and the light volumes made current; params.lightVolume set.
    void updateLightVolume();
    /// Levels that fit the pool: coarsens the cheapest bricks until the working set fits.
    BrickSelection fitBudget(BrickSelection s, const BrickView& view, const TransferFunction& tf);
    void loadBricks(const BrickSelection& s);
    /// Progressive frames: the levels to draw this frame (refinePerFrame_ bricks at `s`'s level, the others
    /// at a resident coarser level or the coarsest), counting last_.pending and last_.coarseFirst.
    std::vector<int> progressiveLevels(const BrickSelection& s, const BrickView& view);
    std::shared_ptr<const VczReader> reader_;
    std::size_t frame_;
    std::unique_ptr<Impl> impl_;
    BrickSelection selection_;
    std::vector<int> forced_;
    std::size_t refinePerFrame_ = 0;
    double refineKernelShare_ = 0.0;
    BrickStats last_, total_;
};

} // namespace volcl
