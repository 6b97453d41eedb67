// What every ray traversal of a tetrahedral mesh shares: the linear field per tet, the face planes that give
// exit distances, and a bounding-volume hierarchy of the boundary faces that finds where a ray (re-)enters.
#pragma once

#include "host/mesh/TetMesh.hpp"
#include "render/VecMath.hpp"

#include <cstdint>
#include <optional>
#include <vector>

namespace volcl::mesh_detail {

/// The tet's scalar as s(x) = value + dot(gradient, x - p0) with p0 its vertex 0 (exact barycentric
/// interpolation of its four vertex values; the gradient is constant in the tet).
struct TetField {
    Vec3 p0{0, 0, 0}, gradient{0, 0, 0};
    double value = 0.0;
    double at(const Vec3& x) const { return value + dot(gradient, sub(x, p0)); }
};
TetField tetField(const mesh::TetMesh& m, std::size_t tet);

/// Outward normal (not unit: twice the face area) and one vertex of face f of tet t: the ray o + t d leaves
/// through the face's plane at t = dot(n, a - o) / dot(n, d) when dot(n, d) > 0.
struct FacePlane {
    Vec3 normal{0, 0, 0}, vertex{0, 0, 0};
};
FacePlane facePlane(const mesh::TetMesh& m, mesh::FaceId f);

/// A BVH over the boundary faces (median split on the longest axis of the centroids, at most 4 faces per
/// leaf). Nodes are in depth-first order: a node's left child follows it, `right` names the right child;
/// a leaf has count > 0 and holds faces[first, first + count).
struct BvhNode {
    Vec3 lo{0, 0, 0}, hi{0, 0, 0};
    std::uint32_t first = 0, count = 0; ///< leaf: face range; inner: count 0
    std::uint32_t right = 0;            ///< inner: index of the right child
};
struct BoundaryBvh {
    std::vector<BvhNode> nodes;
    std::vector<mesh::FaceId> faces; ///< the boundary faces in leaf order
};
BoundaryBvh buildBoundaryBvh(const mesh::TetMesh& m);

/// Per face of bvh.faces (leaf order): 1 when the face lies on the mesh's convex hull, i.e. every mesh point is
/// on its inner side (within 1e-9 of the mesh's half diagonal). A ray that leaves the mesh through such a face
/// moves away from its plane and cannot enter again, so no search for a re-entry is needed. The points tested
/// are the boundary faces' vertices (a linear function's maximum over the mesh is at one of them), pruned with
/// the BVH's boxes.
std::vector<std::uint8_t> hullFaces(const mesh::TetMesh& m, const BoundaryBvh& bvh);

/// Where a ray meets the boundary: the face, the ray parameter of the hit, and whether the ray enters the
/// mesh there (the face's outward normal against the ray) or leaves it.
struct EntryHit {
    mesh::FaceId face = mesh::kNoFace;
    double t = 0.0;
    bool entering = true;
};
/// The nearest boundary face hit by the ray: an entering face at t >= tMin or a leaving face at t > tExitMin,
/// skipping the faces in `exclude` (the recent entries of this ray, so a ray through a boundary edge enters
/// each side once). Hits count up to `tolerance` in barycentric coordinates outside a triangle, so a ray
/// through a shared edge or vertex hits at least one. A leaving face found first means the ray is already
/// inside the mesh before it (a camera inside the mesh, or tets overlapping past a boundary face).
std::optional<EntryHit> firstEntry(const mesh::TetMesh& m, const BoundaryBvh& bvh, const Vec3& o,
                                   const Vec3& d, double tMin, double tExitMin,
                                   const std::vector<mesh::FaceId>& exclude, double tolerance = 1e-12);

/// Where a ray that is inside the mesh at tMin stands: walking back (against d) from the leaving boundary face
/// `exitFace`, hit at tExit, through face-adjacent tets. Returns the tet holding the point at tMin with
/// `entered` 4 (none) and t = tMin, or, when the walk back leaves the mesh at t > tMin (the ray was outside
/// there after all), the tet and face it enters by at that t. At most `stepLimit` tets are crossed.
struct WalkStart {
    std::size_t tet = 0;
    unsigned entered = 4;
    double t = 0.0;
};
WalkStart locateBack(const mesh::TetMesh& m, const Vec3& o, const Vec3& d, mesh::FaceId exitFace,
                     double tExit, double tMin, std::size_t stepLimit);

} // namespace volcl::mesh_detail
