// The unique triangles of a tetrahedral mesh for face-based rendering (k-buffer): boundary faces first, then
// every internal face once, in the importance order of the level of detail.
#pragma once

#include "host/mesh/TetMesh.hpp"

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace volcl {

/// One triangle: three point indices (boundary faces in outward winding), whether it is on the boundary, and the
/// tet face it lies on (for an internal triangle the lower-numbered of its two copies; the pieces of a cut face
/// keep their face's), which a visibility order of the cells places it by.
struct MeshFace {
    std::array<std::uint32_t, 3> v;
    bool boundary = false;
    mesh::FaceId source = mesh::kNoFace;
};

/// The faces of a mesh as the k-buffer draws them: faces[0, boundaryCount) are the boundary faces (every one
/// is always drawn), the rest are the internal faces, each once (a shared triangle's two tet faces give one
/// face), ordered from most to least important for the dynamic level of detail: Callahan's area sampling,
/// priority = area * xi with xi uniform in [0, 1) from a fixed seed, so larger faces tend to come first
/// while small ones keep a chance (uniform subsets clump and leave holes). The ranking is cut into 64 equal
/// levels, each kept in mesh order (memory locality of the per-frame passes). A frame at level of detail q
/// draws the prefix of boundaryCount + round(q * internalCount) faces. Example:
/// ```
/// volcl::MeshFaces f = volcl::buildMeshFaces(mesh);
/// std::size_t drawn = f.prefixForFraction(0.25);   // boundary + the 25 % most important internal faces
/// ```
struct MeshFaces {
    std::vector<MeshFace> faces;
    std::size_t boundaryCount = 0;
    /// Points added by splitLongFaces (indices from the mesh's point count on) and their scalars.
    std::vector<mesh::Point3> extraPoints;
    std::vector<float> extraScalars;
    /// The edge each extra point is the midpoint of (point indices; an earlier extra point may be one), so
    /// per-point attributes linear on the faces (vertex normals) follow the cut: the mean of the two.
    std::vector<std::array<std::uint32_t, 2>> extraParents;
    std::size_t internalCount() const noexcept { return faces.size() - boundaryCount; }
    /// Faces drawn at internal-face fraction q (clamped to [0, 1]).
    std::size_t prefixForFraction(double q) const noexcept;
};

/// Builds the unique faces (about 2 per tet). `seed` drives the random part of the importance order.
MeshFaces buildMeshFaces(const mesh::TetMesh& mesh, std::uint64_t seed = 0x5eed5eedULL);

/// Long faces break the centroid order: a sliver's centroid can lie far from where a ray crosses it, so its
/// fragment arrives more than k places late (the O-grid around the LOx post: 9 % of the pixels at k = 8).
/// Faces whose longest edge exceeds `ratio` times the median longest edge are cut into 4 by their edge
/// midpoints, up to 3 times (64 pieces; a face twice the threshold is cut twice, ...), every long face once
/// before any twice, longest first, adding at most `budget` times the face count. The
/// pieces cover the face exactly (same plane, the linear scalar at the midpoints), keep its winding and its
/// place in the order; a midpoint is shared by every face split along that edge. Returns the faces added.
std::size_t splitLongFaces(MeshFaces& faces, const mesh::TetMesh& mesh, double ratio = 4.0,
                           double budget = 1.0);

} // namespace volcl
