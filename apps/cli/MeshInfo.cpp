// `volcl info` and `volcl convert` on meshes: read flags, the summary as text or JSON, .vtu write flags.
#include "apps/cli/MeshInfo.hpp"

#include "core/Error.hpp"

#include <iomanip>
#include <sstream>

namespace volcl::cli {

void MeshReadFlags::add(CLI::App& cmd) {
    cmd.add_option("--array", array, "Mesh: scalar array to use (default: the first scalar point array)");
    cmd.add_option("--q-var", qVariable,
                   "PLOT3D: q variable 0..4 (0 density, 1-3 momentum, 4 energy; default 0)");
    cmd.add_option("--q", qFile, "PLOT3D: solution file (default: the grid name with xyz -> q)");
}

mesh::MeshReadOptions MeshReadFlags::toReadOptions() const {
    if (qVariable < 0 || qVariable > 4)
        throw UsageError("--q-var " + std::to_string(qVariable) + " is out of range 0..4");
    mesh::MeshReadOptions o;
    if (!array.empty()) o.array = array;
    o.qVariable = qVariable;
    if (!qFile.empty()) o.qFile = qFile;
    return o;
}

void VtuWriteFlags::add(CLI::App& cmd) {
    cmd.add_option("--vtu-encoding", encoding, "Mesh output: appended (raw binary, default) or base64");
    cmd.add_flag("--zlib", zlib, "Mesh output: zlib-compress the .vtu arrays");
}

mesh::VtuWriteOptions VtuWriteFlags::toWriteOptions() const {
    mesh::VtuWriteOptions o;
    if (encoding == "base64")
        o.encoding = mesh::VtuEncoding::Base64;
    else if (encoding != "appended")
        throw UsageError("--vtu-encoding '" + encoding + "': use appended or base64");
    o.zlib = zlib;
    return o;
}

nlohmann::json meshInfoJson(const std::string& path, const mesh::TetMesh& m) {
    const mesh::MeshRepairs& r = m.repairs;
    nlohmann::json j;
    j["file"] = path;
    j["format"] = m.format;
    j["points"] = m.pointCount();
    j["tets"] = m.tetCount();
    j["boundary_faces"] = m.boundaryFaces.size();
    j["internal_faces"] = m.internalFaceCount();
    j["bounds"] = {{"min", m.boundsMin}, {"max", m.boundsMax}};
    j["volume"] = m.totalVolume();
    j["max_edge_length"] = m.maxEdgeLength;
    j["scalar"] = m.scalarName;
    j["scalar_from_cells"] = r.scalarFromCells;
    j["range"] = {m.valueMin, m.valueMax};
    nlohmann::json arrays = nlohmann::json::array();
    for (const mesh::MeshArrayInfo& a : m.arrays)
        arrays.push_back({{"name", a.name},
                          {"association", a.pointData ? "point" : "cell"},
                          {"components", a.components},
                          {"type", a.type}});
    j["arrays"] = arrays;
    j["repairs"] = {{"input_points", r.inputPoints},
                    {"input_cells", r.inputCells},
                    {"split_cells", r.splitCells},
                    {"quadratic_tets", r.quadraticTets},
                    {"blanked_cells", r.blankedCells},
                    {"candidate_tets", r.candidateTets},
                    {"merged_points", r.mergedPoints},
                    {"merged_scalar_conflicts", r.mergedScalarConflicts},
                    {"merged_scalar_max_difference", r.mergedScalarMaxDifference},
                    {"zero_volume_tets", r.zeroVolumeTets},
                    {"inverted_tets", r.invertedTets},
                    {"non_manifold_faces", r.nonManifoldFaces},
                    {"overlapping_faces", r.overlappingFaces},
                    {"unused_points", r.unusedPoints},
                    {"left_handed_grid", r.leftHandedGrid}};
    return j;
}

void printMeshInfo(std::ostream& out, const std::string& path, const mesh::TetMesh& m, bool json) {
    if (json) {
        out << meshInfoJson(path, m).dump(2) << '\n';
        return;
    }
    const mesh::MeshRepairs& r = m.repairs;
    out << path << '\n' << std::setprecision(6);
    out << "  format    " << m.format << '\n';
    out << "  points    " << m.pointCount() << "  (" << r.inputPoints << " in the file)\n";
    out << "  tets      " << m.tetCount() << "  (from " << r.inputCells << " cells, " << r.candidateTets
        << " candidate tets)\n";
    out << "  faces     " << m.boundaryFaces.size() << " boundary, " << m.internalFaceCount()
        << " internal\n";
    out << "  bounds    [" << m.boundsMin[0] << ", " << m.boundsMax[0] << "] x [" << m.boundsMin[1] << ", "
        << m.boundsMax[1] << "] x [" << m.boundsMin[2] << ", " << m.boundsMax[2] << "]\n";
    out << "  volume    " << m.totalVolume() << "  (longest edge " << m.maxEdgeLength << ")\n";
    out << "  scalar    " << m.scalarName
        << (r.scalarFromCells ? "  (cell data averaged onto the points)" : "") << '\n';
    out << "  range     " << m.valueMin << " .. " << m.valueMax << '\n';
    out << "  arrays   ";
    for (const mesh::MeshArrayInfo& a : m.arrays)
        out << " '" << a.name << "' (" << (a.pointData ? "point" : "cell") << ", " << a.type
            << (a.components == 1 ? "" : ", " + std::to_string(a.components) + " components") << ")";
    out << '\n';
    out << "  repairs   ";
    bool any = false;
    auto item = [&](std::size_t n, const std::string& what) {
        if (n == 0) return;
        out << (any ? "; " : "") << n << ' ' << what;
        any = true;
    };
    item(r.splitCells, "cells split into tets");
    item(r.quadraticTets, "quadratic tets reduced to their corners");
    item(r.blankedCells, "cells blanked (iblank 0)");
    item(r.mergedPoints, "duplicate points merged");
    item(
        r.mergedScalarConflicts, "merged groups with differing scalars (averaged, max difference " + [&] {
            std::ostringstream s;
            s << std::setprecision(3) << r.mergedScalarMaxDifference;
            return s.str();
        }() + ")");
    item(r.zeroVolumeTets, "zero-volume tets dropped");
    item(r.invertedTets, "inverted tets re-oriented");
    item(r.nonManifoldFaces, "non-manifold faces (left as boundary)");
    item(r.overlappingFaces, "overlapping face pairs (left as boundary)");
    item(r.unusedPoints, "unused points removed");
    if (r.leftHandedGrid) {
        out << (any ? "; " : "") << "left-handed grid re-ordered";
        any = true;
    }
    out << (any ? "" : "none") << '\n';
}

} // namespace volcl::cli
