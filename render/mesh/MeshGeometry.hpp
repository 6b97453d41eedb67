// What every ray traversal of a tetrahedral mesh shares: the linear field per tet, the face planes that give
// exit distances, and a bounding-volume hierarchy of the boundary faces that finds where a ray (re-)enters.
#pragma once

#include "host/mesh/TetMesh.hpp"
#include "render/VecMath.hpp"

#include <array>
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
/// The same for any values at the tet's four vertices (in the order of m.tets[tet]), e.g. one component of
/// the vertex normals.
TetField tetFieldOf(const mesh::TetMesh& m, std::size_t tet, const std::array<double, 4>& values);

/// Outward normal (not unit: twice the face area) and one vertex of face f of tet t: the ray o + t d leaves
/// through the face's plane at t = dot(n, a - o) / dot(n, d) when dot(n, d) > 0.
struct FacePlane {
    Vec3 normal{0, 0, 0}, vertex{0, 0, 0};
};
FacePlane facePlane(const mesh::TetMesh& m, mesh::FaceId f);

/// A tet in the frame x' = (x - centre) / scale: its four face planes (unit outward normal n and offset w, the
/// plane being n.x' + w = 0, the inside n.x' + w < 0) and its field s(x') = gradient.x' + value. Each shared
/// face's plane is computed from the side with the lower face id and negated on the other, so both tets agree
/// exactly on where a ray crosses it. `finite` is false for a NaN cell (a non-finite vertex value), whose field
/// is then NaN.
struct NormalisedTet {
    std::array<Vec3, 4> normal{};
    std::array<double, 4> offset{};
    Vec3 gradient{0, 0, 0};
    double value = 0.0;
    bool finite = true;
};
NormalisedTet normalisedTet(const mesh::TetMesh& m, std::size_t tet, const Vec3& centre, double scale);

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

/// Where a ray enters the mesh: an entering boundary face (its outward normal against the ray) and the ray
/// parameter of the hit.
struct EntryHit {
    mesh::FaceId face = mesh::kNoFace;
    double t = 0.0;
};
/// The nearest entering boundary face hit at t >= tMin, skipping the faces in `exclude` (the recent entries
/// of this ray, so a ray through a boundary edge enters each side once). Hits count up to `tolerance` in
/// barycentric coordinates outside a triangle, so a ray through a shared edge or vertex hits at least one.
std::optional<EntryHit> firstEntry(const mesh::TetMesh& m, const BoundaryBvh& bvh, const Vec3& o,
                                   const Vec3& d, double tMin, const std::vector<mesh::FaceId>& exclude,
                                   double tolerance = 1e-12);

/// Whether p is inside the mesh: the nearest boundary face along a fixed ray from p is left through (points on
/// the boundary go either way).
bool pointInsideMesh(const mesh::TetMesh& m, const BoundaryBvh& bvh, const Vec3& p);

/// Whether tets of the mesh may overlap, so that a ray can be inside two of them at once: the builder found
/// overlapping or non-manifold face pairs (folded tets), or two face-connected components have bounding boxes
/// that overlap (pieces that interpenetrate or nest without sharing a face). False promises that every point is
/// in at most one tet, up to a single connected component that passes through itself without a shared face,
/// which no cheap test sees.
bool mayOverlap(const mesh::TetMesh& m);

/// Per tet: 1 when its interior overlaps another tet's (a separating-axis test on every pair of tets with
/// overlapping boxes; overlaps thinner than 1e-9 of the mesh's diagonal do not count). Only these tets' boundary
/// faces can be entered inside a part of a ray that other tets cover. The search is bounded: past
/// kOverlapWorkPerTet units per tet (at least 2^20 in all; a tree node or a tet pair's boxes is one unit, a
/// separating-axis test kOverlapTestWork), as when tets span much of the mesh, every tet is 1.
std::vector<std::uint8_t> overlappingTets(const mesh::TetMesh& m);
inline constexpr std::size_t kOverlapWorkPerTet = 1024;
inline constexpr std::size_t kOverlapTestWork = 16;

} // namespace volcl::mesh_detail
