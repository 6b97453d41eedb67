// The k-buffer renderer: device buffers, tables, the per-frame face order (host visibility order or device
// radix sort) and launches (project, keys, bin, raster).
#include "render/mesh/KBufferRenderer.hpp"

#include "core/Error.hpp"
#include "core/Format.hpp"
#include "core/runtime/DeviceProfile.hpp"
#include "core/runtime/Timing.hpp"
#include "render/FrameParams.hpp"
#include "render/VecMath.hpp"
#include "render/mesh/MeshReference.hpp"
#include "render/mesh/PtRenderer.hpp" // sortViewOf
#include "render/mesh/RadixSort.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <sstream>

namespace volcl {

EffectPlan planKBuffer(const Scene& scene, const mesh::TetMesh& mesh, int k, const DeviceProfile& device,
                       MeshSort sort) {
    if (k < kKBufferMinK || k > kKBufferMaxK)
        throw UsageError("render.k must be " + std::to_string(kKBufferMinK) + ".." +
                         std::to_string(kKBufferMaxK) + " (got " + std::to_string(k) + ")");
    const bool iso = scene.mode == RenderMode::Iso;
    if (scene.mode != RenderMode::Dvr && !iso)
        throw UsageError("render.method \"kbuffer\" draws modes dvr and iso only (mode " +
                         std::string(renderModeName(scene.mode)) + ": use render.method \"cells\")");
    EffectPlan p;
    p.defines.set("KB_K", k)
        .set("KB_TILE", kKBufferTile)
        .set("KB_TILE_THREADS", device.mesh.tileThreads)
        .set("BIN_CHUNKS", device.mesh.binChunks);
    const std::string order =
        sort == MeshSort::Centroid
            ? "faces sorted by centroid every frame (device radix sort; render.sort \"centroid\")"
            : "faces placed every frame by the " + std::string(meshSortName(sort)) +
                  " visibility order of the cells (host; render.sort \"" + std::string(meshSortName(sort)) +
                  "\")";
    p.compiled.push_back(
        "mode " + std::string(renderModeName(scene.mode)) + " by k-buffer (HAVS): k = " + std::to_string(k) +
        ", " + std::to_string(kKBufferTile) + "x" + std::to_string(kKBufferTile) + "-pixel tiles, " + order);
    const SceneEffects& fx = scene.effects;
    const std::string why = ": not drawn by render.method \"kbuffer\" (use \"cells\")";
    if (iso) {
        // The iso-surfaces, their colours and the shading the cell caster would draw, found by its planner.
        const EffectPlan cells = planMeshEffects(scene, mesh);
        p.isosurfaces = cells.isosurfaces;
        p.colorScale = cells.colorScale;
        p.shading = cells.shading;
        p.defines.set("KB_ISO").set("ISO_COUNT", std::max<long long>(1, (long long)p.isosurfaces.size()));
        if (p.shading) p.defines.set("SHADING");
        p.compiled.push_back(
            "isosurfaces: " + std::to_string(p.isosurfaces.size()) +
            " (crossed where each popped fragment pair's linear scalar crosses them, composited "
            "in ray order)");
        for (const std::string& c : cells.compiled)
            if (c.rfind("shading:", 0) == 0)
                p.compiled.push_back(c.substr(0, c.find(" (")) +
                                     " (smooth normals: vertex normals interpolated on the faces and along "
                                     "each segment)");
        for (const std::string& d : cells.dropped)
            if (d.rfind("isosurface", 0) == 0 || d.rfind("shading:", 0) == 0) p.dropped.push_back(d);
        if (p.shading && !fx.smoothNormals)
            p.dropped.push_back("normals \"flat\": a fragment pair does not know its tet, so the k-buffer "
                                "lights with smooth vertex normals (use render.method \"cells\")");
    } else {
        p.compiled.push_back("pre-integration: 3D table " + std::to_string(scene.tableSize) + "x" +
                             std::to_string(scene.tableSize) + "x" + std::to_string(scene.tableLengths) +
                             ", lengths up to the longest edge " + formatNumber(mesh.maxEdgeLength));
        if (scene.preintegration != Preintegration::Table3d)
            p.dropped.push_back("preintegration \"" + std::string(preintegrationName(scene.preintegration)) +
                                "\": the k-buffer integrates every segment through the 3D table");
        if (fx.shading) p.dropped.push_back("shading" + why);
        if (!fx.isosurfaces.empty()) p.dropped.push_back("iso-surfaces" + why);
    }
    p.earlyTermination = scene.earlyTermination < 1.0;
    if (p.earlyTermination)
        p.compiled.push_back("early termination at alpha >= " + formatNumber(scene.earlyTermination));
    if (fx.shadows) p.dropped.push_back("shadows" + why);
    if (fx.scattering) p.dropped.push_back("scattering" + why);
    if (!fx.clipPlanes.empty() || fx.cropBox) p.dropped.push_back("clip planes and crop box" + why);
    if (scene.window) p.dropped.push_back("window: mode dvr is not mip");
    planNanColor(scene, meshHasNonFinite(mesh), p);
    return p;
}

/// A table in both forms: the host values rounded to half precision as the device holds them (for the C++
/// mirror), and the device's blocked half-precision copy (kbufferBlockedTable) for kb_raster.
struct KBufferRenderer::Table {
    PreintegrationTable host;
    DeviceBuffer<cl_half> device;
};

struct KBufferRenderer::Impl {
    explicit Impl(ComputeContext& cc) : sorter(cc), binner(cc) {}
    DeviceRadixSort sorter;
    TileBinner binner;
    /// The exact orders' cell sort (its graphs and convexification kept for the renderer's life) and face
    /// placement (made on the first such frame, again when the faces are rebuilt), and the last order given.
    std::unique_ptr<VisibilitySorter> cellSorter;
    std::unique_ptr<KBufferFaceSorter> faceSorter;
    std::vector<std::uint32_t> hostOrder;
    bool hostOrdered = false; ///< the last frame's order came from the host
    DeviceBuffer<cl_uint> order;
    /// defaultKBufferSort of the mesh, found on the first scene that leaves render.sort unset.
    std::optional<MeshSort> defaultSort;
    DeviceBuffer<cl_float4> points, proj;
    DeviceBuffer<float> scalars;
    /// Mode iso with shading: kbufferPointNormals (built on the first such frame); one unused element otherwise.
    DeviceBuffer<cl_float4> normals;
    std::vector<cl_float4> hostNormals;
    DeviceBuffer<cl_uint4> faces, sortedFaces;
    DeviceBuffer<cl_uint> keys, vals;
    DeviceBuffer<cl_uint2> rects, sortedRects;
    cl::Kernel project, faceKeys, gather, raster, toHalf, fromHalf;
    KernelDefines defines;
    /// Tables of full quality (lengths up to the longest edge) and of level of detail (up to the box
    /// diagonal): a viewer alternates between the two.
    TableCache<Table> tables{2};
    const Table* table = nullptr; ///< the one the next frame reads
};

KBufferRenderer::KBufferRenderer(ComputeContext& cc, const mesh::TetMesh& mesh, const TransferFunction& tf,
                                 const Scene& scene, int k, const FaceSplitOptions& split)
    : RendererBase(cc, tf, scene), mesh_(mesh), split_(split), k_(k), impl_(std::make_unique<Impl>(cc)) {
    if (mesh.tets.empty()) throw DataError("mesh has no tetrahedra");
    if (mesh.points.size() > 0xFFFFFFFFu)
        throw DataError("mesh has too many points for the k-buffer (2^32 - 1)");
    start(meshBounds(mesh_), meshValueRange(mesh_)); // admitScene builds the faces for the scene's order
}

void KBufferRenderer::ensureFaces() {
    // Cutting long faces only helps the centroid sort (a sliver's centroid far from where rays cross it); an
    // exact order places every piece of a face together, so they would only cost time.
    const bool cut = sort_ == MeshSort::Centroid && split_.ratio > 0.0;
    if (facesBuilt_ && cut == facesCut_) return;
    faces_ = buildMeshFaces(mesh_);
    if (cut) splitLongFaces(faces_, mesh_, split_.ratio, split_.budget);
    facesBuilt_ = true;
    facesCut_ = cut;
    geometry_ = kbufferGeometry(mesh_, faces_);
    if (geometry_.points.size() > 0xFFFFFFFFu)
        throw DataError("mesh has too many points for the k-buffer (2^32 - 1)");
    Impl& m = *impl_;
    m.faceSorter.reset();
    m.hostOrder.clear();
    m.hostOrdered = false;
    m.hostNormals.clear();
    m.points = cc_.upload(geometry_.points, CL_MEM_READ_ONLY);
    m.scalars = cc_.upload(geometry_.scalars, CL_MEM_READ_ONLY);
    std::vector<cl_uint4> faceRecords(faces_.faces.size());
    for (std::size_t i = 0; i < faceRecords.size(); ++i) {
        const MeshFace& f = faces_.faces[i];
        faceRecords[i] = {{f.v[0], f.v[1], f.v[2], f.boundary ? KB_FACE_BOUNDARY : 0u}};
    }
    m.faces = cc_.upload(faceRecords, CL_MEM_READ_ONLY);
    m.proj = cc_.allocate<cl_float4>(geometry_.points.size());
    m.keys = cc_.allocate<cl_uint>(faceRecords.size());
    m.vals = cc_.allocate<cl_uint>(faceRecords.size());
    m.rects = cc_.allocate<cl_uint2>(faceRecords.size());
    m.sortedFaces = cc_.allocate<cl_uint4>(faceRecords.size());
    m.sortedRects = cc_.allocate<cl_uint2>(faceRecords.size());
    m.normals = cc_.allocate<cl_float4>(1);
    m.order = cc_.allocate<cl_uint>(faceRecords.size());
}

MeshSort KBufferRenderer::sortOf(const Scene& scene) const {
    if (scene.meshSort) return *scene.meshSort;
    if (!impl_->defaultSort) impl_->defaultSort = defaultKBufferSort(mesh_);
    return *impl_->defaultSort;
}

KBufferRenderer::~KBufferRenderer() = default;

EffectPlan KBufferRenderer::planEffects(const Scene& scene) const {
    return planKBuffer(scene, mesh_, k_, cc_.profile(), sortOf(scene));
}

void KBufferRenderer::admitScene(const Scene& next) {
    const int k = next.kBufferDepth != scene_.kBufferDepth ? next.kBufferDepth : k_;
    const MeshSort sort = sortOf(next);
    planKBuffer(next, mesh_, k, cc_.profile(), sort); // refuses before anything changes
    k_ = k;
    sort_ = sort;
    ensureFaces();
}

void KBufferRenderer::setK(int k) {
    planKBuffer(scene_, mesh_, k, cc_.profile(), sort_);
    k_ = k;
    replan(false);
}

void KBufferRenderer::setLodFraction(double q) {
    if (!(q >= 0.0 && q <= 1.0)) throw UsageError("level of detail must be a fraction in [0, 1]");
    lod_ = q;
    ensureTable();
}

std::size_t KBufferRenderer::facesDrawn() const noexcept {
    return faces_.prefixForFraction(lod_);
}

void KBufferRenderer::rebuild(const Rebuild& change) {
    (void)change; // the table's key holds the TF
    Impl& m = *impl_;
    if (!(m.defines == plan_.defines) || m.raster.get() == nullptr) {
        m.defines = plan_.defines;
        m.project = cc_.kernel("mesh/mesh_kbuffer.cl", "kb_project", m.defines);
        m.faceKeys = cc_.kernel("mesh/mesh_kbuffer.cl", "kb_face_keys", m.defines);
        m.gather = cc_.kernel("mesh/mesh_kbuffer.cl", "kb_gather", m.defines);
        m.raster = cc_.kernel("mesh/mesh_kbuffer.cl", "kb_raster", m.defines);
        m.toHalf = cc_.kernel("mesh/mesh_kbuffer.cl", "kb_table_to_half", m.defines);
        m.fromHalf = cc_.kernel("mesh/mesh_kbuffer.cl", "kb_table_from_half", m.defines);
    }
    if (plan_.shading && m.hostNormals.empty()) {
        m.hostNormals = kbufferPointNormals(mesh_, faces_, geometry_);
        m.normals = cc_.upload(m.hostNormals, CL_MEM_READ_ONLY);
    }
    ensureTable();
}

void KBufferRenderer::ensureTable() {
    const WorldBox b = bounds();
    const double maxLength = lod_ < 1.0 ? std::max(norm(b.extent), mesh_.maxEdgeLength) : mesh_.maxEdgeLength;
    const TableSpec spec = kbufferTableSpec(scene_, maxLength > 0.0 ? maxLength : 1.0);
    tableMs_ = 0.0;
    impl_->table =
        &cachedTable(impl_->tables, tableKey(tf_.toJson(), spec), [&] { return buildTable(spec); });
}

KBufferRenderer::Table KBufferRenderer::buildTable(const TableSpec& spec) {
    Impl& m = *impl_;
    Table t;
    t.host = generatePreintegrationTable(tf_, spec, {}, &cc_);
    // Round on the device (vstore_half_rte) and read the rounded values back into the host table, so the C++
    // mirror sees what the kernels see; then block the rounded values (exact in half) for kb_raster.
    const std::size_t entries = t.host.rgba.size() / 4;
    auto toHalf = [&](const std::vector<cl_float4>& values) {
        const DeviceBuffer<cl_float4> f = cc_.upload(values, CL_MEM_READ_ONLY);
        DeviceBuffer<cl_half> h = cc_.allocate<cl_half>(4 * values.size());
        setArgs(m.toHalf, f, cl_uint(values.size()), h);
        cc_.launch1d(m.toHalf, values.size(), cc_.profile().mesh.kbuffer);
        return h;
    };
    std::vector<cl_float4> plain(entries);
    for (std::size_t i = 0; i < entries; ++i)
        plain[i] = {
            {t.host.rgba[4 * i], t.host.rgba[4 * i + 1], t.host.rgba[4 * i + 2], t.host.rgba[4 * i + 3]}};
    const DeviceBuffer<cl_half> rounded = toHalf(plain);
    DeviceBuffer<cl_float4> back = cc_.allocate<cl_float4>(entries);
    setArgs(m.fromHalf, rounded, cl_uint(entries), back);
    cc_.launch1d(m.fromHalf, entries, cc_.profile().mesh.kbuffer);
    const std::vector<cl_float4> values = cc_.download(back);
    for (std::size_t i = 0; i < entries; ++i)
        for (int c = 0; c < 4; ++c)
            t.host.rgba[4 * i + std::size_t(c)] = values[i].s[c];
    t.device = toHalf(kbufferBlockedTable(t.host));
    return t;
}

VolclIsoParams KBufferRenderer::isoFrameParams() const {
    return isoParams(plan_);
}

VolclLightingParams KBufferRenderer::lightFrameParams() const {
    return meshLightingParams(scene_, mesh_, geometry_.centre, geometry_.scale);
}

const std::vector<cl_float4>& KBufferRenderer::pointNormals() const {
    return impl_->hostNormals;
}

const std::vector<float>& KBufferRenderer::tableValues() const {
    return impl_->table->host.rgba;
}

VolclKBufferParams KBufferRenderer::frameParams() const {
    return kbufferParams(geometry_, camera_, scene_.width, scene_.height, scene_.earlyTermination,
                         facesDrawn(), kbufferTfParams(impl_->table->host, knotCount()));
}

ImageBuffer KBufferRenderer::render() {
    Impl& m = *impl_;
    const VolclKBufferParams P = frameParams();
    const Table& table = *m.table;
    ensureFrameBuffers();
    const std::size_t tiles = std::size_t(P.tilesX) * P.tilesY;
    const DeviceProfile::Mesh& tuning = cc_.profile().mesh;
    const cl_uint n = P.faceCount;
    times_ = {};

    setArgs(m.project, m.points, P, m.proj);
    times_.project = eventMilliseconds(cc_.launch1d(m.project, geometry_.points.size(), tuning.kbuffer));
    setArgs(m.faceKeys, m.points, m.proj, m.faces, P, m.keys, m.vals, m.rects);
    times_.keys = eventMilliseconds(cc_.launch1d(m.faceKeys, std::max<std::size_t>(n, 1), tuning.kbuffer));
    m.hostOrdered = sort_ != MeshSort::Centroid;
    cyclesBroken_ = 0;
    if (m.hostOrdered) {
        if (!m.cellSorter) m.cellSorter = std::make_unique<VisibilitySorter>(mesh_);
        if (!m.faceSorter) m.faceSorter = std::make_unique<KBufferFaceSorter>(mesh_, faces_, *m.cellSorter);
        KBufferFaceOrder o = m.faceSorter->order(sortViewOf(camera_), sort_, n);
        if (o.faces.size() != n) throw Error("internal: the k-buffer face order misses faces");
        Stopwatch upload;
        cc_.write(m.order, std::span<const cl_uint>(o.faces));
        times_.sort = o.cellSortMs;
        times_.place = o.faceOrderMs + upload.milliseconds();
        cyclesBroken_ = o.cyclesBroken;
        m.hostOrder = std::move(o.faces);
    } else {
        m.sorter.sort(m.keys, m.vals, n);
        times_.sort = m.sorter.lastMilliseconds();
    }

    setArgs(m.gather, m.hostOrdered ? m.order : m.vals, m.faces, m.rects, n, m.sortedFaces, m.sortedRects);
    times_.bin = eventMilliseconds(cc_.launch1d(m.gather, std::max<std::size_t>(n, 1), tuning.kbuffer));
    times_.bin += m.binner.bin(m.sortedFaces, m.sortedRects, n, P.tilesX, tiles);

    const std::size_t threads = tuning.tileThreads;
    setArgs(m.raster, m.proj, m.scalars, m.binner.ends(), m.binner.list(), P, table.device, m.normals,
            isoFrameParams(), lightFrameParams(), out_);
    times_.raster =
        eventMilliseconds(cc_.launch(m.raster, cl::NDRange(tiles * threads), cl::NDRange(threads)));

    lastMs_ = times_.total();
    ImageBuffer img = downloadFrame(false);
    img.attributes.push_back({"volcl:mode", std::string(renderModeName(scene_.mode))});
    img.attributes.push_back({"volcl:method", std::string("kbuffer")});
    img.attributes.push_back({"volcl:k", k_});
    img.attributes.push_back({"volcl:effects", plan_.defines.toOptions()});
    return img;
}

std::unique_ptr<VolumeRenderer> makeKBufferRenderer(ComputeContext& cc, const mesh::TetMesh& mesh,
                                                    const TransferFunction& tf, const Scene& scene) {
    return std::make_unique<KBufferRenderer>(cc, mesh, tf, scene, scene.kBufferDepth);
}

std::vector<cl_uint> KBufferRenderer::lastOrder() {
    std::vector<cl_uint> all = cc_.download(impl_->hostOrdered ? impl_->order : impl_->vals);
    all.resize(facesDrawn());
    return all;
}

const std::vector<std::uint32_t>* KBufferRenderer::hostOrder() const noexcept {
    return impl_->hostOrdered ? &impl_->hostOrder : nullptr;
}

std::string KBufferRenderer::statistics() const {
    std::ostringstream os;
    os << "faces: " << faces_.boundaryCount << " boundary + " << faces_.internalCount() << " internal, drawn "
       << facesDrawn() << ", k " << k_ << ", sort " << meshSortName(sort_);
    if (impl_->hostOrdered)
        os << " (cells " << formatNumber(times_.sort) << " ms, cycles broken " << cyclesBroken_
           << ", faces placed " << formatNumber(times_.place) << " ms)";
    os << ", tile entries " << impl_->binner.entries();
    return os.str();
}

} // namespace volcl
