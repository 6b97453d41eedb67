// The preview tiers' renderer: TF tables, per-axis run-length encodings on the device, kernel launches.
#include "render/grid/PreviewRenderer.hpp"

#include "core/Error.hpp"
#include "core/Volume.hpp"
#include "core/runtime/Timing.hpp"
#include "render/FrameParams.hpp"
#include "render/grid/GridDetail.hpp"
#include "render/grid/GridRenderer.hpp"
#include "render/grid/PreviewTiers.hpp"

#include <array>
#include <cstring>
#include <iomanip>
#include <optional>
#include <sstream>

namespace volcl {

std::string previewRefusal(const Scene& scene, GridMethod method) {
    const auto& fx = scene.effects;
    const char* what = scene.mode != RenderMode::Dvr                  ? "a mode other than dvr"
                       : fx.shading                                   ? "shading"
                       : !fx.isosurfaces.empty()                      ? "iso-surfaces"
                       : scene.labels                                 ? "labels"
                       : !fx.clipPlanes.empty() || fx.cropBox         ? "clip planes or a crop box"
                       : scene.preintegration != Preintegration::None ? "pre-integration"
                       : fx.fog.enabled                               ? "fog"
                       : fx.scattering || fx.shadows                  ? "scattering or shadows"
                       : scene.filter != ReconstructionFilter::Linear ? "a cubic filter"
                       : scene.smoothing > 0.0                        ? "smoothing"
                       : method == GridMethod::ShearWarp && scene.camera &&
                               scene.camera->projection == Projection::Perspective
                           ? "a perspective camera (shear-warp factorises parallel projections only)"
                           : nullptr;
    if (!what) return {};
    return "render.method " + std::string(gridMethodName(method)) +
           " draws unshaded dvr without effects; the scene asks for " + what + " (use raymarch)";
}

struct GridPreviewRenderer::Impl {
    ValueRange range;
    std::vector<float> values;     ///< the voxels as floats, kept for encodings (shear-warp only)
    DeviceBuffer<cl_uchar> voxels; ///< voxels in their stored type plus one spare (drc)
    VolclPreviewTable table{};
    std::vector<cl_float4> straight; ///< (r, g, b, tau) per node
    DeviceBuffer<cl_float4> straightDevice;
    DeviceBuffer<cl_float4> slabs; ///< shear-warp's two tables for slabDistance
    double slabDistance = -1.0;
    std::optional<preview::OpacityBins> bins;
    struct AxisRuns {
        bool built = false;
        DeviceBuffer<cl_uint> rowRuns;
        DeviceBuffer<cl_uint4> runs;
        DeviceBuffer<float> data;
        std::size_t runCount = 0, cells = 0, visibleCells = 0;
    };
    std::array<AxisRuns, 3> axes;
    int lastAxis = -1;
    DeviceBuffer<cl_float4> inter;
    DeviceBuffer<cl_uint> links;
    cl::Kernel composite, warp, drc;
};

GridPreviewRenderer::GridPreviewRenderer(ComputeContext& cc, const Volume& volume, const TransferFunction& tf,
                                         const Scene& scene)
    : RendererBase(cc, tf, scene), volume_(volume), impl_(std::make_unique<Impl>()) {
    if (volume.empty()) throw DataError("volume is empty");
    if (const std::size_t bad = grid_detail::nonFiniteCount(volume))
        throw DataError("volume has " + std::to_string(bad) + " NaN/Inf voxels; render.method " +
                        std::string(gridMethodName(scene.gridMethod)) +
                        " draws finite data only (raymarch draws the NaN colour)");
    if (volume.voxelCount() >= (std::size_t(1) << 32))
        throw DataError("volume has " + std::to_string(volume.voxelCount()) +
                        " voxels; the preview tiers index at most 2^32 - 1");
    Impl& m = *impl_;
    m.range = grid_detail::valueRange(volume);
    if (scene.gridMethod == GridMethod::ShearWarp) {
        m.values = volume.toFloat();
        m.composite = cc_.kernel("render/shearwarp.cl", "shearwarp_composite");
        m.warp = cc_.kernel("render/shearwarp.cl", "shearwarp_warp");
    } else {
        std::vector<cl_uchar> bytes(volume.byteSize() + scalarSize(volume.type()), 0);
        std::memcpy(bytes.data(), volume.bytes().data(), volume.byteSize());
        m.voxels = cc_.upload(bytes, CL_MEM_READ_ONLY);
        KernelDefines d;
        d.set("VOXEL_TYPE", volume.type() == ScalarType::UInt8    ? 1LL
                            : volume.type() == ScalarType::UInt16 ? 2LL
                            : volume.type() == ScalarType::Int16  ? 3LL
                                                                  : 0LL);
        m.drc = cc_.kernel("render/drc.cl", "drc", d);
    }
    start(gridBounds(volume), m.range);
}

GridPreviewRenderer::~GridPreviewRenderer() = default;

void GridPreviewRenderer::admitScene(const Scene& next) {
    if (next.gridMethod == GridMethod::Raymarch)
        throw UsageError("the preview renderer draws render.method shear-warp or drc, not raymarch");
    if (impl_ && (next.gridMethod == GridMethod::ShearWarp) != bool(impl_->composite.get()))
        throw UsageError("render.method cannot change on a preview renderer: make a new renderer");
    if (const std::string why = previewRefusal(next, next.gridMethod); !why.empty()) throw UsageError(why);
}

EffectPlan GridPreviewRenderer::planEffects(const Scene& scene) const {
    EffectPlan p = volcl::planEffects(scene, gridBounds(volume_), impl_->range,
                                      scene.gridMethod == GridMethod::ShearWarp
                                          ? "runs of transparent cells (run-length encoding)"
                                          : "none",
                                      false);
    p.compiled.push_back("method: " + std::string(gridMethodName(scene.gridMethod)));
    return p;
}

void GridPreviewRenderer::rebuild(const Rebuild& change) {
    Impl& m = *impl_;
    m.table = preview::tableGeometry(m.range, scene_.earlyTermination);
    if (!change.tfChanged && !m.straight.empty()) return;
    m.straight = preview::straightTable(change.shaded, m.range);
    m.straightDevice = cc_.upload(m.straight, CL_MEM_READ_ONLY);
    m.slabDistance = -1.0;
    if (scene_.gridMethod == GridMethod::ShearWarp) {
        m.bins.emplace(change.shaded, m.range);
        for (auto& a : m.axes)
            a = Impl::AxisRuns{};
    }
}

ImageBuffer GridPreviewRenderer::render() {
    return scene_.gridMethod == GridMethod::ShearWarp ? renderShearWarp() : renderDrc();
}

ImageBuffer GridPreviewRenderer::renderShearWarp() {
    Impl& m = *impl_;
    const preview::ShearWarpFactors f = preview::shearWarpFactors(volume_, camera_);
    Impl::AxisRuns& axis = m.axes[std::size_t(f.c)];
    tableMs_ = 0.0;
    if (!axis.built) {
        Stopwatch sw;
        const preview::RunEncoding e = preview::encodeRuns(m.values, volume_.dims(), f.c, *m.bins);
        axis.rowRuns = cc_.upload(e.rowRuns, CL_MEM_READ_ONLY);
        axis.runs = cc_.upload(e.runs.empty() ? std::vector<cl_uint4>(1) : e.runs, CL_MEM_READ_ONLY);
        axis.data = cc_.upload(e.data.empty() ? std::vector<float>(1) : e.data, CL_MEM_READ_ONLY);
        axis.runCount = e.runs.size();
        axis.cells = e.cells;
        axis.visibleCells = e.visibleCells;
        axis.built = true;
        encodingMs_ = sw.milliseconds();
        tableMs_ = encodingMs_; // a one-off cost per TF and axis, reported as a table build
    }
    m.lastAxis = f.c;
    if (f.sliceDistance != m.slabDistance) {
        m.slabs = cc_.upload(preview::slabTables(m.straight, f.sliceDistance), CL_MEM_READ_ONLY);
        m.slabDistance = f.sliceDistance;
    }
    const std::size_t W = std::size_t(f.width), H = std::size_t(f.height);
    if (m.inter.size() < W * H) m.inter = cc_.allocate<cl_float4>(W * H);
    if (m.links.size() < (W + 1) * H) m.links = cc_.allocate<cl_uint>((W + 1) * H);
    const VolclShearWarpParams p = preview::shearWarpParams(f, m.table);
    setArgs(m.composite, axis.rowRuns, axis.runs, axis.data, m.slabs, p, m.inter, m.links);
    const cl::Event composite = cc_.launch1d(m.composite, H, cc_.profile().preview.scanlines);
    ensureFrameBuffers();
    const VolclCameraParams camera = cameraParams(camera_, scene_.width, scene_.height);
    const VolclGridParams grid = grid_detail::gridParams(volume_, grid_detail::MacrocellGrid{});
    setArgs(m.warp, m.inter, p, camera, grid, out_);
    const cl::Event warp = cc_.launch2d(m.warp, std::size_t(scene_.width), std::size_t(scene_.height),
                                        cc_.profile().preview.warp);
    lastMs_ = eventMilliseconds(composite) + eventMilliseconds(warp);
    ImageBuffer img = downloadFrame(false);
    addFrameAttributes(img, "shear-warp");
    return img;
}

ImageBuffer GridPreviewRenderer::renderDrc() {
    Impl& m = *impl_;
    ensureFrameBuffers();
    const VolclCameraParams camera = cameraParams(camera_, scene_.width, scene_.height);
    const VolclGridParams grid = grid_detail::gridParams(volume_, grid_detail::MacrocellGrid{});
    setArgs(m.drc, m.voxels, m.straightDevice, camera, grid, m.table, out_);
    const cl::Event ev =
        cc_.launch2d(m.drc, std::size_t(scene_.width), std::size_t(scene_.height), cc_.profile().preview.drc);
    lastMs_ = eventMilliseconds(ev);
    ImageBuffer img = downloadFrame(false);
    addFrameAttributes(img, "drc");
    return img;
}

std::string GridPreviewRenderer::statistics() const {
    const Impl& m = *impl_;
    if (scene_.gridMethod != GridMethod::ShearWarp) return "discrete ray casting: nearest voxel, 3D DDA";
    std::ostringstream os;
    os << "shear-warp";
    if (m.lastAxis >= 0) {
        const Impl::AxisRuns& a = m.axes[std::size_t(m.lastAxis)];
        os << ": principal axis "
           << "xyz"[m.lastAxis] << ", " << a.runCount << " runs, " << std::setprecision(1) << std::fixed
           << (a.cells ? 100.0 * double(a.visibleCells) / double(a.cells) : 0.0)
           << "% of cells visible, last encoding built in " << std::setprecision(0) << encodingMs_ << " ms";
    }
    return os.str();
}

} // namespace volcl
