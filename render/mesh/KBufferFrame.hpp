// What one k-buffer frame is computed from, shared by the OpenCL renderer and its C++ mirror: normalized mesh
// points, the frame's kernel parameters and the pre-integration table's shape.
#pragma once

#include "cl/mesh/mesh_kbuffer_shared.h"
#include "core/runtime/ClRuntime.hpp"
#include "host/mesh/TetMesh.hpp"
#include "preintegration/PreintegrationTable.hpp"
#include "render/Scene.hpp"
#include "render/mesh/MeshFaces.hpp"

#include <cstddef>
#include <vector>

namespace volcl {

inline constexpr int kKBufferMinK = 2, kKBufferMaxK = 8, kKBufferDefaultK = 6;
inline constexpr int kKBufferTile = 16; ///< tile edge in pixels (one work-group per tile)

/// The mesh in normalized coordinates, (p - centre) / scale, as float: huge and tiny meshes rasterise with the
/// same float precision. `scale` is half the box diagonal (1 for a single point).
struct KBufferGeometry {
    Vec3 centre{0, 0, 0};
    double scale = 1.0;
    std::vector<cl_float4> points; ///< the mesh's points, then the faces' extra points
    std::vector<float> scalars;    ///< one per point
};
KBufferGeometry kbufferGeometry(const mesh::TetMesh& mesh, const MeshFaces& faces);

/// Per point of `g` (the mesh's, then the faces' extra points): the smooth vertex normal (vertexNormals: the
/// one-ring's volume-weighted mean gradient) in normalized units (world gradient times g.scale), an extra point
/// taking the mean of its edge's two ends (linear along the face, as the scalar). What mode iso lights with.
std::vector<cl_float4> kbufferPointNormals(const mesh::TetMesh& mesh, const MeshFaces& faces,
                                           const KBufferGeometry& g);

/// Kernel parameters of a frame: camera in normalized coordinates, image and tile counts, the faces drawn,
/// early termination (values >= 1 disable it) and the table geometry `tf`.
VolclKBufferParams kbufferParams(const KBufferGeometry& g, const Camera& camera, int width, int height,
                                 double earlyTermination, std::size_t faceCount, const VolclTfParams& tf);

/// The 3D pre-integration table of a k-buffer frame: scene.tableSize nodes, scene.tableLengths linear
/// lengths up to `maxLength` (the longest edge at full quality: no segment inside a tet is longer; the box
/// diagonal while the level of detail drops faces).
TableSpec kbufferTableSpec(const Scene& scene, double maxLength);
/// Edge of the front x back node blocks of the device table (KB_TBLOCK in cl/mesh/mesh_kbuffer.cl).
inline constexpr unsigned kKBufferTableBlock = 4;
/// The table as kb_raster reads it: kKBufferTableBlock^2 node blocks (front-major), inside a block front-major
/// nodes, each node's length slices contiguous; blocks past the last node are zero. The eight values of a
/// lookup share one block (one page, not four) and its two lengths one cache line. Same values as `table`.
std::vector<cl_float4> kbufferBlockedTable(const PreintegrationTable& table);
/// Table geometry as the kernels read it.
VolclTfParams kbufferTfParams(const PreintegrationTable& table, std::size_t knotCount);

/// The order-keeping tile binning of the k-buffer (kb_bin_count, exclusive_scan, kb_bin_scatter), shared with
/// projected tetrahedra: n items, each with the rectangle of kKBufferTile-pixel tiles it touches (x0 | y0 << 16,
/// x1 | y1 << 16; empty when x0 > x1), appended to every tile list they touch in their order. ends() then holds,
/// at tile * BIN_CHUNKS + BIN_CHUNKS - 1, the end of the tile's list in list() (the previous tile's end its start).
class TileBinner {
public:
    explicit TileBinner(ComputeContext& cc);
    /// Bins items[0, n) by rects[0, n) over tilesX x (tiles / tilesX) tiles; returns the kernels' milliseconds.
    double bin(const DeviceBuffer<cl_uint4>& items, const DeviceBuffer<cl_uint2>& rects, cl_uint n,
               cl_uint tilesX, std::size_t tiles);
    const DeviceBuffer<cl_uint>& ends() const noexcept { return counts_; }
    const DeviceBuffer<cl_uint4>& list() const noexcept { return list_; }
    /// Entries of the last binning (items times the tiles each touches).
    std::size_t entries() const noexcept { return entries_; }

private:
    ComputeContext& cc_;
    cl::Kernel count_, scan_, scatter_;
    DeviceBuffer<cl_uint> counts_, total_;
    DeviceBuffer<cl_uint4> list_;
    std::size_t entries_ = 0;
};

} // namespace volcl
