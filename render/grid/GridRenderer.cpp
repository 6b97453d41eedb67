// The grid renderer: voxel upload, macrocell emptiness, tables, kernel parameters and launches.
#include "render/grid/GridRenderer.hpp"

#include "cl/volcl_shared.h"
#include "core/Error.hpp"
#include "core/Format.hpp"
#include "core/MemoryBudget.hpp"
#include "core/Volume.hpp"
#include "core/runtime/DeviceProfile.hpp"
#include "core/runtime/Timing.hpp"
#include "preintegration/PreintegrationTable.hpp"
#include "render/FogDevice.hpp"
#include "render/FrameParams.hpp"
#include "render/VecMath.hpp"
#include "render/grid/BsplineField.hpp"
#include "render/grid/GradientCache.hpp"
#include "render/grid/GridDetail.hpp"
#include "render/grid/LabelField.hpp"
#include "render/grid/LightVolume.hpp"
#include "render/grid/PathTracer.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <iomanip>
#include <limits>
#include <optional>
#include <sstream>

namespace volcl {
namespace {

/// VOXEL_TYPE: voxels keep their stored type on the device; the kernel converts on load (exact for all
/// four types). 0 float, 1 uint8, 2 uint16, 3 int16.
int voxelTypeCode(const Volume& volume) {
    return volume.type() == ScalarType::UInt8    ? 1
           : volume.type() == ScalarType::UInt16 ? 2
           : volume.type() == ScalarType::Int16  ? 3
                                                 : 0;
}

/// The iso-surface table's value range: the data's (widened when the data is constant).
std::array<double, 2> isoTableDomain(const ValueRange& r) {
    return {r.min, r.max > r.min ? r.max : r.min + 1.0};
}

/// The pre-integrated lighting table as three N x N slices of float4: (ambient rgb, alpha), (front diffuse
/// rgb, emission centroid), (back diffuse rgb, 0), built on the host in double.
std::vector<cl_float4> lightingTableSlices(const TransferFunction& tf, int size, double step) {
    const ImageBuffer img = lightingTableImage(tf, size, step);
    const std::size_t n = std::size_t(size) * std::size_t(size);
    std::vector<cl_float4> out(3 * n);
    const int nc = img.channelCount();
    for (std::size_t i = 0; i < n; ++i) {
        const float* px = img.pixels.data() + i * std::size_t(nc);
        out[i] = {{px[0], px[1], px[2], px[3]}};
        out[n + i] = {{px[4], px[5], px[6], px[10]}};
        out[2 * n + i] = {{px[7], px[8], px[9], 0.0f}};
    }
    return out;
}

std::string skippingHow(unsigned macrocellEdge) {
    return std::to_string(macrocellEdge) + "^3-voxel macrocells";
}

/// The shared planner on the grid's box and (already scanned) value range, plus the voxel type: the
/// renderer scans the volume once, not on every scene change (a 7M-voxel scan per adaptive-quality step
/// change cost more than the coarse frame).
EffectPlan planGrid(const Scene& scene, const Volume& volume, const ValueRange& range, unsigned macrocellEdge,
                    std::size_t nonFinite, std::uint64_t maxAllocBytes) {
    EffectPlan p = planEffects(scene, gridBounds(volume), range, skippingHow(macrocellEdge), true);
    planNanColor(scene, nonFinite > 0, p);
    planShadowVolume(scene, scene.effects.lightVolumeCell, "", p);
    // Integer voxels spanning at most 511 keep their differences exactly (GRADIENT_CACHE 3); the nearest voxel's
    // word stays octahedral.
    const bool exact =
        gradientCacheFormat(volume.type(), range.max - range.min) == GradientCacheFormat::ExactDifferences &&
        scene.effects.gradient == GradientKind::Cache;
    planGradientCache(scene, (volume.voxelCount() + 1) * kGradientCacheBytesPerVoxel, maxAllocBytes,
                      std::to_string(kGradientCacheBytesPerVoxel) + " bytes per voxel (" +
                          (exact ? "the integer voxel differences, exact: the values span at most 511"
                                 : "12+12-bit octahedral direction, 8-bit norm") +
                          "), built once per volume",
                      p, exact ? gradientCacheDefine(GradientCacheFormat::ExactDifferences) : 1);
    // The cubic filters read float spline coefficients instead of the voxels; smoothing, float voxels.
    p.defines.set("VOXEL_TYPE", scene.filter == ReconstructionFilter::Linear && scene.smoothing == 0.0
                                    ? static_cast<long long>(voxelTypeCode(volume))
                                    : 0LL);
    return p;
}

} // namespace

WorldBox gridBounds(const Volume& volume) {
    const Dims& d = volume.dims();
    return {volume.origin,
            {double(d.x - 1) * volume.spacing[0], double(d.y - 1) * volume.spacing[1],
             double(d.z - 1) * volume.spacing[2]}};
}

EffectPlan planEffects(const Scene& scene, const Volume& volume, const TransferFunction& tf) {
    (void)tf;
    return planGrid(scene, volume, grid_detail::valueRange(volume),
                    genericDeviceProfile().rayMarch.macrocellEdge, grid_detail::nonFiniteCount(volume), 0);
}

Camera defaultCamera(const Volume& volume) {
    return defaultCamera(gridBounds(volume));
}

struct GridRenderer::Impl {
    ValueRange range;               ///< of the volume, scanned once at construction
    std::size_t nonFinite = 0;      ///< NaN/Inf voxels (the NaN colour is compiled in only when > 0)
    DeviceBuffer<cl_uchar> volume;  ///< voxels in their stored type, plus one spare voxel (grid_sample.h)
    DeviceBuffer<cl_uchar> corners; ///< uint8 volumes: 8 corner values per cell for the packet kernels
    bool useCorners = false;        ///< packet kernels read `corners` (-DCORNER_VOXELS)
    /// Cubic filters: the spline's coefficients (float, padded) and macrocells bounding the spline, for
    /// `splineFilter` (Linear: none built yet).
    ReconstructionFilter splineFilter = ReconstructionFilter::Linear;
    double splineSmoothing = 0.0;
    DeviceBuffer<float> spline;
    grid_detail::MacrocellGrid splineMacro;
    /// Linear filter with smoothing: the smoothed voxels (float, one spare) and their macrocells, for
    /// `smoothedSigma` (0: none built yet).
    double smoothedSigma = 0.0;
    DeviceBuffer<float> smoothed;
    grid_detail::MacrocellGrid smoothedMacro;
    DeviceBuffer<cl_uchar> empty;
    FogDevice fog; ///< FOG: parameters and the height-map buffer
    /// Shading gradients (GRADIENT_CACHE), built on the first scene that uses them; until then `noCache`, one
    /// word for the kernels' argument.
    std::optional<GradientCacheBuffer> gradients;
    DeviceBuffer<cl_uint> noCache;
    grid_detail::MacrocellGrid macro;
    std::vector<unsigned char> emptyHost;
    cl::Kernel kernel;
    bool packet = false; ///< kernel is raymarch_packet: one work-item per 4x2 block of pixels
    VolclGridRenderParams params{};
    /// Multiple scattering: the path tracer's majorants and accumulation (built on the first such scene).
    std::unique_ptr<GridPathTracer> pathTracer;
    std::string majorantKey;
    LightVolume lightVolume; ///< SHADOW_VOLUME: transmittance toward each light, rebuilt when it changes
    /// render.skipping auto: choices by TF, effects and step octave (a viewer alternates between a few).
    TableCache<SkipDecision> skipDecisions{16};
    SkipDecision skip;                    ///< the current scene's (auto), else edge and "render.skipping ..."
    SkipProbeTimer probeTimer;            ///< injected probe timing (tests); empty: launch the probe
    grid_detail::MacrocellGrid skipMacro; ///< auto's merged macrocells, when it chose a coarser edge
    /// LABELS: the label map of the scene's labels (read when its file, table, mode or boundary change).
    std::optional<LabelField> labels;
    std::string labelKey;
    DeviceBuffer<cl_ushort> labelVoxels;
    DeviceBuffer<cl_float4> labelTable;
};

GridRenderer::GridRenderer(ComputeContext& cc, const Volume& volume, const TransferFunction& tf,
                           const Scene& scene)
    : RendererBase(cc, tf, scene), volume_(volume), impl_(std::make_unique<Impl>()) {
    if (volume.empty()) throw DataError("volume is empty");
    if (volume.voxelCount() >= (std::size_t(1) << 32))
        throw DataError("volume has " + std::to_string(volume.voxelCount()) +
                        " voxels; the ray marcher indexes at most 2^32 - 1");
    impl_->nonFinite = grid_detail::nonFiniteCount(volume);
    std::vector<cl_uchar> bytes(volume.byteSize() + scalarSize(volume.type()), 0);
    std::memcpy(bytes.data(), volume.bytes().data(), volume.byteSize());
    impl_->volume = cc_.upload(bytes, CL_MEM_READ_ONLY);
    impl_->macro = grid_detail::buildMacrocells(volume, cc_.profile().rayMarch.macrocellEdge);
    impl_->range = grid_detail::valueRange(volume);
    impl_->useCorners =
        volume.type() == ScalarType::UInt8 && volume.voxelCount() <= grid_detail::kMaxCornerVoxels;
    impl_->noCache = cc_.allocate<cl_uint>(1);
    start(gridBounds(volume_), impl_->range);
}

GridRenderer::~GridRenderer() = default;

int GridRenderer::lightVolumeBuilds() const noexcept {
    return impl_->lightVolume.builds();
}

double GridRenderer::gradientCacheBuildMs() const noexcept {
    return impl_->gradients ? impl_->gradients->buildMs : -1.0;
}

std::size_t GridRenderer::macrocellCount() const noexcept {
    return impl_->macro.min.size();
}

void GridRenderer::admitScene(const Scene& next) {
    next.validateSteps(norm(bounds().extent));
    Impl& m = *impl_;
    if (!next.labels) return;
    const LabelLayer& l = *next.labels;
    const std::string key = l.file.string() + "|" + l.table.string() + "|" +
                            std::string(labelModeName(l.mode)) + (l.nearest ? "|nearest" : "|smooth");
    if (key == m.labelKey) return;
    // Read and checked before anything changes: a bad label file leaves the renderer as it was.
    LabelField field = loadLabelField(l, volume_);
    std::vector<cl_float4> table(field.table.size());
    for (std::size_t i = 0; i < table.size(); ++i)
        table[i] = {{field.table[i][0], field.table[i][1], field.table[i][2], field.table[i][3]}};
    m.labelVoxels = cc_.upload(field.labels, CL_MEM_READ_ONLY);
    m.labelTable = cc_.upload(table, CL_MEM_READ_ONLY);
    m.labels = std::move(field);
    m.labelKey = key;
}

void GridRenderer::viewChanged(bool sameView) {
    impl_->params.camera = cameraParams(camera_, scene_.width, scene_.height);
    if (impl_->pathTracer && !sameView) impl_->pathTracer->reset(); // the same view keeps accumulating
}

void GridRenderer::rebuild(const Rebuild& change) {
    Impl& m = *impl_;
    selectTables(change.shaded);
    const grid_detail::MacrocellGrid& macro = prepareSampledField();
    if (plan_.pathTracing) {
        useEmptiness(emptiness(macro, change.shaded));
        m.skip = {};
        preparePathTracer(change.shaded);
        return;
    }
    // DVR without iso-surfaces, unlit or shaded from the gradient cache (the common, time-critical cases),
    // runs as explicit 8-ray packets.
    const bool floatCopy = scene_.filter != ReconstructionFilter::Linear || scene_.smoothing > 0.0;
    const bool cached = plan_.gradientCache != 0;
    m.packet = packetServesLit(scene_, plan_) && (!plan_.shading || cached);
    m.params = grid_detail::makeParams(scene_, camera_, volume_, m.range, tf_, plan_, macro, knotCount(),
                                       tableLengths());
    if (plan_.labels) {
        const LabelField& f = *m.labels;
        for (std::size_t r = 0; r < 3; ++r)
            for (std::size_t c = 0; c < 4; ++c)
                m.params.labels.toLabel[r][c] = float(f.toLabel[r][c]);
        m.params.labels.dims[0] = volcl_uint(f.dims[0]);
        m.params.labels.dims[1] = volcl_uint(f.dims[1]);
        m.params.labels.dims[2] = volcl_uint(f.dims[2]);
        m.params.labels.dims[3] = volcl_uint(f.outside());
        // A layout, like VOXEL_TYPE: the label grid is the volume's, so no transform per sample.
        if (f.sameGrid) plan_.defines.set("LABEL_SAME_GRID");
    }
    if (plan_.isoTable) {
        const std::array<double, 2> domain = isoTableDomain(m.range);
        m.params.tf.domainLo = float(domain[0]);
        m.params.tf.domainHi = float(domain[1]);
        m.params.tf.tableSize = volcl_uint(scene_.tableSize);
    }
    if (plan_.fog) m.params.fog = m.fog.update(cc_, scene_.effects.fog, bounds(), plan_.fogMap);
    // Before the skipping probe, whose frames read it. The volume never changes: built once, whatever the TF,
    // camera or lights.
    const GradientCacheFormat format =
        plan_.gradientCache == 3 ? GradientCacheFormat::ExactDifferences : GradientCacheFormat::Octahedral;
    if (cached && (!m.gradients || m.gradients->format != format))
        m.gradients = buildGradientCache(cc_, m.volume.get(), voxelTypeCode(volume_), m.params.grid, format);
    const float gradientMax = m.params.grid.gradientMax; // the cache's scale, from the value range
    m.params.grid =
        grid_detail::gridParams(volume_, selectSkipping(macro, change.shaded, m.params, floatCopy));
    m.params.grid.gradientMax = gradientMax;
    m.kernel = cc_.kernel("render/raymarch.cl", m.packet ? "raymarch_packet" : "raymarch",
                          m.packet ? packetDefines(plan_.defines, floatCopy) : plan_.defines);
}

const grid_detail::MacrocellGrid& GridRenderer::selectSkipping(const grid_detail::MacrocellGrid& macro,
                                                               const TransferFunction& shaded,
                                                               const VolclGridRenderParams& base,
                                                               bool floatCopy) {
    Impl& m = *impl_;
    std::vector<unsigned char> fine = emptiness(macro, shaded);
    // Shadows from light volumes: the probe frame would run before the light volume it reads is built
    // (render() builds it), so such scenes skip as "on" does, unmeasured.
    if (!plan_.skipping || scene_.skipping != SkipMode::Auto || plan_.shadowVolume) {
        m.skip = {};
        m.skip.edge = plan_.skipping ? macro.edge : 0;
        m.skip.unmeasured = plan_.shadowVolume && scene_.skipping == SkipMode::Auto
                                ? std::string("render.skipping auto as on: light-volume shadows")
                                : "render.skipping " + std::string(skipModeName(scene_.skipping));
        useEmptiness(std::move(fine));
        return macro;
    }
    // Candidates: the profile's edge and merged cells of its coarser multiples.
    const DeviceProfile::RayMarch& tuning = cc_.profile().rayMarch;
    std::vector<grid_detail::MacrocellGrid> grids;
    for (unsigned f : tuning.skipEdgeFactors) {
        if (f <= 1) continue;
        grid_detail::MacrocellGrid g = grid_detail::coarsenMacrocells(macro, f);
        const grid_detail::MacrocellGrid& prev = grids.empty() ? macro : grids.back();
        // A volume already covered by as few cells: the same grid again, nothing new to measure.
        if (g.nx == prev.nx && g.ny == prev.ny && g.nz == prev.nz) break;
        grids.push_back(std::move(g));
    }
    std::vector<std::vector<unsigned char>> empties{std::move(fine)};
    for (const auto& g : grids)
        empties.push_back(emptiness(g, shaded));
    auto gridOf = [&](std::size_t i) -> const grid_detail::MacrocellGrid& {
        return i ? grids[i - 1] : macro;
    };
    std::vector<SkipCandidate> candidates;
    for (std::size_t i = 0; i < empties.size(); ++i) {
        const auto n = std::count(empties[i].begin(), empties[i].end(), 1);
        candidates.push_back(
            {gridOf(i).edge, empties[i].empty() ? 0.0 : double(n) / double(empties[i].size())});
    }
    // What the choice depends on besides the volume: everything compiled, the TF, what the emptiness reads,
    // and the step's octave (the cost of a sample against a cell visit).
    const double minSpacing = std::min({volume_.spacing[0], volume_.spacing[1], volume_.spacing[2]});
    std::ostringstream key;
    key << std::setprecision(17) << plan_.defines.toOptions() << '|' << shaded.toJson() << '|'
        << filterName(scene_.filter) << ' ' << scene_.smoothing << ' ' << scene_.tableSize << ' '
        << scene_.nanColor[3] << ' ' << std::lround(std::log2(scene_.step / minSpacing)) << ' ' << m.packet;
    for (const auto& iso : plan_.isosurfaces)
        key << ' ' << iso.value;
    m.skip = m.skipDecisions.get(key.str(), [&] {
        // The probe: the scene's camera on a subsampled image, each candidate's kernel, flags and cells.
        const double pixels = double(scene_.width) * double(scene_.height);
        const double f = std::min(1.0, std::sqrt(double(tuning.skipProbePixels) / pixels));
        const int pw = std::max(1, int(std::lround(scene_.width * f)));
        const int ph = std::max(1, int(std::lround(scene_.height * f)));
        KernelDefines offDefines = plan_.defines;
        offDefines.erase("SKIPPING");
        const char* name = m.packet ? "raymarch_packet" : "raymarch";
        cl::Kernel on = cc_.kernel("render/raymarch.cl", name,
                                   m.packet ? packetDefines(plan_.defines, floatCopy) : plan_.defines);
        cl::Kernel off = cc_.kernel("render/raymarch.cl", name,
                                    m.packet ? packetDefines(offDefines, floatCopy) : offDefines);
        const DeviceBuffer<cl_float4> out = cc_.allocate<cl_float4>(std::size_t(pw) * ph, CL_MEM_WRITE_ONLY);
        const DeviceBuffer<float> depth = cc_.allocate<float>(std::size_t(pw) * ph, CL_MEM_WRITE_ONLY);
        std::vector<DeviceBuffer<cl_uchar>> flags;
        for (const auto& e : empties)
            flags.push_back(cc_.upload(e, CL_MEM_READ_ONLY));
        VolclGridRenderParams probe = base;
        probe.camera = cameraParams(camera_, pw, ph);
        const SkipProbeTimer launchProbe = [&](unsigned edge) {
            std::size_t i = 0;
            while (i + 1 < empties.size() && gridOf(i).edge != edge)
                ++i;
            probe.grid = grid_detail::gridParams(volume_, gridOf(i));
            probe.grid.gradientMax = base.grid.gradientMax;
            return eventMilliseconds(enqueueFrame(edge ? on : off, sampledVoxels(), flags[i].get(), probe,
                                                  out, depth, std::size_t(pw), std::size_t(ph), m.packet));
        };
        SkipDecision d =
            chooseSkipping(candidates, tuning.skipProbeRounds, m.probeTimer ? m.probeTimer : launchProbe);
        if (!d.timings.empty()) {
            d.width = pw;
            d.height = ph;
        }
        return d;
    });
    const std::string line = "empty-space skipping: " + m.skip.text();
    auto& compiled = plan_.compiled;
    const auto at = std::find_if(compiled.begin(), compiled.end(), [](const std::string& c) {
        return c.rfind("empty-space skipping:", 0) == 0;
    });
    if (m.skip.edge == 0) {
        // Measured slower (or nothing to skip): the frame runs without it.
        if (at != compiled.end()) compiled.erase(at);
        plan_.dropped.push_back(line);
        plan_.skipping = false;
        plan_.defines.erase("SKIPPING");
        useEmptiness(std::move(empties[0]));
        return macro;
    }
    if (at != compiled.end()) *at = line;
    std::size_t chosen = 0;
    while (chosen + 1 < empties.size() && gridOf(chosen).edge != m.skip.edge)
        ++chosen;
    useEmptiness(std::move(empties[chosen]));
    if (chosen == 0) return macro;
    m.skipMacro = std::move(grids[chosen - 1]);
    return m.skipMacro;
}

const SkipDecision& GridRenderer::skipDecision() const noexcept {
    return impl_->skip;
}

void GridRenderer::setSkipProbeTimer(SkipProbeTimer timer) {
    impl_->probeTimer = std::move(timer);
    impl_->skipDecisions = TableCache<SkipDecision>(16);
}

void GridRenderer::selectTables(const TransferFunction& shaded) {
    if (const std::optional<TableSpec> spec = marchTableSpec()) {
        if (!plan_.preintLighting) {
            selectPreintegrationTable(shaded, *spec);
            return;
        }
        selectTable(tableKey(shaded.toJson(), *spec, "lighting"), [&] {
            return DeviceTable{
                cc_.upload(lightingTableSlices(shaded, spec->size, scene_.step), CL_MEM_READ_ONLY), 1};
        });
    } else if (plan_.isoTable) {
        // The iso-surface table over the data's value range (colours associated, scaled as the TF's).
        std::vector<IsoSurface> surfaces;
        for (const auto& iso : plan_.isosurfaces) {
            const double a = iso.rgba[3], cs = plan_.colorScale;
            surfaces.push_back(
                {iso.value, {iso.rgba[0] * cs * a, iso.rgba[1] * cs * a, iso.rgba[2] * cs * a, a}});
        }
        const std::array<double, 2> domain = isoTableDomain(impl_->range);
        std::ostringstream source;
        source << std::setprecision(17) << "iso " << domain[0] << " " << domain[1];
        for (const auto& su : surfaces)
            source << "|" << su.value << "," << su.rgba[0] << "," << su.rgba[1] << "," << su.rgba[2] << ","
                   << su.rgba[3];
        TableSpec spec;
        spec.size = scene_.tableSize;
        selectTable(tableKey(source.str(), spec, "iso"), [&] {
            const ImageBuffer img = isoSurfaceTableImage(surfaces, domain, scene_.tableSize);
            std::vector<cl_float4> rgba(std::size_t(img.width) * std::size_t(img.height));
            std::memcpy(rgba.data(), img.pixels.data(), rgba.size() * sizeof(cl_float4));
            return DeviceTable{cc_.upload(rgba, CL_MEM_READ_ONLY), 1};
        });
    }
}

const grid_detail::MacrocellGrid& GridRenderer::prepareSampledField() {
    Impl& m = *impl_;
    // Cubic filters: the spline's coefficients, built once per filter (prefiltering a 35 MB volume takes
    // about a second; camera and TF changes keep them).
    const bool spline = scene_.filter != ReconstructionFilter::Linear;
    // The cubic filters' prefilter is global: one NaN would spread over every coefficient.
    if (spline && m.nonFinite)
        throw DataError("volume has " + std::to_string(m.nonFinite) + " NaN/Inf voxels, which the " +
                        std::string(filterName(scene_.filter)) +
                        " filter's prefilter spreads over the whole volume (use --filter linear)");
    if (spline && (m.splineFilter != scene_.filter || m.splineSmoothing != scene_.smoothing)) {
        checkMemoryBudget(bsplineCoefficientBytes(volume_, sizeof(float)), 0, "the volume",
                          "the cubic filter's coefficients");
        const BsplineCoefficients<float> c =
            bsplineCoefficients<float>(volume_, scene_.filter, scene_.smoothing);
        // The interpolating prefilter amplifies alternating data up to 27x: values near float's limit overflow.
        if (!std::all_of(c.c.begin(), c.c.end(), [](float v) { return std::isfinite(v); }))
            throw DataError("volume values up to " + formatNumber(m.range.max) + " overflow the " +
                            std::string(filterName(scene_.filter)) +
                            " filter's float coefficients (use --filter linear)");
        m.splineMacro = bsplineMacrocells(c, cc_.profile().rayMarch.macrocellEdge);
        m.spline = cc_.upload(c.c, CL_MEM_READ_ONLY);
        m.splineFilter = scene_.filter;
        m.splineSmoothing = scene_.smoothing;
    }
    // Linear filter on smoothed data: the smoothed voxels as floats, built once per sigma.
    const bool smoothedLinear = !spline && scene_.smoothing > 0.0;
    if (smoothedLinear && m.smoothedSigma != scene_.smoothing) {
        checkMemoryBudget(volume_.voxelCount() * sizeof(float), 0, "the volume", "the smoothed voxels");
        const Volume sm = smoothedVolume(volume_, scene_.smoothing);
        m.smoothedMacro = grid_detail::buildMacrocells(sm, cc_.profile().rayMarch.macrocellEdge);
        std::vector<float> voxels(sm.voxelCount() + 1, 0.0f); // + the spare voxel grid_sample.h reads
        std::memcpy(voxels.data(), sm.bytes().data(), sm.byteSize());
        m.smoothed = cc_.upload(voxels, CL_MEM_READ_ONLY);
        m.smoothedSigma = scene_.smoothing;
    }
    return spline ? m.splineMacro : smoothedLinear ? m.smoothedMacro : m.macro;
}

std::vector<unsigned char> GridRenderer::emptiness(const grid_detail::MacrocellGrid& macro,
                                                   const TransferFunction& shaded) const {
    const Impl& m = *impl_;
    const Preintegration pre = scene_.mode == RenderMode::Dvr ? scene_.preintegration : Preintegration::None;
    std::vector<double> isoValues;
    for (const auto& iso : plan_.isosurfaces)
        isoValues.push_back(iso.value);
    const int tableNodes = pre != Preintegration::None ? scene_.tableSize : 0;
    return grid_detail::emptyMacrocells(macro, shaded, isoValues, scene_.mode == RenderMode::Iso, tableNodes,
                                        m.nonFinite && scene_.nanColor[3] > 0.0);
}

void GridRenderer::useEmptiness(std::vector<unsigned char> empty) {
    Impl& m = *impl_;
    m.emptyHost = std::move(empty);
    std::size_t emptyCount = 0;
    for (unsigned char e : m.emptyHost)
        emptyCount += e;
    emptyFraction_ = m.emptyHost.empty() ? 0.0 : double(emptyCount) / double(m.emptyHost.size());
    m.empty = cc_.upload(m.emptyHost, CL_MEM_READ_ONLY);
}

void GridRenderer::preparePathTracer(const TransferFunction& shaded) {
    Impl& m = *impl_;
    // Multiple scattering: the path tracer reads the stored voxels trilinearly, with majorants from their
    // macrocells.
    if (!m.pathTracer) m.pathTracer = std::make_unique<GridPathTracer>(cc_);
    const std::string key = shaded.toJson() + std::to_string(nanExtinction(scene_));
    if (key != m.majorantKey) {
        m.pathTracer->setMajorants(majorantGrid(m.macro, shaded, m.nonFinite ? nanExtinction(scene_) : 0.0));
        m.majorantKey = key;
    }
    m.pathTracer->reset();
    KernelDefines d = plan_.defines;
    d.set("VOXEL_TYPE", static_cast<long long>(voxelTypeCode(volume_)));
    m.packet = false;
    m.kernel = cc_.kernel("render/pathtrace.cl", "pathtrace", d);
    m.params = grid_detail::makeParams(scene_, camera_, volume_, m.range, tf_, plan_, m.macro, knotCount(),
                                       tableLengths());
}

KernelDefines GridRenderer::packetDefines(KernelDefines d, bool floatCopy) {
    Impl& m = *impl_;
    if (m.useCorners && !floatCopy) {
        // A memory layout, not an effect: kept out of plan_.defines (what --explain and the EXR report).
        d.set("CORNER_VOXELS");
        if (m.corners.size() == 0)
            m.corners = cc_.upload(grid_detail::cellCorners(volume_), CL_MEM_READ_ONLY);
    }
    return d;
}

cl::Event GridRenderer::enqueueFrame(cl::Kernel& kernel, const cl::Buffer& voxels, const cl::Buffer& empty,
                                     const VolclGridRenderParams& params, const DeviceBuffer<cl_float4>& out,
                                     const DeviceBuffer<float>& depth, std::size_t w, std::size_t h,
                                     bool packet) {
    const cl::Buffer& gradients = impl_->gradients ? impl_->gradients->words.get() : impl_->noCache.get();
    if (plan_.labels && !packet)
        setArgs(kernel, voxels, knots(), table(), empty, params, out, depth, impl_->fog.buffer(cc_),
                impl_->lightVolume.buffer(cc_), gradients, impl_->labelVoxels, impl_->labelTable);
    else
        setArgs(kernel, voxels, knots(), table(), empty, params, out, depth, impl_->fog.buffer(cc_),
                impl_->lightVolume.buffer(cc_), gradients);
    // One ray per work-item, or one packet of 4x2 rays (see DeviceProfile::RayMarch for the tiles).
    const DeviceProfile::RayMarch& tuning = cc_.profile().rayMarch;
    return packet ? cc_.launch2d(kernel, (w + 3) / 4, (h + 1) / 2, tuning.packet)
                  : cc_.launch2d(kernel, w, h, tuning.tile);
}

ImageBuffer GridRenderer::launch(cl::Kernel& kernel, const cl::Buffer& voxels, bool withDepth, bool packet) {
    Impl& m = *impl_;
    ensureFrameBuffers();
    if (plan_.pathTracing) {
        m.pathTracer->reset();
        lastMs_ = m.pathTracer->accumulate(kernel, voxels, knots(), m.params, scene_.effects,
                                           scene_.effects.samples, out_);
        return readImage(false);
    }
    const cl::Event ev = enqueueFrame(kernel, voxels, m.empty.get(), m.params, out_, depth_,
                                      std::size_t(scene_.width), std::size_t(scene_.height), packet);
    lastMs_ = eventMilliseconds(ev);
    return readImage(withDepth);
}

ImageBuffer GridRenderer::readImage(bool withDepth) {
    ImageBuffer img = downloadFrame(withDepth);
    addFrameAttributes(img);
    if (scene_.filter != ReconstructionFilter::Linear) // absent: linear, as in images from before the filters
        img.attributes.push_back({"volcl:filter", std::string(filterName(scene_.filter))});
    return img;
}

const cl::Buffer& GridRenderer::sampledVoxels() const {
    const Impl& m = *impl_;
    return scene_.filter != ReconstructionFilter::Linear ? m.spline.get()
           : scene_.smoothing > 0.0                      ? m.smoothed.get()
           : m.packet && m.useCorners                    ? m.corners.get()
                                                         : m.volume.get();
}

ImageBuffer GridRenderer::render() {
    Impl& m = *impl_;
    if (plan_.pathTracing) return launch(m.kernel, m.volume.get(), false, false);
    const cl::Buffer& voxels = sampledVoxels();
    // The light volumes read the field as the per-ray kernel does (never the packets' corner layout).
    if (plan_.shadowVolume) updateLightVolume(&voxels == &m.corners.get() ? m.volume.get() : voxels);
    return launch(m.kernel, voxels, !plan_.isosurfaces.empty(), m.packet);
}

void GridRenderer::updateLightVolume(const cl::Buffer& voxels) {
    Impl& m = *impl_;
    LightVolume::Inputs in;
    in.voxels = &voxels;
    in.knots = &knots().get();
    in.knotCount = knotCount();
    // How light_volume.cl reads the field: the ray marcher's voxel type, filter and NaN colour.
    EffectPlan nan;
    planNanColor(scene_, m.nonFinite > 0, nan);
    in.defines = nan.defines;
    in.defines.set("VOXEL_TYPE", scene_.filter == ReconstructionFilter::Linear && scene_.smoothing == 0.0
                                     ? static_cast<long long>(voxelTypeCode(volume_))
                                     : 0LL);
    if (scene_.filter != ReconstructionFilter::Linear) in.defines.set("FILTER_BSPLINE");
    in.grid = m.params.grid;
    in.lights = sweptLights(m.params.lighting, camera_);
    in.cell = scene_.effects.lightVolumeCell;
    in.step = m.params.lighting.shadowStep;
    std::ostringstream key;
    key << std::setprecision(17) << filterName(scene_.filter) << ' ' << scene_.smoothing << ' '
        << nanExtinction(scene_) << ' ' << tf_.toJson() << ' ' << plan_.colorScale;
    in.fieldKey = key.str();
    in.headToleranceDeg = scene_.effects.headLightToleranceDeg;
    const WorldBox box = bounds();
    in.centre = add(box.origin, scale(box.extent, 0.5));
    if (m.lightVolume.update(cc_, in)) lightVolumeMs_ = m.lightVolume.lastBuildMilliseconds();
    m.params.lightVolume = m.lightVolume.params();
}

int GridRenderer::accumulateSamples(int samples) {
    Impl& m = *impl_;
    if (!plan_.pathTracing)
        throw UsageError("progressive accumulation needs effects.scattering.order multiple");
    if (ensureFrameBuffers()) m.pathTracer->reset();
    lastMs_ =
        m.pathTracer->accumulate(m.kernel, m.volume.get(), knots(), m.params, scene_.effects, samples, out_);
    return m.pathTracer->samplesDone();
}

ImageBuffer GridRenderer::renderProgressive(int samples) {
    if (!plan_.pathTracing) return render();
    accumulateSamples(samples);
    return accumulatedImage();
}

ImageBuffer GridRenderer::accumulatedImage() {
    if (!plan_.pathTracing)
        throw UsageError("progressive accumulation needs effects.scattering.order multiple");
    return readImage(false);
}

ImageBuffer GridRenderer::renderPlainBaseline() {
    if (scene_.mode != RenderMode::Dvr || scene_.preintegration != Preintegration::None)
        throw UsageError("the plain baseline kernel renders point-sampled dvr only");
    KernelDefines d;
    d.set("VOXEL_TYPE", static_cast<long long>(voxelTypeCode(volume_)));
    cl::Kernel k = cc_.kernel("render/raymarch_plain.cl", "raymarch_plain", packetDefines(d, false));
    return launch(k, impl_->useCorners ? impl_->corners.get() : impl_->volume.get(), false, true);
}

EffectPlan GridRenderer::planEffects(const Scene& scene) const {
    return planGrid(scene, volume_, impl_->range, cc_.profile().rayMarch.macrocellEdge, impl_->nonFinite,
                    cc_.device().maxAllocBytes);
}

std::string GridRenderer::statistics() const {
    std::ostringstream os;
    const SkipDecision& skip = impl_->skip;
    os << "macrocells: " << impl_->emptyHost.size() << ", " << std::setprecision(1) << std::fixed
       << 100.0 * emptyFraction_ << "% empty; skipping: " << skip.text();
    if (plan_.shadowVolume)
        os << "; light volumes: " << impl_->lightVolume.builds() << " built, last in " << std::setprecision(1)
           << lightVolumeMs_ << " ms";
    if (impl_->gradients)
        os << "; gradient cache: " << std::setprecision(2) << gradientCacheBuildMs() << " ms to build, "
           << impl_->gradients->words.size() * sizeof(cl_uint) << " bytes";
    return os.str();
}

} // namespace volcl
