// Convexification of a tetrahedral mesh for MPVO (after Guthe): auxiliary tets fill the space between the mesh and
// its convex hull, linked to the mesh's boundary faces, so that MPVO over the union sees every occlusion.
#pragma once

#include "host/mesh/TetMesh.hpp"
#include "render/mesh/VisibilityGraph.hpp"
#include "render/mesh/VisibilitySort.hpp"

namespace volcl {

/// The mesh's tets plus the auxiliary cells, as one graph for sortGraph(), and what building it did.
struct Convexification {
    VisibilityGraph graph;
    ConvexificationStats stats;
};

/// Builds the convexification. How:
/// 1. The Delaunay tetrahedralisation of all the mesh's points (Qhull, "d Qbb Qz Qt") covers their convex hull.
/// 2. Its tets are classified: the same four points as a mesh tet, or four points inside the mesh (no boundary
///    point): inside; flat (|6V| <= 1e-12 L^3): dropped; otherwise inside when the centroid is inside the mesh
///    (the nearest boundary face along a fixed ray is left through). The rest are the auxiliary cells: they fill
///    the concavities, holes, cavities and the gaps between disconnected or nested parts.
/// 3. Links: auxiliary cells with a common triangle, and an auxiliary cell with the mesh tet whose boundary face
///    is that triangle (exact links). Faces left over (the Delaunay picked the other diagonal of a boundary quad,
///    or a flat tet was dropped between two cells) are linked geometrically: two faces of different cells with a
///    common point, facing each other (unit normals' dot < -0.9) and overlapping with positive area in the
///    plane of the first are linked through that plane.
/// 4. Contacts: boundary faces of the mesh that lie in one plane (within 1e-7 of the diagonal), face each other
///    and overlap are linked (parts touching along a plane with different triangulations), found with the BVH.
/// When Qhull fails (points too close to one plane for a 3D Delaunay), there are no auxiliary cells and
/// stats.delaunayError says why: the convexified order is then plain MPVO with the contact links.
/// Where the boundary faces are not Delaunay faces, auxiliary cells may cross the mesh (Delaunay tets whose
/// centroid is outside while a corner pokes in) or leave a boundary face unmet (counted in openBoundaryFaces):
/// the order can then be wrong there, and crossings may show as cycles, which sortGraph() breaks.
Convexification convexify(const mesh::TetMesh& mesh);

} // namespace volcl
