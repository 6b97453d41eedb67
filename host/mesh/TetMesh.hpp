// Tetrahedral mesh model: points, tets, point scalars, face adjacency, boundary faces and the repairs made.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace volcl::mesh {

using Point3 = std::array<double, 3>;
using Tet = std::array<std::uint32_t, 4>;

/// Face f of a tet is the triangle opposite vertex f. These local vertex orders wind counter-clockwise
/// seen from outside (normal pointing away from the tet) when the tet is positively oriented, i.e.
/// det(p1 - p0, p2 - p0, p3 - p0) > 0, which every tet of a built mesh is.
inline constexpr std::uint8_t kTetFaceVertices[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};

/// A tet face named as tet * 4 + face; kNoFace marks "no neighbour" (a boundary face).
using FaceId = std::uint32_t;
inline constexpr FaceId kNoFace = 0xFFFFFFFFu;
inline constexpr std::size_t kMaxTets = (std::size_t{1} << 30) - 1; ///< FaceId must hold tet * 4 + 3
inline constexpr FaceId faceId(std::size_t tet, unsigned face) noexcept {
    return static_cast<FaceId>(tet * 4 + face);
}
inline constexpr std::size_t faceTet(FaceId f) noexcept {
    return f >> 2;
}
inline constexpr unsigned faceLocal(FaceId f) noexcept {
    return f & 3u;
}

/// What reading and repairing a mesh did. Every count is reported by `volcl info`.
struct MeshRepairs {
    std::size_t inputPoints = 0;   ///< points in the file
    std::size_t inputCells = 0;    ///< cells in the file (hexahedra for a PLOT3D grid)
    std::size_t splitCells = 0;    ///< voxels, hexahedra, wedges and pyramids split into tets
    std::size_t quadraticTets = 0; ///< 10-node tets reduced to their 4 corners
    std::size_t blankedCells = 0;  ///< PLOT3D cells dropped because a corner has iblank 0
    std::size_t candidateTets = 0; ///< tets before the repairs below
    std::size_t mergedPoints = 0;  ///< points merged into an earlier point at exactly the same position
    std::size_t mergedScalarConflicts = 0; ///< merged groups whose scalars differed (they are averaged)
    double mergedScalarMaxDifference = 0;  ///< largest max - min of such a group
    std::size_t zeroVolumeTets = 0;   ///< dropped: a repeated vertex, or |volume| <= 1e-12 * (longest edge)^3
    std::size_t invertedTets = 0;     ///< negative volume: two vertices swapped so it is positive
    std::size_t nonManifoldFaces = 0; ///< triangles shared by more than two tets: each copy becomes boundary
    std::size_t overlappingFaces = 0; ///< triangles whose two tets lie on the same side: both become boundary
    std::size_t unusedPoints = 0;     ///< points no kept tet uses: removed
    bool leftHandedGrid = false;      ///< PLOT3D grid with negative i,j,k handedness: every cell re-ordered
    bool scalarFromCells = false;     ///< the scalar was cell data, averaged onto the points
};

/// An array the file holds (any number of components); the mesh's scalar is one of them.
struct MeshArrayInfo {
    std::string name;
    bool pointData = true; ///< false: cell data
    int components = 1;
    std::string type; ///< the file's type name, e.g. "Float32", "float", "int"
};

/// A conforming tetrahedral mesh with a linear scalar per tet (barycentric interpolation of its vertex
/// values). Built by buildTetMesh() (or a reader / generator that calls it), so these invariants hold:
/// every tet has four distinct vertices and positive volume; every point is used; no two points share
/// a position; neighbors[f] is the face on the other side of face f (and neighbors[neighbors[f]] == f),
/// or kNoFace for boundary faces, which boundaryFaces lists in increasing order; scalars are finite.
struct TetMesh {
    std::vector<Point3> points;    ///< world coordinates
    std::vector<Tet> tets;         ///< four point indices each, positively oriented
    std::vector<float> scalars;    ///< one per point
    std::vector<FaceId> neighbors; ///< 4 per tet, indexed by faceId(tet, face)
    std::vector<FaceId> boundaryFaces;
    Point3 boundsMin{0, 0, 0}, boundsMax{0, 0, 0};
    float valueMin = 0, valueMax = 0;
    double maxEdgeLength = 0; ///< longest tet edge (the natural length axis of a pre-integration table)
    std::string scalarName;
    std::vector<MeshArrayInfo> arrays; ///< every array of the source file
    std::string format;                ///< "VTK XML UnstructuredGrid", "legacy VTK", "PLOT3D", "generated"
    MeshRepairs repairs;

    std::size_t tetCount() const noexcept { return tets.size(); }
    std::size_t pointCount() const noexcept { return points.size(); }
    /// Unique internal triangles (each shared by two tets, counted once).
    std::size_t internalFaceCount() const noexcept { return (4 * tets.size() - boundaryFaces.size()) / 2; }
    /// Signed volume of tet t (positive in a built mesh).
    double volume(std::size_t t) const noexcept;
    double totalVolume() const noexcept;
    /// The three point indices of face f in outward winding.
    std::array<std::uint32_t, 3> faceVertices(FaceId f) const noexcept;
};

/// Tets as a reader produced them, before repairs: indices must already be < points.size().
struct TetSoup {
    std::vector<Point3> points;
    std::vector<float> scalars; ///< one per point
    std::vector<Tet> tets;
    MeshRepairs repairs; ///< counts of the reading stage (input sizes, splits, blanking)
};

/// Builds a mesh from a soup. The repairs, in this order:
/// 1. Non-finite coordinates or scalars are refused (DataError "<source>: point i: ...").
/// 2. Points at exactly the same position (compared as doubles; -0 equals +0) are merged into the one
///    with the lowest index; the merged point's scalar is the mean of the group.
/// 3. Tets with a repeated vertex after merging, or with |6 V| <= 1e-12 * L^3 (L its longest edge),
///    are dropped as zero-volume; tets with negative volume get vertices 1 and 2 swapped.
/// 4. Points no remaining tet uses are removed (indices are compacted in order).
/// 5. Face adjacency: triangles are matched by their vertex set. A triangle met by more than two tets
///    is non-manifold and every copy is left as a boundary face; a pair whose tets lie on the same side
///    (equal winding) overlaps and both copies are boundary faces.
/// Throws DataError when no tet survives or the mesh exceeds kMaxTets. Runs in O(n log n) for the point
/// merge and O(n) for the adjacency (faces bucketed by their smallest vertex).
TetMesh buildTetMesh(TetSoup soup, const std::string& source, const std::string& scalarName);

} // namespace volcl::mesh
