// The compressed-brick renderer: per-frame working set, budget fitting, pool uploads, page table, launch.
#include "render/bricks/BrickRenderer.hpp"

#include "cl/volcl_shared.h"
#include "core/Error.hpp"
#include "core/MemoryBudget.hpp"
#include "core/Volume.hpp"
#include "core/runtime/Timing.hpp"
#include "preintegration/PreintegrationTable.hpp"
#include "render/FogDevice.hpp"
#include "render/FrameParams.hpp"
#include "render/VecMath.hpp"
#include "render/bricks/BrickGradientCache.hpp"
#include "render/bricks/BrickLightField.hpp"
#include "render/bricks/BrickPool.hpp"
#include "render/grid/GradientCache.hpp"
#include "render/grid/LightVolume.hpp"
#include "wavelet/Codec.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <numeric>
#include <optional>
#include <set>
#include <sstream>

namespace volcl {

namespace {

constexpr std::uint32_t kHeaderWords = 16; // VOLCL_BRICK_HEADER in cl/common/brick_sample.h
constexpr std::size_t kMaxPoolFloats = std::size_t(1) << 32;

ValueRange frameRange(const VczHeader& h, std::size_t frame) {
    ValueRange r{std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
    for (const VczBrickEntry& e : h.bricks[frame]) {
        r.min = std::min(r.min, e.min);
        r.max = std::max(r.max, e.max);
    }
    return r; // an Inf here: a file from before the encoder kept brick ranges finite (refused by the caller)
}

WorldBox vczBounds(const VczHeader& h) {
    return {h.origin,
            {double(h.dims.x - 1) * h.spacing[0], double(h.dims.y - 1) * h.spacing[1],
             double(h.dims.z - 1) * h.spacing[2]}};
}

} // namespace

void BrickStats::add(const BrickStats& f) {
    frames += f.frames;
    visited += f.visited;
    reachable += f.reachable;
    hidden += f.hidden;
    decoded += f.decoded;
    hits += f.hits;
    bytesDecoded += f.bytesDecoded;
    voxelsDecoded += f.voxelsDecoded;
    coarsened += f.coarsened;
    evictions += f.evictions;
    repacks += f.repacks;
    moved += f.moved;
    peakPoolBytes = std::max(peakPoolBytes, f.peakPoolBytes);
    decodeMs += f.decodeMs;
    gradientBricks += f.gradientBricks;
    gradientMs += f.gradientMs;
    pending += f.pending;
    coarseFirst += f.coarseFirst;
}

std::string BrickStats::summary() const {
    std::ostringstream os;
    os << "bricks visited " << visited << " (reachable " << reachable << ", hidden by the TF " << hidden
       << "), decoded " << decoded << ", cache hits " << hits << ", misses " << decoded << ", bytes decoded "
       << bytesDecoded << " (" << voxelsDecoded << " voxels), peak cache " << std::fixed
       << std::setprecision(2) << double(peakPoolBytes) / (1024.0 * 1024.0) << " MB, evictions " << evictions;
    if (coarsened) os << ", coarsened to fit the budget " << coarsened;
    if (pending)
        os << ", drawn coarser while refining " << pending << " (" << coarseFirst
           << " at their coarsest level first)";
    if (repacks) os << ", pool repacked " << repacks << " (" << moved << " bricks moved, not decoded)";
    os << ", decode " << std::setprecision(1) << decodeMs << " ms";
    if (gradientBricks)
        os << ", gradient cache built for " << gradientBricks << " bricks in " << std::setprecision(2)
           << gradientMs << " ms";
    return os.str();
}

struct BrickRenderer::Impl {
    const VczHeader* h = nullptr;
    std::optional<LodStatistics> stats;
    int maxLevel = 0;
    ValueRange range;
    std::vector<char> nonFinite; ///< per brick: holds NaN/Inf voxels (the file's kVczNonFiniteKey)
    bool hasNonFinite = false;
    std::optional<Volume> whole; ///< P/B frames: decoded once (they decode whole, at level 0 only)
    std::optional<BrickCache> cache;
    double poolMb = -1;
    DeviceBuffer<float> pool;
    bool poolWords = false;       ///< the pool holds a gradient word after its samples (delta: the capacity)
    BrickGradientCache gradients; ///< which bricks' words are current
    DeviceBuffer<cl_uchar> empty;
    FogDevice fog; ///< FOG: parameters and the height-map buffer
    /// The kernels' gradient-cache argument (raymarch.cl) when the scene shades without the cache: one unused
    /// word (with it, the pool is bound: its words sit beside the samples).
    DeviceBuffer<cl_uint> noGradientCache;
    /// SHADOW_VOLUME: every brick at the light plan's level (built on the first such frame, kept while the
    /// level stays) and the light volumes swept through it.
    DeviceBuffer<float> lightField;
    int lightFieldLevel = -1;
    LightVolume lightVolume;
    double lightVolumeMs = 0.0; ///< the last build, with the field's decode when that build decoded it
    double lightFieldMs = 0.0;  ///< the field's last decode and upload
    cl::Kernel kernel;
    bool packet = false;
    VolclGridRenderParams params{};
    std::size_t pageFloats() const { return kHeaderWords + 4 * h->brickCount(); }
};

BrickRenderer::BrickRenderer(ComputeContext& cc, std::shared_ptr<const VczReader> reader, std::size_t frame,
                             const TransferFunction& tf, const Scene& scene)
    : RendererBase(cc, tf, scene), reader_(std::move(reader)), frame_(frame),
      impl_(std::make_unique<Impl>()) {
    Impl& m = *impl_;
    m.h = &reader_->header();
    const VczHeader& h = *m.h;
    if (frame_ >= h.frames.size())
        throw UsageError("--frame " + std::to_string(frame_) + " out of range: " + reader_->name() + " has " +
                         std::to_string(h.frames.size()) + " frame(s)");
    if (h.dims.count() >= (std::size_t(1) << 32))
        throw DataError(reader_->name() + ": the brick renderer indexes at most 2^32 - 1 voxels");
    m.stats = LodStatistics::fromHeader(h, reader_->name());
    m.range = frameRange(h, frame_);
    m.nonFinite.assign(h.brickCount(), 0);
    for (std::size_t b : vczNonFiniteBricks(h, frame_))
        m.nonFinite[b] = 1;
    m.hasNonFinite = std::find(m.nonFinite.begin(), m.nonFinite.end(), 1) != m.nonFinite.end();
    // Files written before the encoder listed NaN/Inf bricks: an Inf shows in the index's ranges.
    if (!std::isfinite(m.range.min) || !std::isfinite(m.range.max))
        throw DataError(reader_->name() + ": frame " + std::to_string(frame_) +
                        " holds Inf voxels but the file does not list its NaN/Inf bricks (written by an "
                        "older volcl): decode and re-encode it (volcl decode, volcl encode)");
    const bool intra = h.frames[frame_].type == FrameType::I;
    m.maxLevel = intra && h.transform != TransformKind::RawBits ? h.levels : 0;
    if (!intra) m.whole = reader_->decodeFrame(cc_, frame_);
    start(vczBounds(*impl_->h), impl_->range);
}

BrickRenderer::~BrickRenderer() = default;

EffectPlan BrickRenderer::planEffects(const Scene& scene) const {
    // The two table paths need tables built from a whole volume's renderer state; bricks shade per sample.
    Scene s = scene;
    std::vector<std::string> notes;
    if (s.effects.shadingPreintegrated) {
        s.effects.shadingPreintegrated = false;
        notes.push_back(
            "pre-integrated lighting: compressed bricks are lit per sample (decode the file for the table)");
    }
    if (s.effects.isoTable) {
        s.effects.isoTable = false;
        notes.push_back("iso-surface table: compressed bricks find iso-surfaces by exact roots");
    }
    EffectPlan p = volcl::planEffects(
        s, bounds(), impl_->range,
        std::to_string(std::min({impl_->h->brick.x, impl_->h->brick.y, impl_->h->brick.z})) +
            "^3-voxel macrocells over the brick index");
    p.defines.set("VOXEL_TYPE", 0LL);
    planNanColor(s, impl_->hasNonFinite, p);
    if (p.shadows && s.effects.shadowMethod == ShadowMethod::Volume) {
        const BrickLightPlan lp = lightPlan(s);
        planShadowVolume(s, lp.cell, lp.how(), p);
    }
    // One word per pool sample, in a second pool region as large as the samples' (render.cache_mb again).
    const double poolBytes =
        std::min(s.cacheMb * 1024.0 * 1024.0, double(impl_->h->dims.count() * sizeof(float)));
    planGradientCache(
        s, std::size_t(poolBytes), cc_.device().maxAllocBytes,
        std::to_string(kGradientCacheBytesPerVoxel) +
            " bytes per pool sample beside it, built when its brick becomes resident (and again "
            "when a face neighbour changes level or residency)",
        p);
    for (std::string& n : notes)
        p.dropped.push_back(std::move(n));
    return p;
}

BrickLightPlan BrickRenderer::lightPlan(const Scene& scene) const {
    const Impl& m = *impl_;
    return planBrickLightVolume(*m.h, m.maxLevel, m.nonFinite, scene.effects.lightVolumeCell,
                                std::max<std::size_t>(scene.lights.size(), 1),
                                scene.cacheMb * 1024.0 * 1024.0, reader_->name());
}

void BrickRenderer::updateLightVolume() {
    Impl& m = *impl_;
    const BrickLightPlan lp = lightPlan(scene_);
    double fieldMs = 0.0;
    if (m.lightFieldLevel != lp.level) {
        const Stopwatch sw;
        m.lightField =
            buildBrickLightField(cc_, *reader_, frame_, m.whole ? &*m.whole : nullptr, lp, m.nonFinite);
        m.lightFieldLevel = lp.level;
        m.lightFieldMs = fieldMs = sw.milliseconds();
    }
    LightVolume::Inputs in;
    in.voxels = &m.lightField.get();
    in.knots = &knots().get();
    in.knotCount = knotCount();
    EffectPlan nan; // how the sweep reads the field: float samples, the NaN colour
    planNanColor(scene_, m.hasNonFinite, nan);
    in.defines = nan.defines;
    in.defines.set("VOXEL_TYPE", 0LL);
    in.source = "render/light_volume_bricks.cl";
    in.grid = m.params.grid;
    in.lights = sweptLights(m.params.lighting, camera_);
    in.cell = lp.cell;
    in.step = m.params.lighting.shadowStep;
    std::ostringstream key;
    key << std::setprecision(17) << lp.level << ' ' << nanExtinction(scene_) << ' ' << tf_.toJson() << ' '
        << plan_.colorScale;
    in.fieldKey = key.str();
    in.headToleranceDeg = scene_.effects.headLightToleranceDeg;
    const WorldBox box = bounds();
    in.centre = add(box.origin, scale(box.extent, 0.5));
    if (m.lightVolume.update(cc_, in)) m.lightVolumeMs = fieldMs + m.lightVolume.lastBuildMilliseconds();
    m.params.lightVolume = m.lightVolume.params();
}

int BrickRenderer::lightVolumeBuilds() const noexcept {
    return impl_->lightVolume.builds();
}

double BrickRenderer::lastLightVolumeMilliseconds() const noexcept {
    return impl_->lightVolumeMs;
}

void BrickRenderer::admitScene(const Scene& next) {
    if (next.filter != ReconstructionFilter::Linear || next.smoothing > 0.0)
        throw UsageError(reader_->name() +
                         ": compressed bricks render with the linear filter and no smoothing "
                         "(decode the file for cubic filters)");
    next.validateSteps(norm(bounds().extent));
}

void BrickRenderer::viewChanged(bool sameView) {
    (void)sameView;
    impl_->params.camera = cameraParams(camera_, scene_.width, scene_.height);
}

void BrickRenderer::makePool(bool words) {
    Impl& m = *impl_;
    const VczHeader& h = *m.h;
    // Granule: a brick's samples at the coarsest level; the top block holds a whole level-0 brick.
    const Dims coarse = brickSamples(h, 0, m.maxLevel);
    const std::size_t granule = std::max<std::size_t>(1, coarse.count());
    const BuddyAllocator probe(granule, 0, 1);
    int top = 0;
    while (probe.blockFloats(top) < h.brick.count())
        ++top;
    const BuddyAllocator full(granule, top, 1);
    // No more than the whole frame at level 0 needs.
    std::size_t wanted = 0;
    for (std::size_t b = 0; b < h.brickCount(); ++b)
        wanted += full.blockFloats(full.orderFor(brickSamples(h, b, 0).count()));
    const double budgetFloats = scene_.cacheMb * 1024.0 * 1024.0 / sizeof(float);
    std::size_t capacity = std::size_t(std::min<double>(budgetFloats, double(wanted)));
    while (top > 0 && full.blockFloats(top) > capacity)
        --top;
    const BuddyAllocator sized(granule, top, 1);
    // Top blocks: as many as the budget holds, but no more than the whole frame needs (edge bricks take
    // smaller blocks, so that is the rounded-up share of `wanted`).
    const std::size_t topFloats = sized.blockFloats(top);
    const std::size_t count = std::min<std::size_t>(std::size_t(budgetFloats / double(topFloats)),
                                                    (wanted + topFloats - 1) / topFloats);
    if (count == 0)
        throw UsageError("render.cache_mb " + std::to_string(scene_.cacheMb) +
                         " is below one brick at the coarsest level (" +
                         std::to_string(double(granule * sizeof(float)) / (1024.0 * 1024.0)) + " MB)");
    // What the brick path holds of the file: this pool (host memory on a CPU device) and the index; never the
    // decoded frame, which may be larger than memory.
    const BuddyAllocator planned(granule, top, count);
    checkMemoryBudget((m.pageFloats() + (words ? 2 : 1) * planned.capacity()) * sizeof(float) +
                          h.brickCount() * h.frames.size() * sizeof(VczBrickEntry),
                      0, reader_->name(),
                      "the brick pool of render.cache_mb " + std::to_string(scene_.cacheMb) +
                          " with the index");
    if (m.pageFloats() + (words ? 2 : 1) * count * sized.blockFloats(top) > kMaxPoolFloats)
        throw UsageError("render.cache_mb " + std::to_string(scene_.cacheMb) +
                         " exceeds the 16 GiB the page table addresses");
    m.cache.emplace(planned);
    // With words the device writes the pool too (cl/render/brick_gradient_cache.cl); the samples only the host.
    m.pool = cc_.allocate<float>(m.pageFloats() + (words ? 2 : 1) * m.cache->allocator().capacity(),
                                 words ? CL_MEM_READ_WRITE : CL_MEM_READ_ONLY);
    m.poolMb = scene_.cacheMb;
    m.poolWords = words;
    m.gradients.reset();
}

void BrickRenderer::rebuild(const Rebuild& change) {
    Impl& m = *impl_;
    const bool cached = plan_.gradientCache != 0;
    if (m.poolMb != scene_.cacheMb || (cached && !m.poolWords)) makePool(cached || m.poolWords);
    if (const std::optional<TableSpec> spec = marchTableSpec())
        selectPreintegrationTable(change.shaded, *spec);
    m.packet = packetServesLit(scene_, plan_) && (!plan_.shading || cached);
    m.kernel =
        cc_.kernel("render/raymarch_bricks.cl", m.packet ? "raymarch_packet" : "raymarch", plan_.defines);

    const VczHeader& h = *m.h;
    VolclGridRenderParams& p = m.params;
    p = VolclGridRenderParams{};
    p.camera = cameraParams(camera_, scene_.width, scene_.height);
    p.clip = clipParams(plan_.clipPlanes);
    p.march = marchParams(scene_, m.range);
    p.tf = tfParams(scene_, tf_, knotCount(), tableLengths());
    const double maxSpacing = std::max({h.spacing[0], h.spacing[1], h.spacing[2]});
    p.lighting = lightingParams(scene_, 1e-6 * std::max(m.range.max - m.range.min, 1e-30) / maxSpacing);
    p.iso = isoParams(plan_);
    for (int i = 0; i < 3; ++i) {
        p.grid.origin[i] = float(h.origin[std::size_t(i)]);
        p.grid.spacing[i] = float(h.spacing[std::size_t(i)]);
        p.grid.invSpacing[i] = float(1.0 / h.spacing[std::size_t(i)]);
    }
    p.grid.dims[0] = volcl_uint(h.dims.x);
    p.grid.dims[1] = volcl_uint(h.dims.y);
    p.grid.dims[2] = volcl_uint(h.dims.z);
    p.grid.gradientMax = gradientCacheScale(h.spacing, m.range);
    if (plan_.fog) p.fog = m.fog.update(cc_, scene_.effects.fog, bounds(), plan_.fogMap);
}

BrickSelection BrickRenderer::fitBudget(BrickSelection s, const BrickView& view, const TransferFunction& tf) {
    Impl& m = *impl_;
    const VczHeader& h = *m.h;
    const BuddyAllocator& a = m.cache->allocator();
    const LodStatistics* stats = m.stats ? &*m.stats : nullptr;
    std::size_t coarsened = 0;
    for (;;) {
        std::size_t need = 0;
        bool oversized = false;
        for (std::size_t b = 0; b < s.level.size(); ++b) {
            if (s.level[b] < 0) continue;
            const int order = a.orderFor(brickSamples(h, b, s.level[b]).count());
            if (order < 0)
                oversized = true;
            else
                need += a.blockFloats(order);
        }
        if (!oversized && need <= a.capacity()) break;
        // Coarsen the bricks whose next level costs the least error, a batch at a time.
        std::vector<std::pair<double, std::size_t>> cand;
        for (std::size_t b = 0; b < s.level.size(); ++b)
            if (s.level[b] >= 0 && s.level[b] < m.maxLevel && !m.nonFinite[b])
                cand.push_back({brickError(h, stats, frame_, b, s.level[b] + 1, tf, view), b});
        if (cand.empty())
            throw UsageError(reader_->name() + ": render.cache_mb " + std::to_string(scene_.cacheMb) +
                             " holds less than this view's working set at its coarsest levels (" +
                             std::to_string(double(need) * sizeof(float) / (1024.0 * 1024.0)) + " MB)");
        std::sort(cand.begin(), cand.end());
        const std::size_t batch = std::max<std::size_t>(1, cand.size() / 16);
        std::vector<int> forced = s.level;
        for (std::size_t b = 0; b < s.level.size(); ++b)
            if (forced[b] < 0) forced[b] = 0; // re-selected below: reachability and emptiness decide again
        for (std::size_t i = 0; i < batch; ++i)
            ++forced[cand[i].second];
        coarsened += batch;
        // Keep the coarsening of earlier rounds: forced levels for every brick.
        for (std::size_t b = 0; b < s.level.size(); ++b)
            if (s.level[b] < 0) forced[b] = std::max(forced[b], 0);
        s = selectBricks(h, stats, frame_, m.maxLevel, tf, view, forced);
    }
    last_.coarsened = coarsened;
    return s;
}

std::vector<int> BrickRenderer::progressiveLevels(const BrickSelection& s, const BrickView& view) {
    Impl& m = *impl_;
    const VczHeader& h = *m.h;
    std::vector<int> draw(s.level.size(), 0); // bricks out of the working set: selectBricks drops them again
    std::vector<std::pair<double, std::size_t>> missing; // (-pixels on screen, brick)
    for (std::size_t b = 0; b < s.level.size(); ++b) {
        if (s.level[b] < 0) continue;
        draw[b] = s.level[b];
        if (!m.cache->holds({frame_, b, s.level[b]})) missing.push_back({-brickPixels(h, b, view), b});
    }
    // Largest on screen first (nearest, for bricks of one size), then in brick order.
    std::sort(missing.begin(), missing.end());
    // Beyond the fixed count, bricks whose predicted decode fits the share of the last kernel time.
    const double msPerByte = total_.bytesDecoded ? total_.decodeMs / double(total_.bytesDecoded) : 0.0;
    double predictedMs = 0.0;
    std::size_t now = std::min(refinePerFrame_, missing.size());
    while (now < missing.size() && msPerByte > 0.0) {
        predictedMs += msPerByte * double(h.bricks[frame_][missing[now].second].size);
        if (predictedMs > refineKernelShare_ * lastMs_) break;
        ++now;
    }
    for (std::size_t i = now; i < missing.size(); ++i) {
        const std::size_t b = missing[i].second;
        // A coarser level already held draws at no cost; else the coarsest, a fraction of the brick's samples.
        int level = m.maxLevel;
        for (int l = s.level[b] + 1; l < m.maxLevel; ++l)
            if (m.cache->holds({frame_, b, l})) {
                level = l;
                break;
            }
        if (level == m.maxLevel && !m.cache->holds({frame_, b, level})) ++last_.coarseFirst;
        draw[b] = level;
        ++last_.pending;
    }
    return draw;
}

void BrickRenderer::loadBricks(const BrickSelection& s) {
    Impl& m = *impl_;
    const VczHeader& h = *m.h;
    std::vector<std::size_t> work;
    std::set<BrickCache::Key> pinned;
    for (std::size_t b = 0; b < s.level.size(); ++b)
        if (s.level[b] >= 0) {
            work.push_back(b);
            pinned.insert({frame_, b, s.level[b]});
        }
    // Largest first, so that a pool rebuilt from empty packs without fragments.
    std::stable_sort(work.begin(), work.end(), [&](std::size_t x, std::size_t y) {
        return brickSamples(h, x, s.level[x]).count() > brickSamples(h, y, s.level[y]).count();
    });
    std::vector<float> page = brickPageTable(h, s.standIn);
    page[6] =
        brickPageWord(m.poolWords ? std::uint32_t(m.cache->allocator().capacity()) : 0u); // to the words
    last_.visited = work.size();
    // Slots first (hits from the pool, room for the misses), then the data: a pool fragmented by bricks kept
    // from earlier frames is repacked without decoding again what it already holds.
    std::vector<CachedBrick> slot(s.level.size());
    std::vector<char> decode(s.level.size(), 0);
    bool placed = true;
    for (std::size_t b : work) {
        const BrickCache::Key key{frame_, b, s.level[b]};
        if (const CachedBrick* hit = m.cache->touch(key)) {
            slot[b] = *hit;
            continue;
        }
        const std::optional<CachedBrick> room =
            m.cache->insert(key, brickSamples(h, b, s.level[b]).count(), pinned);
        if (!room) {
            placed = false;
            break;
        }
        slot[b] = *room;
        decode[b] = 1;
    }
    if (!placed) {
        std::vector<std::pair<BrickCache::Key, std::size_t>> ws;
        for (std::size_t b : work)
            ws.push_back({{frame_, b, s.level[b]}, brickSamples(h, b, s.level[b]).count()});
        const auto placements = m.cache->repack(std::move(ws));
        if (!placements)
            throw Error("internal: the brick pool cannot hold a working set that fits its budget");
        // Read every moving brick before writing any: old and new places may overlap.
        std::vector<std::pair<const BrickCache::Placement*, std::vector<float>>> moving;
        for (const BrickCache::Placement& p : *placements) {
            const std::size_t b = std::get<1>(p.key);
            const bool filled = p.resident && !decode[b]; // slots taken this frame hold nothing yet
            slot[b] = p.slot;
            decode[b] = filled ? 0 : 1;
            if (filled && p.from != p.slot.offset) {
                std::vector<float> samples(p.slot.floats);
                cc_.read(m.pool, std::span<float>(samples), m.pageFloats() + p.from);
                moving.push_back({&p, std::move(samples)});
            }
        }
        for (const auto& [p, samples] : moving)
            cc_.write(m.pool, std::span<const float>(samples), m.pageFloats() + p->slot.offset);
        ++last_.repacks;
        last_.moved += moving.size();
    }
    for (std::size_t b : work) {
        const int level = s.level[b];
        if (decode[b]) {
            Stopwatch sw;
            Volume v;
            try {
                if (m.whole) {
                    const Dims o = h.brickOrigin(b), d = h.brickDims(b);
                    v = m.whole->cropped(o, {o.x + d.x, o.y + d.y, o.z + d.z});
                } else {
                    v = reader_->decodeBrick(cc_, frame_, b, level);
                }
            } catch (...) {
                m.cache->clear(); // slots of this frame hold no samples: none may be found as a hit later
                throw;
            }
            const std::vector<float> samples = v.toFloat();
            if (samples.size() != slot[b].floats)
                throw Error("internal: decoded brick has an unexpected size");
            cc_.write(m.pool, std::span<const float>(samples), m.pageFloats() + slot[b].offset);
            last_.decodeMs += sw.milliseconds();
            ++last_.decoded;
            last_.bytesDecoded += h.bricks[frame_][b].size;
            last_.voxelsDecoded += samples.size();
        } else {
            ++last_.hits;
        }
        page[kHeaderWords + 4 * b + 0] = brickPageWord(std::uint32_t(m.pageFloats() + slot[b].offset));
        page[kHeaderWords + 4 * b + 1] = brickPageWord(std::uint32_t(level));
    }
    last_.peakPoolBytes = m.cache->allocator().usedFloats() * sizeof(float);
    cc_.write(m.pool, std::span<const float>(page), 0);
    if (m.poolWords) {
        // Without the cache this frame, bricks written now are only marked stale for a later cached frame.
        if (plan_.gradientCache == 0)
            m.gradients.forget(decode);
        else
            last_.gradientMs =
                m.gradients.refresh(cc_, m.pool.get(), h, page, decode, m.params.grid, last_.gradientBricks);
    }
}

ImageBuffer BrickRenderer::render() {
    Impl& m = *impl_;
    const VczHeader& h = *m.h;
    last_ = BrickStats{};
    last_.frames = 1;
    const std::size_t evictionsBefore = m.cache->evictions();
    BrickView view;
    view.camera = camera_;
    view.width = scene_.width;
    view.height = scene_.height;
    view.lod = scene_.lod;
    view.lodError = scene_.lodError;
    for (const auto& iso : plan_.isosurfaces)
        view.isoValues.push_back(iso.value);
    view.isoOnly = scene_.mode == RenderMode::Iso;
    view.clipPlanes = plan_.clipPlanes;
    if (m.hasNonFinite) {
        view.nonFinite = m.nonFinite;
        view.nanVisible = scene_.nanColor[3] > 0.0;
    }
    const Preintegration pre = scene_.mode == RenderMode::Dvr ? scene_.preintegration : Preintegration::None;
    view.tableNodes = pre != Preintegration::None ? scene_.tableSize : 0;
    // MIP and x-ray see every value: nothing is hidden by the TF there.
    const bool tfHides = scene_.mode == RenderMode::Dvr || scene_.mode == RenderMode::Iso;
    TransferFunction culling = tf_;
    if (!tfHides) culling.extinction = {{tf_.domain[0], 1.0}};
    std::vector<int> forced = forced_;
    if (!forced.empty()) {
        if (forced.size() != h.brickCount()) throw UsageError("forced levels: one per brick");
        for (int& l : forced)
            l = std::clamp(l, 0, m.maxLevel);
    }
    BrickSelection s =
        selectBricks(h, m.stats ? &*m.stats : nullptr, frame_, m.maxLevel, culling, view, forced);
    s = fitBudget(std::move(s), view, culling);
    last_.reachable = s.reachable;
    last_.hidden = s.hidden;
    if (refinePerFrame_ > 0)
        s = selectBricks(h, m.stats ? &*m.stats : nullptr, frame_, m.maxLevel, culling, view,
                         progressiveLevels(s, view));
    loadBricks(s);
    last_.evictions = m.cache->evictions() - evictionsBefore;
    std::vector<unsigned char> empty = s.empty;
    if (!tfHides) std::fill(empty.begin(), empty.end(), 0);
    m.empty = cc_.upload(empty, CL_MEM_READ_ONLY);
    m.params.grid.macroDims[0] = s.macro.nx;
    m.params.grid.macroDims[1] = s.macro.ny;
    m.params.grid.macroDims[2] = s.macro.nz;
    m.params.grid.macroDims[3] = s.macro.edge;
    selection_ = std::move(s);
    total_.add(last_);

    ensureFrameBuffers();
    // The gradient cache is the pool's word region (GRADIENT_CACHE), else one unused word; the light volumes:
    // one float before the first build.
    if (m.noGradientCache.size() == 0) m.noGradientCache = cc_.allocate<cl_uint>(1);
    if (plan_.shadowVolume) updateLightVolume();
    if (plan_.gradientCache != 0)
        setArgs(m.kernel, m.pool, knots(), table(), m.empty, m.params, out_, depth_, m.fog.buffer(cc_),
                m.lightVolume.buffer(cc_), m.pool);
    else
        setArgs(m.kernel, m.pool, knots(), table(), m.empty, m.params, out_, depth_, m.fog.buffer(cc_),
                m.lightVolume.buffer(cc_), m.noGradientCache);
    const std::size_t w = std::size_t(scene_.width), hgt = std::size_t(scene_.height);
    cl::Event ev = m.packet
                       ? cc_.launch2d(m.kernel, (w + 3) / 4, (hgt + 1) / 2, cc_.profile().rayMarch.packet)
                       : cc_.launch2d(m.kernel, w, hgt, cc_.profile().rayMarch.tile);
    lastMs_ = eventMilliseconds(ev);
    ImageBuffer img = downloadFrame(!plan_.isosurfaces.empty());
    addFrameAttributes(img);
    img.attributes.push_back({"volcl:lod", std::string(lodModeName(scene_.lod))});
    return img;
}

std::vector<std::uint32_t> BrickRenderer::gradientWords(std::size_t b) const {
    const Impl& m = *impl_;
    if (!m.poolWords || b >= m.h->brickCount()) return {};
    float e[2];
    cc_.read(m.pool, std::span<float>(e, 2), kHeaderWords + 4 * b);
    std::uint32_t off, level;
    std::memcpy(&off, &e[0], 4);
    std::memcpy(&level, &e[1], 4);
    if (level == kBrickAbsent) return {};
    std::vector<float> w(brickSamples(*m.h, b, int(level)).count());
    cc_.read(m.pool, std::span<float>(w), off + m.cache->allocator().capacity());
    std::vector<std::uint32_t> out(w.size());
    std::memcpy(out.data(), w.data(), w.size() * 4);
    return out;
}

double BrickRenderer::gradientCacheBuildMs() const noexcept {
    return total_.gradientBricks ? total_.gradientMs : -1.0;
}

std::string BrickRenderer::statistics() const {
    std::ostringstream os;
    os << "last frame: " << last_.summary();
    if (total_.frames > 1) os << "\nall " << total_.frames << " frames: " << total_.summary();
    if (plan_.shadowVolume)
        os << "\nlight volumes: " << impl_->lightVolume.builds() << " built from the bricks at level "
           << impl_->lightFieldLevel << ", last in " << std::fixed << std::setprecision(1)
           << impl_->lightVolumeMs << " ms (the field's decode: " << impl_->lightFieldMs << " ms)";
    // As the grid reports its cache: build time (all frames' builds) and size (the pool's word region).
    if (impl_->poolWords && total_.gradientBricks)
        os << "\ngradient cache: " << std::fixed << std::setprecision(2) << total_.gradientMs
           << " ms to build (" << total_.gradientBricks << " brick builds), "
           << impl_->cache->allocator().capacity() * kGradientCacheBytesPerVoxel << " bytes";
    return os.str();
}

} // namespace volcl
