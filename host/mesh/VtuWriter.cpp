// VTK XML UnstructuredGrid (.vtu) writer: tetra cells and the point scalar, appended raw or base64, zlib.
#include "core/AtomicFile.hpp"
#include "host/io/IoDetail.hpp"
#include "host/io/VtkXmlArrays.hpp"
#include "host/mesh/MeshIo.hpp"

#include <algorithm>
#include <cstring>
#include <sstream>

namespace volcl::mesh {

namespace fs = std::filesystem;

namespace {

template <class T> std::vector<std::byte> littleBytes(const std::vector<T>& values) {
    std::vector<std::byte> out;
    out.reserve(values.size() * sizeof(T));
    for (const T& v : values)
        io::appendLittle(out, v);
    return out;
}

} // namespace

void writeVtu(const TetMesh& mesh, const fs::path& path, const VtuWriteOptions& options) {
    bool floatPoints = true;
    for (const Point3& p : mesh.points)
        for (double c : p)
            floatPoints &= static_cast<double>(static_cast<float>(c)) == c;
    std::vector<std::byte> pointBytes;
    pointBytes.reserve(mesh.points.size() * 3 * (floatPoints ? 4 : 8));
    for (const Point3& p : mesh.points)
        for (double c : p)
            floatPoints ? io::appendLittle(pointBytes, static_cast<float>(c))
                        : io::appendLittle(pointBytes, c);
    std::vector<std::int64_t> connectivity, offsets;
    connectivity.reserve(4 * mesh.tets.size());
    offsets.reserve(mesh.tets.size());
    for (const Tet& t : mesh.tets) {
        for (std::uint32_t v : t)
            connectivity.push_back(v);
        offsets.push_back(static_cast<std::int64_t>(connectivity.size()));
    }
    const std::vector<std::uint8_t> types(mesh.tets.size(), 10);

    struct Array {
        std::string attributes;
        io::VtkXmlEncodedArray encoded;
    };
    const std::string name = io::xmlEscape(mesh.scalarName.empty() ? "scalar" : mesh.scalarName);
    std::vector<Array> arrays;
    arrays.push_back({"type=\"Float32\" Name=\"" + name + "\" RangeMin=\"" + io::formatDouble(mesh.valueMin) +
                          "\" RangeMax=\"" + io::formatDouble(mesh.valueMax) + "\"",
                      io::encodeVtkXmlArray(littleBytes(mesh.scalars), options.zlib)});
    arrays.push_back({std::string("type=\"") + (floatPoints ? "Float32" : "Float64") +
                          "\" Name=\"Points\" NumberOfComponents=\"3\"",
                      io::encodeVtkXmlArray(pointBytes, options.zlib)});
    arrays.push_back({"type=\"Int64\" Name=\"connectivity\"",
                      io::encodeVtkXmlArray(littleBytes(connectivity), options.zlib)});
    arrays.push_back(
        {"type=\"Int64\" Name=\"offsets\"", io::encodeVtkXmlArray(littleBytes(offsets), options.zlib)});
    arrays.push_back(
        {"type=\"UInt8\" Name=\"types\"", io::encodeVtkXmlArray(littleBytes(types), options.zlib)});

    const bool appended = options.encoding == VtuEncoding::Appended;
    std::size_t offset = 0;
    auto element = [&](Array& a) {
        std::string s = "<DataArray " + a.attributes;
        if (appended) {
            s += " format=\"appended\" offset=\"" + std::to_string(offset) + "\"/>\n";
            offset += a.encoded.header.size() + a.encoded.data.size();
        } else {
            // Header and data are separate base64 runs, as VTK writes them.
            s += " format=\"binary\">\n          " + io::base64Encode(a.encoded.header) +
                 io::base64Encode(a.encoded.data) + "\n        </DataArray>\n";
        }
        return s;
    };
    std::ostringstream x;
    x << "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" "
         "byte_order=\"LittleEndian\" "
         "header_type=\"UInt64\""
      << (options.zlib ? " compressor=\"vtkZLibDataCompressor\"" : "") << ">\n  <UnstructuredGrid>\n"
      << "    <Piece NumberOfPoints=\"" << mesh.points.size() << "\" NumberOfCells=\"" << mesh.tets.size()
      << "\">\n"
      << "      <PointData Scalars=\"" << name << "\">\n        " << element(arrays[0])
      << "      </PointData>\n"
      << "      <CellData>\n      </CellData>\n"
      << "      <Points>\n        " << element(arrays[1]) << "      </Points>\n"
      << "      <Cells>\n        " << element(arrays[2]) << "        " << element(arrays[3]) << "        "
      << element(arrays[4]) << "      </Cells>\n    </Piece>\n  </UnstructuredGrid>\n";
    AtomicFile out(path);
    out.write(x.str());
    if (appended) {
        out.write("  <AppendedData encoding=\"raw\">\n   _");
        for (const Array& a : arrays) {
            out.write(a.encoded.header);
            out.write(a.encoded.data);
        }
        out.write("\n  </AppendedData>\n");
    }
    out.write("</VTKFile>\n");
    out.commit();
}

} // namespace volcl::mesh
