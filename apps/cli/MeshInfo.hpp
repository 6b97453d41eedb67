// Mesh input for `volcl info` and `volcl convert`: read flags, the mesh summary, .vtu output flags.
#pragma once

#include "host/mesh/MeshIo.hpp"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <ostream>
#include <string>

namespace volcl::cli {

/// --array NAME, --q-var 0..4, --q FILE.
struct MeshReadFlags {
    std::string array, qFile;
    int qVariable = 0;
    void add(CLI::App& cmd);
    mesh::MeshReadOptions toReadOptions() const;
};

/// The summary `volcl info` prints for a mesh: counts, bounds, value range, arrays, repairs.
nlohmann::json meshInfoJson(const std::string& path, const mesh::TetMesh& m);
void printMeshInfo(std::ostream& out, const std::string& path, const mesh::TetMesh& m, bool json);

/// --vtu-encoding appended|base64, --zlib (convert with a mesh input).
struct VtuWriteFlags {
    std::string encoding = "appended";
    bool zlib = false;
    void add(CLI::App& cmd);
    mesh::VtuWriteOptions toWriteOptions() const;
};

} // namespace volcl::cli
