// Reading tetrahedral meshes (VTK legacy and XML unstructured grids, PLOT3D grids) and writing .vtu files.
#pragma once

#include "host/mesh/TetMesh.hpp"

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

namespace volcl::mesh {

enum class MeshFormat : std::uint8_t {
    VtkXml,    ///< .vtu UnstructuredGrid
    VtkLegacy, ///< .vtk DATASET UNSTRUCTURED_GRID
    Plot3d,    ///< single-block PLOT3D grid (.xyz/.x/.g/.p3d/.bin) plus a q solution file
};
std::string_view meshFormatName(MeshFormat f) noexcept;

struct MeshReadOptions {
    std::optional<std::string> array; ///< scalar array by name (default: the first scalar point array)
    int qVariable = 0;                ///< PLOT3D: 0 density, 1-3 momentum x/y/z, 4 energy
    std::optional<std::filesystem::path> qFile; ///< PLOT3D: default = the grid's name with "xyz" -> "q"
};

/// The mesh format of a file, or nullopt when it is not a mesh (a volume, or unknown). Looks at the
/// extension and the content: a .vtu must hold an UnstructuredGrid, a .vtk an UNSTRUCTURED_GRID, a
/// PLOT3D grid's header must describe exactly the file's size.
std::optional<MeshFormat> detectMeshFormat(const std::filesystem::path& path);

/// Reads a mesh file of any supported format and builds the repaired tetrahedral mesh (see
/// buildTetMesh for the repairs). Bad files throw IoError naming the file and the element; unsupported
/// content (cell types, multi-block grids, no scalar array) throws DataError; a bad option UsageError.
/// Example: `TetMesh m = readMesh("xsmall_turb.vtu");`
TetMesh readMesh(const std::filesystem::path& path, const MeshReadOptions& options = {});

/// The PLOT3D solution file that belongs to a grid file: the last "xyz" of the name replaced by "q"
/// (bluntfinxyz.bin -> bluntfinq.bin, wing.xyz -> wing.q).
std::optional<std::filesystem::path> plot3dSolutionFor(const std::filesystem::path& grid);

enum class VtuEncoding : std::uint8_t {
    Appended, ///< raw binary in an AppendedData section (smallest, fastest)
    Base64,   ///< inline base64 DataArrays (plain text, e-mail safe)
};
struct VtuWriteOptions {
    VtuEncoding encoding = VtuEncoding::Appended;
    bool zlib = false; ///< vtkZLibDataCompressor blocks of 32 KiB
};

/// Writes the mesh as a VTK XML UnstructuredGrid (UInt64 headers, little-endian) with its points
/// (Float32 when every coordinate is exactly a float, else Float64), tetra cells (Int64 connectivity)
/// and the scalar as Float32 point data. Atomic: a failed write leaves no file.
void writeVtu(const TetMesh& mesh, const std::filesystem::path& path, const VtuWriteOptions& options = {});

} // namespace volcl::mesh
