// Smooth vertex normals of a tetrahedral mesh: volume-weighted one-ring gradient means, and their linear field
// inside a tet.
#include "render/mesh/VertexNormals.hpp"

#include "render/mesh/MeshGeometry.hpp"

#include <cmath>

namespace volcl {

std::vector<Vec3> vertexNormals(const mesh::TetMesh& mesh) {
    std::vector<Vec3> sum(mesh.points.size(), Vec3{0, 0, 0});
    std::vector<double> weight(mesh.points.size(), 0.0);
    for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
        const auto& v = mesh.tets[t];
        bool finite = true;
        for (std::uint32_t p : v)
            finite = finite && std::isfinite(mesh.scalars[p]);
        if (!finite) continue;
        const mesh_detail::TetField f = mesh_detail::tetField(mesh, t);
        const Vec3 p0 = mesh.points[v[0]];
        const double volume = std::abs(dot(sub(mesh.points[v[1]], p0),
                                           cross(sub(mesh.points[v[2]], p0), sub(mesh.points[v[3]], p0)))) /
                              6.0;
        for (std::uint32_t p : v) {
            sum[p] = add(sum[p], scale(f.gradient, volume));
            weight[p] += volume;
        }
    }
    for (std::size_t i = 0; i < sum.size(); ++i)
        if (weight[i] > 0.0) sum[i] = scale(sum[i], 1.0 / weight[i]);
    return sum;
}

TetNormalField tetNormalField(const mesh::TetMesh& mesh, const std::vector<Vec3>& normals, std::size_t tet) {
    const auto& v = mesh.tets[tet];
    TetNormalField n;
    n.p0 = mesh.points[v[0]];
    for (int c = 0; c < 3; ++c) {
        const mesh_detail::TetField f = mesh_detail::tetFieldOf(
            mesh, tet, {normals[v[0]][c], normals[v[1]][c], normals[v[2]][c], normals[v[3]][c]});
        n.gradient[std::size_t(c)] = f.gradient;
        n.value[std::size_t(c)] = f.value;
    }
    return n;
}

} // namespace volcl
