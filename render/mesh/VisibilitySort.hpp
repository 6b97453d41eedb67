// Visibility orders of a tetrahedral mesh's cells for projected tetrahedra: centroid, MPVO and MPVO over the
// convexified mesh.
#pragma once

#include "host/mesh/TetMesh.hpp"
#include "render/VecMath.hpp"

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace volcl {

/// How render.method "pt" orders cells (scene key render.sort).
enum class MeshSort {
    Centroid,   ///< by distance of the centroid along the view: fast, wrong where cells overlap in depth
    Mpvo,       ///< Williams' MPVO on the face-adjacency graph: exact for convex acyclic meshes only
    Convexified ///< MPVO over the mesh plus the auxiliary cells filling its concavities (Guthe)
};
std::string_view meshSortName(MeshSort s);
MeshSort parseMeshSort(std::string_view s); ///< "centroid", "mpvo", "convexified"; throws UsageError

/// Whether the mesh is convex: every boundary face lies on the convex hull of the mesh (every point on its
/// inner side, within 1e-9 of the half diagonal). Holes, cavities, notches and disconnected parts make it false.
bool meshIsConvex(const mesh::TetMesh& mesh);
/// The default of render.sort: Mpvo for a convex mesh (exact there), Convexified otherwise.
MeshSort defaultMeshSort(const mesh::TetMesh& mesh);

/// What the convexification built (render/mesh/Convexify.hpp says how).
struct ConvexificationStats {
    std::size_t delaunayTets = 0;   ///< tets of the Delaunay tetrahedralisation of the mesh's points
    std::size_t auxiliaryCells = 0; ///< of them kept outside the mesh as auxiliary cells
    std::size_t exactLinks = 0;     ///< links through a triangle both cells have (same three points)
    std::size_t geometricLinks = 0; ///< links through overlapping near-coplanar faces (different diagonals)
    std::size_t contactLinks = 0;   ///< links between boundary faces of the mesh that touch in one plane
    std::size_t openBoundaryFaces = 0; ///< mesh boundary faces off the hull that no auxiliary cell meets
    std::string delaunayError;         ///< why Qhull failed (then there are no auxiliary cells), else empty
    double seconds = 0.0;              ///< time the build took
};

/// The viewpoint a visibility order is for: a perspective eye point, or an orthographic view direction.
struct SortView {
    Vec3 eye{0, 0, 0};       ///< perspective: the eye in world coordinates
    Vec3 direction{0, 0, 1}; ///< orthographic: the viewing direction (unit, from the eye into the scene)
    bool perspective = false;
};

/// A back-to-front order of the mesh's real tets (auxiliary cells are sorted but not listed).
struct VisibilityOrder {
    std::vector<std::uint32_t> tets; ///< every tet of the mesh exactly once, farthest first
    std::size_t cyclesBroken = 0;    ///< visibility cycles broken while sorting (0: the order is exact)
    double seconds = 0.0;            ///< time the sort took
};

/// Sorts the mesh's tets back to front for `view`. Centroid and Mpvo work on any mesh; Convexified uses the
/// mesh's convexification (built on first use and cached with the sorter).
class VisibilitySorter {
public:
    explicit VisibilitySorter(const mesh::TetMesh& mesh);
    ~VisibilitySorter();
    VisibilitySorter(const VisibilitySorter&) = delete;
    VisibilitySorter& operator=(const VisibilitySorter&) = delete;

    VisibilityOrder sort(const SortView& view, MeshSort method);
    /// The convexification (built now if no Convexified sort has built it yet).
    const ConvexificationStats& convexification();

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

} // namespace volcl
