// The cell-adjacency graph MPVO sorts: cells (a mesh's tets, then auxiliary cells) linked through shared planes,
// and the topological sort (Kahn) that turns a viewpoint into a back-to-front order, breaking cycles.
#pragma once

#include "host/mesh/TetMesh.hpp"
#include "render/VecMath.hpp"

#include <cstddef>
#include <cstdint>
#include <vector>

namespace volcl {

struct SortView;

/// Cells [0, realCells) are the mesh's tets (listed in the order), cells from realCells on are auxiliary (sorted
/// with the others, never listed). Two cells that touch over a piece of plane are linked through that plane:
/// a ray that crosses it from the negative side to the positive side (of `normal`) leaves the cell on the
/// negative side for the one on the positive side, so that one is behind. Adjacency is stored per cell (CSR):
/// entries [first[c], first[c + 1]) name the other cell and the plane, with the low bit of `plane` set when
/// the plane's normal points towards this cell rather than away from it.
struct VisibilityGraph {
    std::size_t realCells = 0;
    std::vector<std::uint32_t> first; ///< cellCount() + 1 offsets into other/plane
    std::vector<std::uint32_t> other;
    std::vector<std::uint32_t> plane; ///< plane index * 2 + (1: the normal points into this cell)
    std::vector<Vec3> normals;        ///< per plane (not unit)
    std::vector<double> offsets;      ///< per plane: dot(normal, a point of the plane)
    std::vector<Vec3> centroids;      ///< per cell: where a broken cycle's farthest cell is judged from

    std::size_t cellCount() const noexcept { return centroids.size(); }
};

/// One link of a graph under construction: the cells on the negative and the positive side of plane `plane`.
struct GraphLink {
    std::uint32_t negative = 0, positive = 0;
    std::uint32_t plane = 0;
};

/// Adds a plane through `point` with `normal` and returns its index.
std::uint32_t addPlane(VisibilityGraph& g, const Vec3& normal, const Vec3& point);
/// Adds the mesh's tets as cells (they must come first) and a link through every internal face.
void addMeshCells(VisibilityGraph& g, const mesh::TetMesh& mesh, std::vector<GraphLink>& links);
/// Builds the CSR adjacency from `links` (each link is listed from both of its cells).
void buildAdjacency(VisibilityGraph& g, const std::vector<GraphLink>& links);

/// The mesh's tets as cells, linked through every internal face (Williams' MPVO graph).
VisibilityGraph meshAdjacencyGraph(const mesh::TetMesh& mesh);

/// A back-to-front order of the graph's real cells for `view`. Kahn's algorithm: a cell is ready when every
/// cell behind it (across a plane the view looks through from its side) is out; ready cells leave in FIFO
/// order. When none is ready but cells remain, a cycle is found by walking from a remaining cell to a remaining
/// cell behind it until one repeats; an auxiliary cell on it is deleted (Guthe), else the cycle's real cell
/// with the farthest centroid goes out first. Each such step counts in `cyclesBroken`.
struct GraphOrder {
    std::vector<std::uint32_t> tets;
    std::size_t cyclesBroken = 0;
    std::size_t auxDeleted = 0; ///< auxiliary cells deleted to break cycles
};
GraphOrder sortGraph(const VisibilityGraph& g, const SortView& view);

} // namespace volcl
