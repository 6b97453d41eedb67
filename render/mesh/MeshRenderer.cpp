// The cell ray caster's host side: the normalised mesh on the device, per-tet emptiness, TF and 3D table,
// kernel parameters and launches.
#include "render/mesh/MeshRenderer.hpp"

#include "cl/volcl_shared.h"
#include "core/Error.hpp"
#include "core/Format.hpp"
#include "core/runtime/DeviceProfile.hpp"
#include "core/runtime/ParallelFor.hpp"
#include "core/runtime/Timing.hpp"
#include "preintegration/PreintegrationTable.hpp"
#include "render/FrameParams.hpp"
#include "render/VecMath.hpp"
#include "render/grid/GridDetail.hpp"
#include "render/mesh/MeshGeometry.hpp"
#include "render/mesh/MeshReference.hpp"
#include "render/mesh/VertexNormals.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <iomanip>
#include <sstream>

namespace volcl {
namespace {

constexpr int kEmptyBins = 4096; ///< TF emptiness is looked up per bin of the domain

cl_float4 f4(const Vec3& v, float w) {
    cl_float4 r;
    r.s[0] = float(v[0]);
    r.s[1] = float(v[1]);
    r.s[2] = float(v[2]);
    r.s[3] = w;
    return r;
}

float bitsAsFloat(std::uint32_t u) {
    float f;
    std::memcpy(&f, &u, sizeof f);
    return f;
}

/// Rounds a normalised bound outward by a few float ulps so the float box still contains the faces.
float outward(double v, bool up) {
    const float f = float(v);
    const float pad = 4e-7f * std::max(std::abs(f), 1.0f);
    return up ? f + pad : f - pad;
}

} // namespace

struct MeshRenderer::Impl {
    Vec3 centre{0, 0, 0};
    double scale = 1.0;
    std::vector<float> tetMin, tetMax;
    DeviceBuffer<cl_float4> cells, bvhNodes, bvhFaces; ///< cells: 6 per tet (planes, field, neighbours)
    DeviceBuffer<cl_uchar> empty;
    /// Shading with smooth normals: 3 per tet, the interpolated vertex normals' linear field in the normalised
    /// frame (SMOOTH_NORMALS); one unused element otherwise. Built on the first frame that needs it.
    DeviceBuffer<cl_float4> normals;
    bool normalsBuilt = false;
    DeviceBuffer<float> tauIntegral;
    std::size_t bvhNodeCount = 0;
    double maxSegment = 1.0;
    bool mayOverlap = false; ///< tets may overlap: rays integrate the union of their tet intervals
    cl::Kernel kernel;
    VolclMeshRenderParams params{};
};

VolclClipParams meshClipParams(const std::vector<ClipPlane>& planes, const Vec3& centre, double meshScale) {
    VolclClipParams p = clipParams(planes);
    for (unsigned i = 0; i < p.count; ++i) {
        const double nn = norm(planes[i].normal);
        p.plane[i][3] = float((dot(scale(planes[i].normal, 1.0 / nn), centre) + planes[i].offset / nn) *
                              (1.0 / meshScale));
    }
    return p;
}

MeshRenderer::MeshRenderer(ComputeContext& cc, const mesh::TetMesh& mesh, const TransferFunction& tf,
                           const Scene& scene)
    : RendererBase(cc, tf, scene), mesh_(mesh), impl_(std::make_unique<Impl>()) {
    if (mesh.tets.empty()) throw DataError("mesh has no tetrahedra");
    Impl& m = *impl_;
    const std::size_t nt = mesh.tets.size();
    m.centre = scale(add(mesh.boundsMin, mesh.boundsMax), 0.5);
    m.scale = std::max(0.5 * norm(sub(mesh.boundsMax, mesh.boundsMin)), 1e-300);
    const double inv = 1.0 / m.scale;
    auto normalise = [&](const Vec3& p) { return scale(sub(p, m.centre), inv); };

    // Per tet, contiguous: face planes (unit normals in the normalised frame), field, neighbours. Each shared
    // face's plane is computed from the lower-numbered side and negated on the other, so both tets agree
    // exactly on where a ray crosses it.
    constexpr std::size_t kStride = 6; // CELL_STRIDE of cl/mesh/mesh_cells.cl
    std::vector<cl_float4> cells(kStride * nt);
    m.tetMin.resize(nt);
    m.tetMax.resize(nt);
    parallelFor(nt, 0u, [&](std::size_t t) {
        const mesh_detail::NormalisedTet nt4 = mesh_detail::normalisedTet(mesh, t, m.centre, m.scale);
        for (unsigned f = 0; f < 4; ++f) {
            cells[kStride * t + f] = f4(nt4.normal[f], float(nt4.offset[f]));
            cells[kStride * t + 5].s[f] = bitsAsFloat(mesh.neighbors[mesh::faceId(t, f)]);
        }
        // A NaN cell says so by a NaN field (the kernel's NAN_COLOR test); no range: only the NaN colour can
        // show there.
        cells[kStride * t + 4] = f4(nt4.gradient, float(nt4.value));
        if (!nt4.finite) {
            m.tetMin[t] = m.tetMax[t] = NAN;
            return;
        }
        float lo = mesh.scalars[mesh.tets[t][0]], hi = lo;
        for (int k = 1; k < 4; ++k) {
            lo = std::min(lo, mesh.scalars[mesh.tets[t][k]]);
            hi = std::max(hi, mesh.scalars[mesh.tets[t][k]]);
        }
        m.tetMin[t] = lo;
        m.tetMax[t] = hi;
    });
    const mesh_detail::BoundaryBvh bvh = mesh_detail::buildBoundaryBvh(mesh);
    m.mayOverlap = mesh_detail::mayOverlap(mesh);
    // A boundary face on the convex hull says so in its neighbour slot: a ray leaving there is done.
    const std::vector<std::uint8_t> hull = mesh_detail::hullFaces(mesh, bvh);
    for (std::size_t i = 0; i < bvh.faces.size(); ++i)
        if (hull[i])
            cells[kStride * mesh::faceTet(bvh.faces[i]) + 5].s[mesh::faceLocal(bvh.faces[i])] =
                bitsAsFloat(VOLCL_MESH_HULL_FACE);
    m.cells = cc_.upload(cells, CL_MEM_READ_ONLY);
    // Where tets may overlap, the faces of tets that do overlap others (and the nodes above them) are marked: only
    // they can be entered inside a part of the ray that earlier walks covered (see mesh_cells.cl, ray_advance).
    std::vector<std::uint8_t> faceOverlaps(bvh.faces.size(), 0), nodeOverlaps(bvh.nodes.size(), 0);
    if (m.mayOverlap) {
        const std::vector<std::uint8_t> tets = mesh_detail::overlappingTets(mesh);
        for (std::size_t i = 0; i < bvh.faces.size(); ++i)
            faceOverlaps[i] = tets[mesh::faceTet(bvh.faces[i])];
        for (std::size_t i = bvh.nodes.size(); i-- > 0;) { // children follow their parent
            const auto& n = bvh.nodes[i];
            if (n.count)
                for (std::uint32_t k = n.first; k < n.first + n.count; ++k)
                    nodeOverlaps[i] |= faceOverlaps[k];
            else
                nodeOverlaps[i] = nodeOverlaps[i + 1] | nodeOverlaps[n.right];
        }
    }
    std::vector<cl_float4> nodes(2 * std::max<std::size_t>(bvh.nodes.size(), 1));
    for (std::size_t i = 0; i < bvh.nodes.size(); ++i) {
        const auto& n = bvh.nodes[i];
        const Vec3 lo = normalise(n.lo), hi = normalise(n.hi);
        nodes[2 * i] = {{outward(lo[0], false), outward(lo[1], false), outward(lo[2], false),
                         bitsAsFloat(n.count ? n.first : n.right)}};
        nodes[2 * i + 1] = {{outward(hi[0], true), outward(hi[1], true), outward(hi[2], true),
                             bitsAsFloat(n.count | (nodeOverlaps[i] ? VOLCL_MESH_BVH_OVERLAP : 0u))}};
    }
    std::vector<cl_float4> faces(3 * std::max<std::size_t>(bvh.faces.size(), 1));
    for (std::size_t i = 0; i < bvh.faces.size(); ++i) {
        const auto v = mesh.faceVertices(bvh.faces[i]);
        const Vec3 a = normalise(mesh.points[v[0]]), b = normalise(mesh.points[v[1]]),
                   c = normalise(mesh.points[v[2]]);
        faces[3 * i] = f4(a, bitsAsFloat(bvh.faces[i]));
        faces[3 * i + 1] = f4(sub(b, a), hull[i] ? 1.0f : 0.0f);
        faces[3 * i + 2] = f4(sub(c, a), faceOverlaps[i] ? 1.0f : 0.0f);
    }
    m.bvhNodes = cc_.upload(nodes, CL_MEM_READ_ONLY);
    m.bvhFaces = cc_.upload(faces, CL_MEM_READ_ONLY);
    m.bvhNodeCount = bvh.nodes.size();
    m.maxSegment = mesh.maxEdgeLength > 0.0 ? mesh.maxEdgeLength : m.scale;
    start(meshBounds(mesh_), meshValueRange(mesh_));
}

MeshRenderer::~MeshRenderer() = default;

EffectPlan MeshRenderer::planEffects(const Scene& scene) const {
    return planMeshEffects(scene, mesh_);
}

void MeshRenderer::viewChanged(bool sameView) {
    (void)sameView;
    impl_->params.camera = cameraParams(camera_, scene_.width, scene_.height);
}

void MeshRenderer::rebuild(const Rebuild& change) {
    const bool preint = plan_.defines.toOptions().find("-DPREINT=3") != std::string::npos;
    if (change.knotsChanged) uploadTauIntegral();
    if (preint) {
        TableSpec spec;
        spec.size = scene_.tableSize;
        spec.axis = LengthAxis::Linear;
        spec.lengths = scene_.tableLengths;
        spec.maxLength = impl_->maxSegment;
        selectPreintegrationTable(change.shaded, spec);
    }
    updateEmptiness(change.shaded, preint);
    KernelDefines defines = plan_.defines;
    defines.set("RAYS_X", cc_.profile().mesh.cellRaysX).set("RAYS_Y", cc_.profile().mesh.cellRaysY);
    // Where tets may overlap (folds, interpenetrating components) rays take every entry and count the union;
    // elsewhere a ray is outside after a boundary exit and the next entry ahead is all there is.
    if (impl_->mayOverlap) defines.set("MESH_OVERLAPS", 1);
    if (plan_.shading && scene_.effects.smoothNormals) {
        defines.set("SMOOTH_NORMALS", 1);
        uploadNormals();
    } else if (impl_->normals.size() == 0) {
        impl_->normals = cc_.allocate<cl_float4>(1);
    }
    impl_->kernel = cc_.kernel("mesh/mesh_cells.cl", "mesh_cells", defines);
    updateParams(change.shaded);
}

void MeshRenderer::uploadNormals() {
    Impl& m = *impl_;
    if (m.normalsBuilt) return;
    const std::vector<Vec3> vn = vertexNormals(mesh_);
    const std::size_t nt = mesh_.tets.size();
    std::vector<cl_float4> rows(3 * nt);
    // N_c(x) = value_c + g_c . (x - p0) with x = centre + scale x', scaled by `scale` as the cell's field
    // gradient is (the gradient threshold is in those units): N'_c(x') = scale (value_c + g_c . (centre - p0))
    // + scale^2 g_c . x'.
    parallelFor(nt, 0u, [&](std::size_t t) {
        const TetNormalField f = tetNormalField(mesh_, vn, t);
        for (int c = 0; c < 3; ++c) {
            const Vec3& g = f.gradient[std::size_t(c)];
            rows[3 * t + std::size_t(c)] =
                f4(scale(g, m.scale * m.scale),
                   float(m.scale * (f.value[std::size_t(c)] + dot(g, sub(m.centre, f.p0)))));
        }
    });
    m.normals = cc_.upload(rows, CL_MEM_READ_ONLY);
    m.normalsBuilt = true;
}

void MeshRenderer::uploadTauIntegral() {
    // Exact for the piecewise-linear tau.
    const std::vector<VolclTfKnot>& knots = hostKnots();
    std::vector<float> cum(knots.size(), 0.0f);
    double acc = 0.0;
    for (std::size_t k = 0; k + 1 < knots.size(); ++k) {
        const double d = double(knots[k + 1].s) - double(knots[k].s);
        acc += d * double(knots[k].value[3]) + 0.5 * d * d * double(knots[k].slope[3]);
        cum[k + 1] = float(acc);
    }
    impl_->tauIntegral = cc_.upload(cum, CL_MEM_READ_ONLY);
}

void MeshRenderer::updateEmptiness(const TransferFunction& shaded, bool preint) {
    Impl& m = *impl_;
    // Per-tet emptiness: a tet is skipped when no iso-value lies in its range and (dvr) the TF's
    // extinction is zero over it, widened to the table nodes a lookup blends.
    const std::size_t nt = mesh_.tets.size();
    std::vector<cl_uchar> empty(nt, 0);
    std::size_t emptyCount = 0;
    if (plan_.skipping) {
        const double lo = shaded.domain[0], hi = shaded.domain[1], bw = (hi - lo) / kEmptyBins;
        std::vector<int> visibleBefore(kEmptyBins + 1, 0);
        const bool dvr = scene_.mode == RenderMode::Dvr;
        for (int b = 0; b < kEmptyBins; ++b) {
            const bool vis =
                dvr && grid_detail::maxExtinctionOver(shaded, lo + b * bw, lo + (b + 1) * bw) > 0.0;
            visibleBefore[b + 1] = visibleBefore[b] + (vis ? 1 : 0);
        }
        const double pad = preint ? (hi - lo) / double(std::max(scene_.tableSize - 1, 1)) : 0.0;
        auto bin = [&](double s) { return std::clamp(int(std::floor((s - lo) / bw)), 0, kEmptyBins - 1); };
        const bool nanShows = dvr && scene_.nanColor[3] > 0.0;
        for (std::size_t t = 0; t < nt; ++t) {
            const double a = m.tetMin[t], b = m.tetMax[t];
            if (std::isnan(a)) { // a NaN cell: only the NaN colour shows there
                empty[t] = nanShows ? 0 : 1;
                emptyCount += empty[t];
                continue;
            }
            bool vis = false;
            for (const auto& iso : plan_.isosurfaces)
                vis |= iso.value > a && iso.value <= b;
            if (!vis) {
                const int b0 = bin(a - pad), b1 = bin(b + pad);
                vis = visibleBefore[b1 + 1] - visibleBefore[b0] > 0;
            }
            empty[t] = vis ? 0 : 1;
            emptyCount += empty[t];
        }
    }
    emptyFraction_ = double(emptyCount) / double(nt);
    m.empty = cc_.upload(empty, CL_MEM_READ_ONLY);
}

void MeshRenderer::updateParams(const TransferFunction& shaded) {
    Impl& m = *impl_;
    const std::size_t nt = mesh_.tets.size();
    VolclMeshRenderParams& p = m.params;
    p = {};
    p.camera = cameraParams(camera_, scene_.width, scene_.height);
    p.clip = meshClipParams(plan_.clipPlanes, m.centre, m.scale);
    const double inv = 1.0 / m.scale;
    p.march = marchParams(scene_, meshValueRange(mesh_));
    p.tf = tfParams(scene_, shaded, knotCount(), tableLengths());
    p.tf.tableMaxLength = float(m.maxSegment);
    p.lighting = meshLightingParams(scene_, mesh_, m.centre, m.scale);
    p.iso = isoParams(plan_);
    VolclMeshParams& mp = p.mesh;
    const Vec3 lo = scale(sub(mesh_.boundsMin, m.centre), inv),
               hi = scale(sub(mesh_.boundsMax, m.centre), inv);
    for (int a = 0; a < 3; ++a) {
        mp.centre[a] = float(m.centre[a]);
        mp.boxLo[a] = outward(lo[a], false);
        mp.boxHi[a] = outward(hi[a], true);
    }
    mp.scale = float(m.scale);
    mp.invScale = float(inv);
    mp.epsilon = 1e-5f;
    mp.maxSegment = float(m.maxSegment);
    mp.tetCount = volcl_uint(nt);
    mp.boundaryFaces = volcl_uint(mesh_.boundaryFaces.size());
    mp.bvhNodes = volcl_uint(m.bvhNodeCount);
}

ImageBuffer MeshRenderer::render() {
    Impl& m = *impl_;
    ensureFrameBuffers();
    setArgs(m.kernel, m.cells, m.empty, m.bvhNodes, m.bvhFaces, knots(), m.tauIntegral, table(), m.normals,
            m.params, out_, depth_);
    // One work-item per RAYS_X x RAYS_Y pixel block.
    const DeviceProfile::Mesh& tuning = cc_.profile().mesh;
    cl::Event ev =
        cc_.launch2d(m.kernel, (std::size_t(scene_.width) + tuning.cellRaysX - 1) / tuning.cellRaysX,
                     (std::size_t(scene_.height) + tuning.cellRaysY - 1) / tuning.cellRaysY, tuning.cells);
    lastMs_ = eventMilliseconds(ev);
    ImageBuffer img = downloadFrame(!plan_.isosurfaces.empty());
    addFrameAttributes(img, "cells");
    return img;
}

std::string MeshRenderer::statistics() const {
    std::ostringstream os;
    os << "tets: " << mesh_.tets.size() << ", boundary faces: " << mesh_.boundaryFaces.size() << " (BVH of "
       << impl_->bvhNodeCount << " nodes), " << std::setprecision(1) << std::fixed << 100.0 * emptyFraction_
       << "% of tets empty under the TF"
       << (impl_->mayOverlap ? "; tets may overlap: rays take the union of the tets' intervals" : "");
    return os.str();
}

} // namespace volcl
