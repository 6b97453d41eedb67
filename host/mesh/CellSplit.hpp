// Splitting VTK cells (tetra, voxel, hexahedron, wedge, pyramid, quadratic tetra) into tetrahedra.
#pragma once

#include "host/mesh/TetMesh.hpp"

#include <cstdint>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

namespace volcl::mesh {

/// VTK cell type numbers of the cells volcl reads.
enum class VtkCellType : std::uint8_t {
    Tetra = 10,
    Voxel = 11,
    Hexahedron = 12,
    Wedge = 13,
    Pyramid = 14,
    QuadraticTetra = 24,
};

/// Name of a VTK cell type number ("triangle", "hexahedron", ...), for messages.
std::string_view vtkCellTypeName(int type) noexcept;
/// Number of points a supported cell type has, or nullopt for an unsupported type.
std::optional<std::size_t> supportedCellPoints(int type) noexcept;

/// Appends the tets of one supported cell with global point ids `ids` to `out`.
///
/// The splitting rule makes neighbouring cells conform without knowing them: every quadrilateral face
/// is cut by the diagonal through its vertex with the smallest global id (so both cells sharing the
/// face cut it the same way), and the cell is split into tets that all share the cell's vertex v with
/// the smallest global id: one tet per triangle of each face not containing v (the faces containing v
/// are cut through v by the same rule). A hexahedron gives 6 tets, a wedge 3, a pyramid 2. Outward face
/// windings make every tet of a correctly oriented cell positively oriented. A quadratic tetra keeps
/// its 4 corner points.
void splitCell(VtkCellType type, std::span<const std::uint32_t> ids, std::vector<Tet>& out);

/// Tets of a structured ni x nj x nk point grid (point (i,j,k) has index i + ni*(j + nj*k)): each hexahedral
/// cell split by splitCell. Cells with a corner whose `keepPoint` entry is 0 are skipped and counted in
/// `skippedCells` (PLOT3D iblank); `keepPoint` may be empty.
void splitStructuredGrid(std::size_t ni, std::size_t nj, std::size_t nk,
                         std::span<const std::uint8_t> keepPoint, std::vector<Tet>& out,
                         std::size_t& skippedCells);

} // namespace volcl::mesh
