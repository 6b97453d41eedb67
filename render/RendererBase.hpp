// What every renderer shares under the VolumeRenderer interface: scene, TF and view storage validated once
// at commit, the rebuild decision, the TF knots on the device, frame buffers and one table cache.
#pragma once

#include "cl/volcl_shared.h"
#include "core/runtime/Timing.hpp"
#include "preintegration/PreintegrationTable.hpp"
#include "render/VolumeRenderer.hpp"

#include <cstddef>
#include <list>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace volcl {

/// The one key format of cached tables: what the table is made from (a TF's JSON, an iso-surface list), its
/// spec, and a variant tag for tables built differently from the same inputs ("lighting").
std::string tableKey(std::string_view source, const TableSpec& spec, std::string_view variant = {});

/// Recently used tables by key, most recent last: an interactive viewer alternates between a few steps, and
/// a table costs 10-100 ms to rebuild (far more than a coarse frame). References stay valid until the entry
/// is evicted.
template <class Table> class TableCache {
public:
    explicit TableCache(std::size_t capacity) : capacity_(capacity) {}
    /// The table for `key`: the cached one (now the most recent), else make()'s.
    template <class Make> const Table& get(const std::string& key, Make&& make) {
        for (auto it = entries_.begin(); it != entries_.end(); ++it)
            if (it->first == key) {
                entries_.splice(entries_.end(), entries_, it);
                return entries_.back().second;
            }
        entries_.emplace_back(key, make());
        if (entries_.size() > capacity_) entries_.pop_front();
        return entries_.back().second;
    }

private:
    std::list<std::pair<std::string, Table>> entries_;
    std::size_t capacity_;
};

/// The base of the four renderers. A scene, TF or view is validated when it is committed (the constructor,
/// setScene, setTransferFunction, setView), never per frame; a committed scene or TF re-plans and calls the
/// renderer's rebuild(), a view of the same step only moves the camera (viewChanged()).
class RendererBase : public VolumeRenderer {
public:
    RendererBase(const RendererBase&) = delete; ///< a renderer owns device buffers: one per owner
    RendererBase& operator=(const RendererBase&) = delete;

    void setScene(const Scene& scene) override;
    void setTransferFunction(const TransferFunction& tf) override;
    /// A new step re-plans as setScene (unless stepNeedsRebuild() says the renderer ignores the step).
    void setView(const Camera& camera, int width, int height, double step) override;

    /// The data's world box and value range, fixed when the renderer starts.
    WorldBox bounds() const final { return box_; }
    ValueRange valueRange() const final { return range_; }
    const cl::Buffer& outputBuffer() const noexcept override { return out_.get(); }
    const EffectPlan& plan() const noexcept override { return plan_; }
    const Scene& scene() const noexcept override { return scene_; }
    const Camera& camera() const noexcept override { return camera_; }
    double lastKernelMilliseconds() const noexcept override { return lastMs_; }
    double lastTableMilliseconds() const noexcept override { return tableMs_; }

protected:
    /// A float4 table on the device and its slice count (1 for 2D tables).
    struct DeviceTable {
        DeviceBuffer<cl_float4> values;
        int lengths = 1;
    };
    /// What changed since the last rebuild, for the renderer's own part of it.
    struct Rebuild {
        const TransferFunction& shaded; ///< the TF with the plan's colour scale folded into its colours
        bool tfChanged = false;
        bool knotsChanged = false; ///< knots() were uploaded again
    };

    /// Validates the scene and the TF (UsageError, DataError). Derived constructors finish with start().
    RendererBase(ComputeContext& cc, const TransferFunction& tf, const Scene& scene);
    /// Takes the data's world box and value range, admits the constructor's scene and builds everything
    /// for it (rebuild with the TF changed).
    void start(const WorldBox& box, const ValueRange& range);

    /// Refuses (UsageError) a validated scene this renderer cannot draw, before anything changes, and takes
    /// what it keeps from it. Called on every committed scene (a view of the same step is not one).
    virtual void admitScene(const Scene& next) { (void)next; }
    /// The renderer's part of a rebuild: plan_, camera_ and the knots are current.
    virtual void rebuild(const Rebuild& change) = 0;
    /// The camera or image size moved (same step); `sameView`: neither did.
    virtual void viewChanged(bool sameView) { (void)sameView; }
    /// True for renderers whose kernels classify by gradient magnitude (TF_GRADIENT, checkGradientTf()).
    virtual bool drawsGradientTf() const { return false; }
    /// True for renderers whose kernels draw label maps (LABELS, checkLabels()).
    virtual bool drawsLabels() const { return false; }
    /// False for renderers whose frames do not depend on render.step (no re-plan on a new step).
    virtual bool stepNeedsRebuild() const { return true; }

    /// Device knots of the shaded TF, their count, and the packed host copy.
    const DeviceBuffer<VolclTfKnot>& knots() const noexcept { return knots_; }
    std::size_t knotCount() const noexcept { return hostKnots_.size(); }
    const std::vector<VolclTfKnot>& hostKnots() const noexcept { return hostKnots_; }

    /// Makes the table for `key` current (table(), tableLengths()): the cached one, else make()'s, timed.
    template <class Make> void selectTable(const std::string& key, Make&& make) {
        const DeviceTable& t = cachedTable(tables_, key, std::forward<Make>(make));
        table_ = t.values;
        tableLengths_ = t.lengths;
    }
    /// The pre-integration table a ray marcher of the scene's step reads: 2D for the step, or 3D with lengths
    /// up to it; none outside DVR or without pre-integration.
    std::optional<TableSpec> marchTableSpec() const;
    /// selectTable() of the pre-integration table of `shaded` for `spec`.
    void selectPreintegrationTable(const TransferFunction& shaded, const TableSpec& spec);
    /// The current table and its slice count; before the first selection a one-texel buffer, since a kernel
    /// argument must always be bound.
    const DeviceBuffer<cl_float4>& table() const noexcept { return table_; }
    int tableLengths() const noexcept { return tableLengths_; }
    /// `cache.get(key, make)`, with a build's time in lastTableMilliseconds().
    template <class Table, class Make>
    const Table& cachedTable(TableCache<Table>& cache, const std::string& key, Make&& make) {
        return cache.get(key, [&] {
            Stopwatch sw;
            Table t = make();
            tableMs_ = sw.milliseconds();
            return t;
        });
    }

    /// Sizes out_ and depth_ to the scene's image; true when they were reallocated.
    bool ensureFrameBuffers();
    /// out_ (and depth_ as channel Z) as an image, before attributes.
    ImageBuffer downloadFrame(bool withDepth);
    /// The attributes every ray caster's image carries: mode, `method` (when given), step, pre-integration,
    /// effects.
    void addFrameAttributes(ImageBuffer& img, std::string_view method = {}) const;

    WorldBox box_;
    ValueRange range_;
    ComputeContext& cc_;
    TransferFunction tf_;
    Scene scene_;
    Camera camera_;
    EffectPlan plan_;
    DeviceBuffer<cl_float4> out_;
    DeviceBuffer<float> depth_;
    double lastMs_ = 0.0, tableMs_ = 0.0;

    /// Re-plans the committed scene and TF, refreshes the knots and calls rebuild().
    void replan(bool tfChanged);

private:
    DeviceBuffer<VolclTfKnot> knots_;
    std::vector<VolclTfKnot> hostKnots_;
    TableCache<DeviceTable> tables_{8};
    DeviceBuffer<cl_float4> table_;
    int tableLengths_ = 1;
};

} // namespace volcl
