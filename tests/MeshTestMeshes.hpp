// Test meshes shared by the mesh suites: jittered hex grids with cells removed (concave walls, folds), and the
// removed-cell shapes of the non-convex ones (a U, a tunnel, a block nested in a shell).
#pragma once

#include "host/mesh/MeshGenerator.hpp"
#include "host/mesh/TetMesh.hpp"
#include "render/VecMath.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>

namespace volcl::test {

/// Position within [-1, 1) from an integer: a fixed jitter that needs no random engine state.
inline double hashUnit(std::uint64_t i, std::uint64_t salt) {
    std::uint64_t x = i * 0x9E3779B97F4A7C15ull + salt * 0xBF58476D1CE4E5B9ull;
    x ^= x >> 31;
    x *= 0x94D049BB133111EBull;
    x ^= x >> 29;
    return double(x >> 11) / double(1ull << 52) - 1.0;
}

/// The tets of an nx x ny x nz hex grid on the box [lo, hi] whose cells' centres `removed` does not name, every
/// point moved by up to `jitter` cell widths per axis (points on the box's faces stay in them unless
/// `jitterSurface`), so the walls the removed cells leave are bumpy and concave; `seed` picks the jitter. From
/// about 0.3 cell widths some tets fold over (the mesh builder turns them and leaves their overlapping faces as
/// boundary faces), from 0.4 tens of them. The points' scalars sample sin(3x + 1) cos(2y) + z, or with
/// `linearField` a linear field that every tet interpolates exactly, so that where tets overlap all of them
/// hold the same value and the oracle's choice of tet does not matter.
inline mesh::TetSoup jitteredSoup(std::array<std::size_t, 3> n, Vec3 lo, Vec3 hi, double jitter,
                                  bool jitterSurface,
                                  const std::function<bool(double, double, double)>& removed,
                                  std::uint64_t seed = 0, bool linearField = false) {
    auto field = [linearField](double x, double y, double z) {
        return linearField ? 0.8 * x - 0.5 * y + z : std::sin(3.0 * x + 1.0) * std::cos(2.0 * y) + z;
    };
    const mesh::TetMesh full =
        mesh::generateHexGridMesh(n, {lo[0], lo[1], lo[2]}, {hi[0], hi[1], hi[2]}, field);
    double h[3];
    for (int a = 0; a < 3; ++a)
        h[a] = (hi[a] - lo[a]) / double(n[a]);
    mesh::TetSoup soup;
    for (const auto& t : full.tets) {
        // The tet's hex cell: the cell containing its centroid (the centroid is strictly inside the cell).
        double c[3] = {0, 0, 0};
        for (auto v : t)
            for (int a = 0; a < 3; ++a)
                c[a] += 0.25 * full.points[v][a];
        double cell[3];
        for (int a = 0; a < 3; ++a)
            cell[a] = lo[a] + (std::floor((c[a] - lo[a]) / h[a]) + 0.5) * h[a];
        if (!removed(cell[0], cell[1], cell[2])) soup.tets.push_back(t);
    }
    soup.points = full.points;
    for (std::size_t i = 0; i < soup.points.size(); ++i)
        for (int a = 0; a < 3; ++a) {
            double& p = soup.points[i][a];
            if ((p > lo[a] && p < hi[a]) || jitterSurface)
                p += jitter * h[a] * hashUnit(i, std::uint64_t(a) + 1 + 16 * seed);
        }
    for (const auto& p : soup.points)
        soup.scalars.push_back(float(field(p[0], p[1], p[2])));
    return soup;
}

/// n^3 cells of jitteredSoup on the unit cube, built into a mesh.
inline mesh::TetMesh jitteredMesh(std::size_t n, double jitter, bool jitterSurface,
                                  const std::function<bool(double, double, double)>& removed,
                                  bool linearField = false) {
    return mesh::buildTetMesh(
        jitteredSoup({n, n, n}, {0, 0, 0}, {1, 1, 1}, jitter, jitterSurface, removed, 0, linearField),
        "jittered", "f");
}

/// The unit cube's n^3 grid, points inside jittered by 0.2 cells (its faces stay flat), minus `removed` cells.
inline mesh::TetMesh cubeMesh(std::size_t n, const std::function<bool(double, double, double)>& removed) {
    return jitteredMesh(n, 0.2, false, removed);
}

// Removed cells of the non-convex unit-cube meshes (cell centres in, true: the cell is left out).

/// A U: the notch 0.33 < x < 0.67, y > 0.3 runs through z; views along x look through one prong, the notch, then
/// the other prong.
inline bool uNotch(double x, double y, double) {
    return x > 0.33 && x < 0.67 && y > 0.3;
}
/// A square tunnel through the cube along z.
inline bool tunnelAlongZ(double x, double y, double) {
    return x > 0.3 && x < 0.7 && y > 0.3 && y < 0.7;
}
/// A hollow shell with a block floating inside it (a gap all round).
inline bool nestedBlockGap(double x, double y, double z) {
    const double m = std::max({std::abs(x - 0.5), std::abs(y - 0.5), std::abs(z - 0.5)});
    return m > 0.15 && m < 0.35;
}

} // namespace volcl::test
