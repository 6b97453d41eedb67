// Tetrahedral mesh compression (.vcm): cut-border connectivity coding, predicted and entropy-coded geometry.
#pragma once

#include "host/mesh/MeshIo.hpp"
#include "host/mesh/TetMesh.hpp"
#include "meshcodec/VcmFormat.hpp"

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

namespace volcl::meshcodec {

struct VcmOptions {
    int bits = 16;         ///< quantisation bits per coordinate and for the scalar, 1-30
    bool lossless = false; ///< keep float64 positions and float32 scalars exactly (bits unused)
};

/// A compressed mesh and what the encoder knows about it.
struct EncodedMesh {
    std::vector<std::uint8_t> bytes;
    /// newIndex[i]: the index point i of the input has in the decoded mesh (decoding renumbers points in
    /// the order the cut border meets them).
    std::vector<std::uint32_t> newIndex;
    VcmHeader header;
    std::size_t headerBytes = 0;
};

/// Encodes a mesh (any TetMesh: disconnected parts start new components, non-manifold spots and tets the
/// border growth cannot reach are coded as explicit vertex indices). Throws UsageError for bits out of
/// range. The decoded mesh holds the same tets over renumbered points, in cut-border order.
EncodedMesh encodeMesh(const mesh::TetMesh& mesh, const VcmOptions& options = {});

/// A decoded .vcm: points (dequantised unless lossless), scalars and tets in cut-border order, exactly as
/// the encoder's traversal emitted them (no repairs).
struct DecodedMesh {
    VcmHeader header;
    std::vector<mesh::Point3> points;
    std::vector<float> scalars;
    std::vector<mesh::Tet> tets;
};

/// Decodes a whole .vcm. Corrupt, truncated or forged files throw IoError "<source>: ..." (checked by
/// parseVcm before any decoding, and by the streams' exact ends after it).
DecodedMesh decodeMesh(std::span<const std::uint8_t> file, const std::string& source,
                       std::size_t memoryBudget = 0);

/// The largest distance a dequantised coordinate of axis `axis` (0-2, 3 = the scalar) may lie from the
/// original: half a quantisation step, (max - min) / (2^bits - 1) / 2; 0 for a lossless file.
double quantisationBound(const VcmHeader& header, int axis) noexcept;

/// True when the file starts with the .vcm magic (false when it cannot be read).
bool isVcmFile(const std::filesystem::path& path);

/// Reads a .vcm into a TetMesh (buildTetMesh: with quantised positions, points that fall together are
/// merged and tets that flatten are dropped, and the repairs say so). `options.array` must name the
/// file's scalar if given.
mesh::TetMesh readVcm(const std::filesystem::path& path, const mesh::MeshReadOptions& options = {});

/// True when a reader of readAnyMesh takes the file: a .vcm, or what mesh::detectMeshFormat recognises.
bool isMeshFile(const std::filesystem::path& path);

/// Every mesh reader behind one call: a .vcm here, anything else through mesh::readMesh.
mesh::TetMesh readAnyMesh(const std::filesystem::path& path, const mesh::MeshReadOptions& options = {});

/// Encodes and writes a .vcm atomically.
EncodedMesh writeVcm(const mesh::TetMesh& mesh, const std::filesystem::path& path,
                     const VcmOptions& options = {});

} // namespace volcl::meshcodec
