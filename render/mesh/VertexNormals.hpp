// Smooth normals of a tetrahedral mesh's field: one gradient per point, interpolated barycentrically inside each
// tet (Guthe 3.2.3's smooth lit tetrahedra) instead of each tet's own constant gradient.
#pragma once

#include "host/mesh/TetMesh.hpp"
#include "render/VecMath.hpp"

#include <array>
#include <vector>

namespace volcl {

/// Per mesh point: the volume-weighted mean of the gradients of the tets that use the point (its one-ring; the
/// 3D counterpart of area-weighted vertex normals), not normalised. Shading normalises after interpolating, so
/// the length still tells a flat region (below the renderer's gradient threshold) from a surface. Tets with a
/// non-finite vertex value add nothing; a point with no finite tet gets the zero vector. O(tets). Example:
/// ```
/// std::vector<volcl::Vec3> g = volcl::vertexNormals(mesh);   // g[i]: smoothed gradient at mesh.points[i]
/// ```
std::vector<Vec3> vertexNormals(const mesh::TetMesh& mesh);

/// The normal field of tet `tet` as three linear functions, one per component: component c at x is
/// dot(rows[c].gradient, x - rows[c].p0) + rows[c].value, the barycentric interpolation of the tet's four
/// vertex normals (exact on its faces, so the two tets of a face agree there).
struct TetNormalField {
    std::array<Vec3, 3> gradient{};
    std::array<double, 3> value{};
    Vec3 p0{0, 0, 0};
    Vec3 at(const Vec3& x) const {
        const Vec3 r = sub(x, p0);
        return {value[0] + dot(gradient[0], r), value[1] + dot(gradient[1], r),
                value[2] + dot(gradient[2], r)};
    }
};
TetNormalField tetNormalField(const mesh::TetMesh& mesh, const std::vector<Vec3>& normals, std::size_t tet);

} // namespace volcl
