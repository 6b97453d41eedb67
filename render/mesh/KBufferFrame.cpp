// Normalized geometry, frame parameters and table shape of the k-buffer renderer and its C++ mirror.
#include "render/mesh/KBufferFrame.hpp"

#include "core/runtime/DeviceProfile.hpp"
#include "core/runtime/Timing.hpp"
#include "render/VecMath.hpp"
#include "render/mesh/VertexNormals.hpp"

#include <algorithm>
#include <cmath>

namespace volcl {

KBufferGeometry kbufferGeometry(const mesh::TetMesh& mesh, const MeshFaces& faces) {
    KBufferGeometry g;
    Vec3 extent{};
    for (int i = 0; i < 3; ++i) {
        g.centre[i] = 0.5 * (mesh.boundsMin[i] + mesh.boundsMax[i]);
        extent[i] = mesh.boundsMax[i] - mesh.boundsMin[i];
    }
    const double r = 0.5 * norm(extent);
    g.scale = r > 0.0 && std::isfinite(r) ? r : 1.0;
    const std::size_t n = mesh.points.size();
    g.points.resize(n + faces.extraPoints.size());
    g.scalars = mesh.scalars;
    g.scalars.insert(g.scalars.end(), faces.extraScalars.begin(), faces.extraScalars.end());
    for (std::size_t i = 0; i < g.points.size(); ++i) {
        const auto& p = i < n ? mesh.points[i] : faces.extraPoints[i - n];
        g.points[i] = {{float((p[0] - g.centre[0]) / g.scale), float((p[1] - g.centre[1]) / g.scale),
                        float((p[2] - g.centre[2]) / g.scale), 0.0f}};
    }
    return g;
}

std::vector<cl_float4> kbufferPointNormals(const mesh::TetMesh& mesh, const MeshFaces& faces,
                                           const KBufferGeometry& g) {
    const std::vector<Vec3> vn = vertexNormals(mesh);
    std::vector<Vec3> all(vn);
    all.reserve(vn.size() + faces.extraParents.size());
    for (const auto& e : faces.extraParents) // parents come before their midpoint
        all.push_back(scale(add(all[e[0]], all[e[1]]), 0.5));
    std::vector<cl_float4> out(all.size());
    for (std::size_t i = 0; i < all.size(); ++i)
        out[i] = {{float(all[i][0] * g.scale), float(all[i][1] * g.scale), float(all[i][2] * g.scale), 0.0f}};
    return out;
}

VolclKBufferParams kbufferParams(const KBufferGeometry& g, const Camera& cam, int width, int height,
                                 double earlyTermination, std::size_t faceCount, const VolclTfParams& tf) {
    VolclKBufferParams p{};
    const Vec3 f = normalized(sub(cam.target, cam.eye));
    const Vec3 r = normalized(cross(f, cam.up));
    const Vec3 u = cross(r, f);
    const Vec3 eye = scale(sub(cam.eye, g.centre), 1.0 / g.scale);
    for (int i = 0; i < 3; ++i) {
        p.eye[i] = float(eye[i]);
        p.forward[i] = float(f[i]);
        p.right[i] = float(r[i]);
        p.up[i] = float(u[i]);
    }
    const double aspect = double(width) / double(height);
    if (cam.projection == Projection::Orthographic) {
        p.halfY = float(cam.height / 2.0 / g.scale);
        p.halfX = float(cam.height / 2.0 * aspect / g.scale);
    } else {
        const double t = std::tan(cam.fovYDeg * 3.14159265358979323846 / 360.0);
        p.halfY = float(t);
        p.halfX = float(t * aspect);
    }
    p.perspective = cam.projection == Projection::Perspective ? 1u : 0u;
    p.worldScale = float(g.scale);
    p.earlyTermination = earlyTermination < 1.0 ? float(earlyTermination) : 2.0f;
    p.width = volcl_uint(width);
    p.height = volcl_uint(height);
    p.faceCount = volcl_uint(faceCount);
    p.pointCount = volcl_uint(g.points.size());
    p.tilesX = volcl_uint((width + kKBufferTile - 1) / kKBufferTile);
    p.tilesY = volcl_uint((height + kKBufferTile - 1) / kKBufferTile);
    p.tf = tf;
    p.tableScale = float(tf.tableSize - 1) / (tf.domainHi - tf.domainLo);
    p.lengthScale = float(tf.tableLengths) / tf.tableMaxLength;
    return p;
}

TableSpec kbufferTableSpec(const Scene& scene, double maxLength) {
    TableSpec s;
    s.size = scene.tableSize;
    s.axis = LengthAxis::Linear;
    s.lengths = scene.tableLengths;
    s.maxLength = maxLength;
    return s;
}

std::vector<cl_float4> kbufferBlockedTable(const PreintegrationTable& table) {
    const std::size_t n = std::size_t(table.size()), lengths = std::size_t(table.sliceCount()),
                      B = kKBufferTableBlock;
    const std::size_t nb = (n + B - 1) / B;
    std::vector<cl_float4> out(nb * nb * B * B * lengths, cl_float4{{0, 0, 0, 0}});
    for (std::size_t k = 0; k < lengths; ++k)
        for (std::size_t i = 0; i < n; ++i)
            for (std::size_t j = 0; j < n; ++j) {
                const float* v = table.rgba.data() + ((k * n + i) * n + j) * 4;
                const std::size_t at = (((i / B) * nb + j / B) * (B * B) + (i % B) * B + j % B) * lengths + k;
                out[at] = {{v[0], v[1], v[2], v[3]}};
            }
    return out;
}

VolclTfParams kbufferTfParams(const PreintegrationTable& table, std::size_t knotCount) {
    VolclTfParams p{};
    p.knotCount = volcl_uint(knotCount);
    p.tableSize = volcl_uint(table.size());
    p.tableLengths = volcl_uint(table.sliceCount());
    p.domainLo = float(table.domain[0]);
    p.domainHi = float(table.domain[1]);
    p.tableMaxLength = float(table.spec.maxLength);
    return p;
}

TileBinner::TileBinner(ComputeContext& cc) : cc_(cc) {
    KernelDefines defines;
    defines.set("KB_TILE", kKBufferTile).set("BIN_CHUNKS", cc.profile().mesh.binChunks);
    count_ = cc.kernel("mesh/mesh_kbuffer.cl", "kb_bin_count", defines);
    scatter_ = cc.kernel("mesh/mesh_kbuffer.cl", "kb_bin_scatter", defines);
    scan_ = cc.kernel("mesh/radix_sort.cl", "exclusive_scan");
    total_ = cc.allocate<cl_uint>(1);
    list_ = cc.allocate<cl_uint4>(1);
}

double TileBinner::bin(const DeviceBuffer<cl_uint4>& items, const DeviceBuffer<cl_uint2>& rects, cl_uint n,
                       cl_uint tilesX, std::size_t tiles) {
    const DeviceProfile::Mesh& tuning = cc_.profile().mesh;
    const std::size_t chunks = tuning.binChunks;
    if (counts_.size() != tiles * chunks) counts_ = cc_.allocate<cl_uint>(tiles * chunks);
    cc_.fill(counts_, cl_uint(0));
    setArgs(count_, rects, n, tilesX, counts_);
    double ms = eventMilliseconds(cc_.launch1d(count_, chunks, tuning.binLocal));
    setArgs(scan_, counts_, cl_uint(tiles * chunks), total_);
    ms += eventMilliseconds(cc_.launch1d(scan_, 1, 1));
    cl_uint entries = 0;
    cc_.read(total_, std::span<cl_uint>(&entries, 1));
    if (list_.size() < entries) list_ = cc_.allocate<cl_uint4>(std::size_t(entries) + entries / 4);
    entries_ = entries;
    setArgs(scatter_, items, rects, n, tilesX, counts_, list_);
    ms += eventMilliseconds(cc_.launch1d(scatter_, chunks, tuning.binLocal));
    return ms;
}

} // namespace volcl
