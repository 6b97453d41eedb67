// The projected-tetrahedra renderer's host side: cell records and tets on the device, the per-frame order, and
// the launches (project, tile rectangles, binning, tile compositing).
#include "render/mesh/PtRenderer.hpp"

#include "core/Error.hpp"
#include "core/Format.hpp"
#include "core/runtime/DeviceProfile.hpp"
#include "core/runtime/ParallelFor.hpp"
#include "core/runtime/Timing.hpp"
#include "render/FrameParams.hpp"
#include "render/VecMath.hpp"
#include "render/mesh/MeshGeometry.hpp"
#include "render/mesh/MeshReference.hpp"
#include "render/mesh/MeshRenderer.hpp"

#include <algorithm>
#include <sstream>

namespace volcl {

namespace {
constexpr std::size_t kTetStride = 5; ///< PT_TET_STRIDE of cl/mesh/mesh_pt.cl: four planes, the field
} // namespace

MeshSort sceneMeshSort(const Scene& scene, const mesh::TetMesh& mesh) {
    return scene.meshSort ? *scene.meshSort : defaultMeshSort(mesh);
}

SortView sortViewOf(const Camera& camera) {
    SortView v;
    v.perspective = camera.projection == Projection::Perspective;
    v.eye = camera.eye;
    v.direction = normalized(sub(camera.target, camera.eye));
    return v;
}

EffectPlan planPt(const Scene& scene, const mesh::TetMesh& mesh, const DeviceProfile& device) {
    if (scene.mode != RenderMode::Dvr)
        throw UsageError("render.method \"pt\" draws mode dvr only (mode " +
                         std::string(renderModeName(scene.mode)) + ": use render.method \"cells\")");
    Scene s = scene;
    s.preintegration = Preintegration::Table3d;
    s.skipping = SkipMode::Off;
    EffectPlan p = planMeshEffects(s, mesh);
    const std::string why = " is not drawn by render.method \"pt\" (use \"cells\")";
    if (p.shading) throw UsageError("shading" + why);
    if (!p.isosurfaces.empty()) throw UsageError("iso-surfaces" + why);
    if (scene.preintegration != Preintegration::Table3d)
        p.dropped.push_back("preintegration \"" + std::string(preintegrationName(scene.preintegration)) +
                            "\": projected tetrahedra integrate every cell segment through the 3D table");
    if (scene.skipping != SkipMode::Off)
        p.dropped.push_back("empty-space skipping: every cell in the order is composited");
    p.defines.set("KB_TILE", kKBufferTile)
        .set("KB_TILE_THREADS", device.mesh.tileThreads)
        .set("BIN_CHUNKS", device.mesh.binChunks);
    p.compiled.push_back("projected tetrahedra: cells in " +
                         std::string(meshSortName(sceneMeshSort(scene, mesh))) +
                         " visibility order, composited front to back per " + std::to_string(kKBufferTile) +
                         "x" + std::to_string(kKBufferTile) + "-pixel tile");
    return p;
}

struct PtRenderer::Impl {
    Impl(ComputeContext& cc, const mesh::TetMesh& mesh) : sorter(mesh), binner(cc) {}
    VisibilitySorter sorter;
    TileBinner binner;
    DeviceBuffer<cl_float4> points, proj, cells;
    DeviceBuffer<cl_uint4> tets, items;
    DeviceBuffer<cl_uint> order;
    DeviceBuffer<cl_uint2> rects;
    cl::Kernel project, tetRects, raster;
    KernelDefines defines;
    VolclTfParams tf{};
};

PtRenderer::PtRenderer(ComputeContext& cc, const mesh::TetMesh& mesh, const TransferFunction& tf,
                       const Scene& scene)
    : RendererBase(cc, tf, scene), mesh_(mesh) {
    if (mesh.tets.empty()) throw DataError("mesh has no tetrahedra");
    if (mesh.points.size() > 0xFFFFFFFFu || mesh.tets.size() > 0xFFFFFFFFu)
        throw DataError("mesh has too many points or tets for projected tetrahedra (2^32 - 1)");
    impl_ = std::make_unique<Impl>(cc, mesh);
    geometry_ = kbufferGeometry(mesh, MeshFaces{});
    Impl& m = *impl_;
    const std::size_t nt = mesh.tets.size();
    std::vector<cl_float4> cells(kTetStride * nt);
    std::vector<cl_uint4> tets(nt);
    parallelFor(nt, 0u, [&](std::size_t t) {
        const mesh_detail::NormalisedTet r =
            mesh_detail::normalisedTet(mesh, t, geometry_.centre, geometry_.scale);
        for (unsigned f = 0; f < 4; ++f)
            cells[kTetStride * t + f] = {
                {float(r.normal[f][0]), float(r.normal[f][1]), float(r.normal[f][2]), float(r.offset[f])}};
        cells[kTetStride * t + 4] = {
            {float(r.gradient[0]), float(r.gradient[1]), float(r.gradient[2]), float(r.value)}};
        tets[t] = {{mesh.tets[t][0], mesh.tets[t][1], mesh.tets[t][2], mesh.tets[t][3]}};
    });
    m.points = cc_.upload(geometry_.points, CL_MEM_READ_ONLY);
    m.cells = cc_.upload(cells, CL_MEM_READ_ONLY);
    m.tets = cc_.upload(tets, CL_MEM_READ_ONLY);
    m.proj = cc_.allocate<cl_float4>(geometry_.points.size());
    m.order = cc_.allocate<cl_uint>(nt);
    m.items = cc_.allocate<cl_uint4>(nt);
    m.rects = cc_.allocate<cl_uint2>(nt);
    start(meshBounds(mesh_), meshValueRange(mesh_));
}

PtRenderer::~PtRenderer() = default;

EffectPlan PtRenderer::planEffects(const Scene& scene) const {
    return planPt(scene, mesh_, cc_.profile());
}

void PtRenderer::admitScene(const Scene& next) {
    planPt(next, mesh_, cc_.profile()); // refuses before anything changes
    sort_ = sceneMeshSort(next, mesh_);
}

void PtRenderer::rebuild(const Rebuild& change) {
    Impl& m = *impl_;
    const double maxSegment = mesh_.maxEdgeLength > 0.0 ? mesh_.maxEdgeLength : geometry_.scale;
    TableSpec spec;
    spec.size = scene_.tableSize;
    spec.axis = LengthAxis::Linear;
    spec.lengths = scene_.tableLengths;
    spec.maxLength = maxSegment;
    selectPreintegrationTable(change.shaded, spec);
    m.tf = tfParams(scene_, change.shaded, knotCount(), tableLengths());
    m.tf.tableMaxLength = float(maxSegment);
    if (!(m.defines == plan_.defines) || m.raster.get() == nullptr) {
        m.defines = plan_.defines;
        KernelDefines project;
        project.set("KB_TILE", kKBufferTile).set("BIN_CHUNKS", cc_.profile().mesh.binChunks);
        m.project = cc_.kernel("mesh/mesh_kbuffer.cl", "kb_project", project);
        m.tetRects = cc_.kernel("mesh/mesh_pt.cl", "pt_tet_rects", m.defines);
        m.raster = cc_.kernel("mesh/mesh_pt.cl", "pt_raster", m.defines);
    }
}

VolclKBufferParams PtRenderer::frameParams() const {
    return kbufferParams(geometry_, camera_, scene_.width, scene_.height, scene_.earlyTermination,
                         mesh_.tets.size(), impl_->tf);
}

VolclClipParams PtRenderer::normalisedClip() const {
    return meshClipParams(plan_.clipPlanes, geometry_.centre, geometry_.scale);
}

std::vector<float> PtRenderer::tableValues() {
    const std::vector<cl_float4> t = cc_.download(table());
    std::vector<float> out(4 * t.size());
    for (std::size_t i = 0; i < t.size(); ++i)
        for (int c = 0; c < 4; ++c)
            out[4 * i + std::size_t(c)] = t[i].s[c];
    return out;
}

ImageBuffer PtRenderer::render() {
    Impl& m = *impl_;
    const VolclKBufferParams P = frameParams();
    const VolclClipParams K = normalisedClip();
    ensureFrameBuffers();
    const std::size_t tiles = std::size_t(P.tilesX) * P.tilesY;
    const DeviceProfile::Mesh& tuning = cc_.profile().mesh;
    const cl_uint n = cl_uint(mesh_.tets.size());
    times_ = {};

    order_ = m.sorter.sort(sortViewOf(camera_), sort_);
    times_.sort = order_.seconds * 1000.0;
    cc_.write(m.order, std::span<const cl_uint>(order_.tets));

    setArgs(m.project, m.points, P, m.proj);
    times_.project = eventMilliseconds(cc_.launch1d(m.project, geometry_.points.size(), tuning.kbuffer));
    setArgs(m.tetRects, m.order, m.tets, m.proj, n, P, m.items, m.rects);
    times_.bin = eventMilliseconds(cc_.launch1d(m.tetRects, n, tuning.kbuffer));
    times_.bin += m.binner.bin(m.items, m.rects, n, P.tilesX, tiles);

    const std::size_t threads = tuning.tileThreads;
    setArgs(m.raster, m.cells, m.binner.ends(), m.binner.list(), P, K, table(), out_);
    times_.raster =
        eventMilliseconds(cc_.launch(m.raster, cl::NDRange(tiles * threads), cl::NDRange(threads)));

    lastMs_ = times_.kernels();
    ImageBuffer img = downloadFrame(false);
    img.attributes.push_back({"volcl:mode", std::string(renderModeName(scene_.mode))});
    img.attributes.push_back({"volcl:method", std::string("pt")});
    img.attributes.push_back({"volcl:sort", std::string(meshSortName(sort_))});
    img.attributes.push_back({"volcl:effects", plan_.defines.toOptions()});
    return img;
}

std::string PtRenderer::statistics() const {
    std::ostringstream os;
    os << "tets: " << mesh_.tets.size() << ", sort " << meshSortName(sort_) << " (cycles broken "
       << order_.cyclesBroken << ", " << formatNumber(order_.seconds * 1000.0) << " ms), tile entries "
       << impl_->binner.entries();
    return os.str();
}

} // namespace volcl
