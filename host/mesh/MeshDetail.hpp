// Internal to host/mesh: the cell soup the VTK readers produce, array choice, number parsing.
#pragma once

#include "host/io/IoDetail.hpp"
#include "host/mesh/MeshIo.hpp"

#include <filesystem>
#include <vector>

namespace volcl::mesh::detail {

/// Cells as a VTK file stores them, before splitting and repairs.
struct CellSoup {
    std::vector<Point3> points;
    std::vector<double> types;   ///< VTK cell type per cell
    std::vector<double> offsets; ///< cells + 1 entries: cell c uses connectivity[offsets[c], offsets[c+1])
    std::vector<double> connectivity; ///< point ids
    std::vector<MeshArrayInfo> arrays;
    std::vector<double> values; ///< the chosen scalar array, one per point or per cell
    std::string valuesName;
    bool valuesOnPoints = true;
};

/// Index in `arrays` of the scalar to use: the one-component array named `name` (point data preferred
/// over cell data of the same name), else the first one-component point array, else the first
/// one-component cell array. Throws DataError listing what the file has when nothing fits.
std::size_t chooseScalarArray(const std::vector<MeshArrayInfo>& arrays,
                              const std::optional<std::string>& name, const std::filesystem::path& file);

/// Validates cells (sizes, types, point ids), splits them into tets, moves cell values to the points
/// when needed, and builds the mesh.
TetMesh meshFromCells(CellSoup soup, const std::filesystem::path& file, MeshFormat format);

/// Exactly `count` whitespace-separated numbers from `text`; fewer or more raise IoError naming `what`.
std::vector<double> parseAsciiNumbers(std::string_view text, std::size_t count,
                                      const std::filesystem::path& file, std::string_view what);

detail::CellSoup readVtuCells(const std::filesystem::path& path, const MeshReadOptions& options);
detail::CellSoup readLegacyCells(const std::filesystem::path& path, const MeshReadOptions& options);
TetMesh readPlot3d(const std::filesystem::path& path, const MeshReadOptions& options);
/// Layout of a PLOT3D grid file when its header describes the file's size exactly.
bool looksLikePlot3dGrid(const std::filesystem::path& path);

} // namespace volcl::mesh::detail
