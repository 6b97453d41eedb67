// The k-buffer's face order from an exact visibility order of the cells (render.sort "mpvo" / "convexified"):
// each face placed with the nearer of its two tets, so fragments reach the k-buffer in ray order wherever the
// cell order is right.
#pragma once

#include "host/mesh/TetMesh.hpp"
#include "render/mesh/MeshFaces.hpp"
#include "render/mesh/VisibilitySort.hpp"

#include <cstddef>
#include <cstdint>
#include <vector>

namespace volcl {

/// The k-buffer's face order when render.sort is unset: the exact cell order of projected tetrahedra
/// (defaultMeshSort: "mpvo" for a convex mesh, else "convexified"), unless the tets may overlap (folds,
/// interpenetrating parts: mayOverlap), where no visibility order of the cells exists and the centroid sort,
/// finished per pixel by the k-buffer, is kept (docs/meshes.md has the measurements behind the choice).
MeshSort defaultKBufferSort(const mesh::TetMesh& mesh);

/// One frame's face order and what it cost.
struct KBufferFaceOrder {
    std::vector<std::uint32_t> faces; ///< indices into MeshFaces::faces, nearest first
    std::size_t cyclesBroken = 0;     ///< the cell sort's (0: exact wherever the mesh is acyclic)
    double cellSortMs = 0.0;          ///< VisibilitySorter::sort
    double faceOrderMs = 0.0;         ///< placing the faces by the cell order
};

/// Orders the faces of a MeshFaces for the k-buffer by a visibility order of the mesh's cells. The cells come
/// back to front from VisibilitySorter; walked front to back, each tet emits its faces that face the eye
/// (it is entered through them) before those facing away, each face only at the first of its two tets (the
/// nearer one in an exact order), the pieces of a cut face together. Along any ray through the mesh the
/// faces it crosses then come in the order the ray crosses them wherever the cell order is right: the entry
/// face of a tet is emitted with (or before) it, its exit face is the entry face of the next tet the ray
/// meets, which the order puts later. A subset of the faces (a level-of-detail prefix) keeps this order as a
/// subsequence. The mesh, the faces and the cell sorter (which keeps the graphs and the convexification, so
/// they outlive a rebuild of the faces) must outlive the face sorter. Example:
/// ```
/// volcl::VisibilitySorter cells(mesh);
/// volcl::KBufferFaceSorter s(mesh, faces, cells);
/// volcl::KBufferFaceOrder o = s.order(sortViewOf(camera), volcl::MeshSort::Mpvo, faces.faces.size());
/// ```
class KBufferFaceSorter {
public:
    KBufferFaceSorter(const mesh::TetMesh& mesh, const MeshFaces& faces, VisibilitySorter& cells);

    /// The faces [0, drawn) of the MeshFaces, nearest first, for `view` by the cell order of `method`
    /// (Mpvo or Convexified; Centroid gives the centroid order of the cells, placed alike).
    KBufferFaceOrder order(const SortView& view, MeshSort method, std::size_t drawn);

    /// The faces [0, drawn) placed by a given back-to-front order of all the mesh's tets.
    std::vector<std::uint32_t> placeFaces(const std::vector<std::uint32_t>& cellsBackToFront,
                                          const SortView& view, std::size_t drawn) const;

private:
    const mesh::TetMesh& mesh_;
    VisibilitySorter& cells_;
    /// Per tet face (tet * 4 + face): the run [begin, end) of MeshFaces::faces lying on it (both copies of an
    /// internal triangle name the same run; a cut face's pieces are adjacent).
    std::vector<std::uint32_t> begin_, end_;
};

} // namespace volcl
