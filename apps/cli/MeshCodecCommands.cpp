// The .vcm side of `volcl encode`, `decode` and `info`: read, encode, decode and describe compressed meshes.
#include "apps/cli/MeshCodecCommands.hpp"

#include "core/AtomicFile.hpp"
#include "core/Error.hpp"
#include "core/Format.hpp"
#include "core/runtime/Timing.hpp"

#include <filesystem>
#include <iostream>

namespace volcl::cli {

namespace {

struct VcmSummary {
    std::size_t fileBytes = 0, headerBytes = 0, connectivityBytes = 0, geometryBytes = 0;
    double bitsPerTet = 0, bitsPerVertex = 0, connectivityBitsPerTet = 0, geometryBitsPerVertex = 0;
};

VcmSummary summarise(const meshcodec::VcmHeader& h, std::size_t fileBytes, std::size_t headerBytes) {
    using namespace meshcodec;
    VcmSummary s;
    s.fileBytes = fileBytes;
    s.headerBytes = headerBytes;
    s.connectivityBytes = h.sectionSize[ConnectivityRans] + h.sectionSize[ConnectivityRaw];
    s.geometryBytes = h.sectionSize[GeometryRans] + h.sectionSize[GeometryRaw];
    s.bitsPerTet = 8.0 * double(fileBytes) / double(h.tets);
    s.bitsPerVertex = 8.0 * double(fileBytes) / double(h.points);
    s.connectivityBitsPerTet = 8.0 * double(s.connectivityBytes) / double(h.tets);
    s.geometryBitsPerVertex = 8.0 * double(s.geometryBytes) / double(h.points);
    return s;
}

std::string quantisationText(const meshcodec::VcmHeader& h) {
    return h.lossless ? std::string("lossless (float64 positions, float32 scalars)")
                      : std::to_string(h.bits) + " bits per coordinate and scalar";
}

} // namespace

bool writesVcm(const std::string& out) {
    return std::filesystem::path(out).extension() == ".vcm";
}

void encodeMeshCommand(const std::string& in, const std::string& out, const meshcodec::VcmOptions& options,
                       const MeshReadFlags& read, bool quiet) {
    if (!meshcodec::isMeshFile(in))
        throw UsageError(in + ": a .vcm output needs a tetrahedral mesh input (.vtu, .vtk, PLOT3D or .vcm)");
    checkNotSameFile({std::filesystem::path(in)}, {std::filesystem::path(out)});
    checkOutputPath(out);
    const mesh::TetMesh m = meshcodec::readAnyMesh(in, read.toReadOptions());
    Stopwatch sw;
    const meshcodec::EncodedMesh e = meshcodec::encodeMesh(m, options);
    const double ms = sw.milliseconds();
    AtomicFile file(out);
    file.write({reinterpret_cast<const std::byte*>(e.bytes.data()), e.bytes.size()});
    file.commit();
    if (quiet) return;
    const VcmSummary s = summarise(e.header, e.bytes.size(), e.headerBytes);
    std::cerr << "volcl: wrote " << out << ": " << e.bytes.size() << " bytes for " << m.tetCount()
              << " tets and " << m.pointCount() << " points; connectivity "
              << formatFixed(s.connectivityBitsPerTet, 3) << " bits/tet, geometry "
              << formatFixed(s.geometryBitsPerVertex, 2) << " bits/vertex (" << quantisationText(e.header)
              << "), " << formatFixed(double(m.tetCount()) / ms / 1e3, 2) << " M tets/s\n";
}

void decodeMeshCommand(const std::string& in, const std::string& out, const VtuWriteFlags& write,
                       bool quiet) {
    if (std::filesystem::path(out).extension() != ".vtu")
        throw UsageError("-o " + out + ": a .vcm decodes to a .vtu");
    checkNotSameFile({std::filesystem::path(in)}, {std::filesystem::path(out)});
    const mesh::VtuWriteOptions wo = write.toWriteOptions();
    checkOutputPath(out);
    const mesh::TetMesh m = meshcodec::readVcm(in);
    mesh::writeVtu(m, out, wo);
    if (!quiet)
        std::cerr << "volcl: wrote " << out << " (" << m.pointCount() << " points, " << m.tetCount()
                  << " tets, in cut-border order)\n";
}

void printVcmInfo(std::ostream& out, const std::string& path, const MeshReadFlags& read, bool json) {
    const std::vector<std::byte> bytes = readFileBytes(path);
    const std::span<const std::uint8_t> file(reinterpret_cast<const std::uint8_t*>(bytes.data()),
                                             bytes.size());
    const meshcodec::VcmView view = meshcodec::parseVcm(file, path);
    const meshcodec::VcmHeader& h = view.header;
    const VcmSummary s = summarise(h, bytes.size(), view.headerBytes);
    const mesh::TetMesh m = meshcodec::readVcm(path, read.toReadOptions());
    if (json) {
        nlohmann::json j = meshInfoJson(path, m);
        j["vcm"] = {{"bytes", s.fileBytes},
                    {"header_bytes", s.headerBytes},
                    {"connectivity_bytes", s.connectivityBytes},
                    {"geometry_bytes", s.geometryBytes},
                    {"points", h.points},
                    {"tets", h.tets},
                    {"lossless", h.lossless},
                    {"bits", h.bits},
                    {"predictor", h.predictor == meshcodec::Predictor::Reflect ? "reflect" : "average"},
                    {"bits_per_tet", s.bitsPerTet},
                    {"bits_per_vertex", s.bitsPerVertex},
                    {"connectivity_bits_per_tet", s.connectivityBitsPerTet},
                    {"geometry_bits_per_vertex", s.geometryBitsPerVertex},
                    {"max_position_error",
                     {meshcodec::quantisationBound(h, 0), meshcodec::quantisationBound(h, 1),
                      meshcodec::quantisationBound(h, 2)}},
                    {"max_scalar_error", meshcodec::quantisationBound(h, 3)}};
        out << j.dump(2) << '\n';
        return;
    }
    printMeshInfo(out, path, m, false);
    out << "  vcm       " << s.fileBytes << " bytes (" << h.points << " points, " << h.tets
        << " tets): connectivity " << s.connectivityBytes
        << " bytes = " << formatFixed(s.connectivityBitsPerTet, 3) << " bits/tet, geometry "
        << s.geometryBytes << " bytes = " << formatFixed(s.geometryBitsPerVertex, 2) << " bits/vertex; "
        << formatFixed(s.bitsPerTet, 2) << " bits/tet in all\n";
    out << "  quantised " << quantisationText(h) << ", "
        << (h.predictor == meshcodec::Predictor::Reflect ? "reflection" : "centroid") << " prediction";
    if (!h.lossless)
        out << "; error at most " << meshcodec::quantisationBound(h, 0) << ", "
            << meshcodec::quantisationBound(h, 1) << ", " << meshcodec::quantisationBound(h, 2)
            << " (x, y, z), " << meshcodec::quantisationBound(h, 3) << " (scalar)";
    out << '\n';
}

} // namespace volcl::cli
