// Generated meshes: hex grids over a box split into conforming tets, Marschner-Lobb on [-1,1]^3.
#include "host/mesh/MeshGenerator.hpp"

#include "core/Error.hpp"
#include "host/mesh/CellSplit.hpp"
#include "host/phantoms/Phantoms.hpp"

namespace volcl::mesh {

TetMesh generateHexGridMesh(std::array<std::size_t, 3> cells, Point3 lo, Point3 hi,
                            const std::function<double(double, double, double)>& f) {
    for (int a = 0; a < 3; ++a)
        if (cells[a] < 1 || cells[a] > 4096 || !(hi[a] > lo[a]))
            throw UsageError("generateHexGridMesh: each axis needs 1..4096 cells and hi > lo");
    const std::size_t ni = cells[0] + 1, nj = cells[1] + 1, nk = cells[2] + 1;
    if (6 * cells[0] * cells[1] * cells[2] > kMaxTets) throw UsageError("generateHexGridMesh: too many tets");
    TetSoup soup;
    soup.points.resize(ni * nj * nk);
    soup.scalars.resize(soup.points.size());
    auto coord = [&](int a, std::size_t i, std::size_t n) {
        return i + 1 == n ? hi[a] : lo[a] + (hi[a] - lo[a]) * double(i) / double(n - 1);
    };
    for (std::size_t k = 0; k < nk; ++k)
        for (std::size_t j = 0; j < nj; ++j)
            for (std::size_t i = 0; i < ni; ++i) {
                const std::size_t id = i + ni * (j + nj * k);
                soup.points[id] = {coord(0, i, ni), coord(1, j, nj), coord(2, k, nk)};
                soup.scalars[id] =
                    static_cast<float>(f(soup.points[id][0], soup.points[id][1], soup.points[id][2]));
            }
    soup.repairs.inputPoints = soup.points.size();
    soup.repairs.inputCells = cells[0] * cells[1] * cells[2];
    soup.repairs.splitCells = soup.repairs.inputCells;
    splitStructuredGrid(ni, nj, nk, {}, soup.tets, soup.repairs.blankedCells);
    TetMesh m = buildTetMesh(std::move(soup), "generated hex grid", "f");
    m.format = "generated";
    m.arrays.push_back({"f", true, 1, "Float32"});
    return m;
}

TetMesh marschnerLobbMesh(std::size_t n) {
    TetMesh m = generateHexGridMesh({n, n, n}, {-1, -1, -1}, {1, 1, 1},
                                    [](double x, double y, double z) { return marschnerLobbValue(x, y, z); });
    m.scalarName = "marschner_lobb";
    m.arrays = {{"marschner_lobb", true, 1, "Float32"}};
    return m;
}

} // namespace volcl::mesh
