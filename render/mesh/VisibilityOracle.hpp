// A ray oracle for visibility orders that shares nothing with MPVO: every tet is clipped with each ray, and tets
// a ray crosses one after the other must come back to front in the order.
#pragma once

#include "host/mesh/TetMesh.hpp"
#include "render/VecMath.hpp"
#include "render/mesh/VisibilitySort.hpp"

#include <cstddef>
#include <cstdint>
#include <vector>

namespace volcl {

/// The ray interval [t0, t1] inside tet `t` (closed half-spaces of its four face planes, each oriented toward
/// the opposite vertex), empty when t1 <= t0; independent of the mesh's adjacency and face planes.
bool tetRayInterval(const mesh::TetMesh& m, std::size_t t, const Vec3& o, const Vec3& d, double& t0,
                    double& t1);

/// What the oracle counted: pairs of tets one ray crosses one after the other (the first interval ends where or
/// before the second starts, within 1e-9 of the half diagonal), and those the order puts the wrong way round.
struct OrderCheck {
    std::size_t rays = 0, pairs = 0, violations = 0;
};

/// Rays of the view: orthographic, a raysPerAxis^2 grid across the mesh's bounding sphere along the direction;
/// perspective, raysPerAxis^2 directions spread over the whole sphere from the eye (only t >= 0 counts). Costs
/// raysPerAxis^2 x tets clips. `order` must be a permutation of the tets.
OrderCheck checkOrderAlongRays(const mesh::TetMesh& m, const std::vector<std::uint32_t>& order,
                               const SortView& view, int raysPerAxis);

} // namespace volcl
