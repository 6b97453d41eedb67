// Generated tetrahedral meshes: structured hex grids split into tets, with analytic scalars (benchmarks,
// tests).
#pragma once

#include "host/mesh/TetMesh.hpp"

#include <functional>

namespace volcl::mesh {

/// A box [lo, hi] cut into cells[0] x cells[1] x cells[2] hexahedra, each split into 6 tets by the
/// conforming rule of splitCell, with point scalar f(x, y, z). 6 * cells tets, (cells + 1) points.
/// Example: `TetMesh m = generateHexGridMesh({8, 8, 8}, {0, 0, 0}, {1, 1, 1}, [](double x, double, double) {
/// return x; });`
TetMesh generateHexGridMesh(std::array<std::size_t, 3> cells, Point3 lo, Point3 hi,
                            const std::function<double(double, double, double)>& f);

/// Marschner & Lobb's test signal on [-1, 1]^3 over n^3 hexahedra: 6 n^3 tets (n = 64: 1,572,864 tets,
/// 274,625 points), the standard >= 1 M tet benchmark mesh.
TetMesh marschnerLobbMesh(std::size_t n = 64);

} // namespace volcl::mesh
