// Cell splitting by the smallest-global-vertex rule: conforming tets from hexahedra, wedges and pyramids.
#include "host/mesh/CellSplit.hpp"

#include <algorithm>

namespace volcl::mesh {

namespace {

// Faces of the linear cells in VTK's local numbering, wound counter-clockwise seen from outside;
// -1 ends a triangle.
constexpr int kHexFaces[6][4] = {{0, 4, 7, 3}, {1, 2, 6, 5}, {0, 1, 5, 4},
                                 {3, 7, 6, 2}, {0, 3, 2, 1}, {4, 5, 6, 7}};
constexpr int kWedgeFaces[5][4] = {{0, 1, 2, -1}, {3, 5, 4, -1}, {0, 3, 4, 1}, {1, 4, 5, 2}, {2, 5, 3, 0}};
constexpr int kPyramidFaces[5][4] = {
    {0, 3, 2, 1}, {0, 1, 4, -1}, {1, 2, 4, -1}, {2, 3, 4, -1}, {3, 0, 4, -1}};

template <std::size_t F>
void splitByFaces(const int (&faces)[F][4], std::span<const std::uint32_t> ids, std::vector<Tet>& out) {
    const std::size_t apexLocal =
        static_cast<std::size_t>(std::min_element(ids.begin(), ids.end()) - ids.begin());
    const std::uint32_t apex = ids[apexLocal];
    for (const auto& face : faces) {
        const int n = face[3] < 0 ? 3 : 4;
        bool hasApex = false;
        for (int k = 0; k < n; ++k)
            hasApex |= static_cast<std::size_t>(face[k]) == apexLocal;
        if (hasApex) continue;
        if (n == 3) {
            out.push_back({apex, ids[face[0]], ids[face[1]], ids[face[2]]});
            continue;
        }
        int k = 0;
        for (int i = 1; i < 4; ++i)
            if (ids[face[i]] < ids[face[k]]) k = i;
        const std::uint32_t q0 = ids[face[k]], q1 = ids[face[(k + 1) % 4]], q2 = ids[face[(k + 2) % 4]],
                            q3 = ids[face[(k + 3) % 4]];
        out.push_back({apex, q0, q1, q2});
        out.push_back({apex, q0, q2, q3});
    }
}

} // namespace

std::string_view vtkCellTypeName(int type) noexcept {
    switch (type) {
    case 0:
        return "empty cell";
    case 1:
        return "vertex";
    case 2:
        return "poly-vertex";
    case 3:
        return "line";
    case 4:
        return "poly-line";
    case 5:
        return "triangle";
    case 6:
        return "triangle strip";
    case 7:
        return "polygon";
    case 8:
        return "pixel";
    case 9:
        return "quad";
    case 10:
        return "tetra";
    case 11:
        return "voxel";
    case 12:
        return "hexahedron";
    case 13:
        return "wedge";
    case 14:
        return "pyramid";
    case 15:
        return "pentagonal prism";
    case 16:
        return "hexagonal prism";
    case 21:
        return "quadratic edge";
    case 22:
        return "quadratic triangle";
    case 23:
        return "quadratic quad";
    case 24:
        return "quadratic tetra";
    case 25:
        return "quadratic hexahedron";
    case 26:
        return "quadratic wedge";
    case 27:
        return "quadratic pyramid";
    case 42:
        return "polyhedron";
    default:
        return "unknown cell type";
    }
}

std::optional<std::size_t> supportedCellPoints(int type) noexcept {
    switch (type) {
    case 10:
        return 4;
    case 11:
        return 8;
    case 12:
        return 8;
    case 13:
        return 6;
    case 14:
        return 5;
    case 24:
        return 10;
    default:
        return std::nullopt;
    }
}

void splitCell(VtkCellType type, std::span<const std::uint32_t> ids, std::vector<Tet>& out) {
    switch (type) {
    case VtkCellType::Tetra:
    case VtkCellType::QuadraticTetra:
        out.push_back({ids[0], ids[1], ids[2], ids[3]});
        return;
    case VtkCellType::Voxel: {
        const std::uint32_t hex[8] = {ids[0], ids[1], ids[3], ids[2], ids[4], ids[5], ids[7], ids[6]};
        splitByFaces(kHexFaces, hex, out);
        return;
    }
    case VtkCellType::Hexahedron:
        splitByFaces(kHexFaces, ids, out);
        return;
    case VtkCellType::Wedge:
        splitByFaces(kWedgeFaces, ids, out);
        return;
    case VtkCellType::Pyramid:
        splitByFaces(kPyramidFaces, ids, out);
        return;
    }
}

void splitStructuredGrid(std::size_t ni, std::size_t nj, std::size_t nk,
                         std::span<const std::uint8_t> keepPoint, std::vector<Tet>& out,
                         std::size_t& skippedCells) {
    if (ni < 2 || nj < 2 || nk < 2) return;
    out.reserve(out.size() + 6 * (ni - 1) * (nj - 1) * (nk - 1));
    auto index = [&](std::size_t i, std::size_t j, std::size_t k) {
        return static_cast<std::uint32_t>(i + ni * (j + nj * k));
    };
    for (std::size_t k = 0; k + 1 < nk; ++k)
        for (std::size_t j = 0; j + 1 < nj; ++j)
            for (std::size_t i = 0; i + 1 < ni; ++i) {
                const std::uint32_t ids[8] = {index(i, j, k),
                                              index(i + 1, j, k),
                                              index(i + 1, j + 1, k),
                                              index(i, j + 1, k),
                                              index(i, j, k + 1),
                                              index(i + 1, j, k + 1),
                                              index(i + 1, j + 1, k + 1),
                                              index(i, j + 1, k + 1)};
                if (!keepPoint.empty()) {
                    bool keep = true;
                    for (std::uint32_t id : ids)
                        keep &= keepPoint[id] != 0;
                    if (!keep) {
                        ++skippedCells;
                        continue;
                    }
                }
                splitByFaces(kHexFaces, ids, out);
            }
}

} // namespace volcl::mesh
