// VTK XML UnstructuredGrid (.vtu) reader: points, cells and one scalar array, any VTK XML encoding.
#include "core/AtomicFile.hpp"
#include "core/MemoryBudget.hpp"
#include "host/io/VtkXmlArrays.hpp"
#include "host/mesh/MeshDetail.hpp"

#include <algorithm>

namespace volcl::mesh::detail {

namespace fs = std::filesystem;
using io::fail;
using io::unsupported;

namespace {

// Deflate expands at most about 1032:1, so no array can decode to more than this many bytes.
constexpr std::size_t kMaxInflateRatio = 1040;

struct VtuArrays {
    const io::VtkXmlPayload& payload;
    std::size_t fileBytes;

    // Reads `count` values of `da` (ascii, inline binary or appended), checking sizes before allocating.
    std::vector<double> read(pugi::xml_node da, std::size_t count, const std::string& what) const {
        const fs::path& path = payload.layout().file;
        const std::string typeName = io::attr(da, "type").value_or("");
        const auto st = io::vtkXmlType(typeName);
        if (!st) unsupported(path, what + ": type '" + typeName + "' is not supported");
        const std::string format = io::attr(da, "format").value_or("ascii");
        if (format == "ascii") return parseAsciiNumbers(io::elementText(da), count, path, what);
        const std::size_t bytes = io::checkedByteCount(count, io::sampleSize(*st), path);
        const std::size_t limit = payload.layout().compressed ? fileBytes * kMaxInflateRatio : fileBytes;
        if (bytes > limit)
            fail(path, "truncated: " + what + " needs " + std::to_string(bytes) + " bytes, the file has " +
                           std::to_string(fileBytes));
        return io::decodeToDouble(payload.decode(da, bytes), *st, payload.layout().endian);
    }
};

std::size_t countAttr(pugi::xml_node e, const char* key, const fs::path& path) {
    const auto text = io::attr(e, key);
    if (!text) fail(path, "<" + std::string(e.name()) + "> has no " + std::string(key));
    const long long n = io::requireInt(*text, path, key);
    if (n < 0) fail(path, std::string(key) + " " + std::to_string(n) + " is negative");
    return static_cast<std::size_t>(n);
}

int components(pugi::xml_node da, const fs::path& path) {
    const long long n =
        io::requireInt(io::attr(da, "NumberOfComponents").value_or("1"), path, "NumberOfComponents");
    if (n < 1 || n > 1024) fail(path, "NumberOfComponents " + std::to_string(n) + " is invalid");
    return static_cast<int>(n);
}

} // namespace

CellSoup readVtuCells(const fs::path& path, const MeshReadOptions& options) {
    const std::vector<std::byte> bytes = readFileBytes(path);
    io::VtkXmlDocument doc;
    io::parseVtkXml(doc, io::asText(bytes), path);
    const pugi::xml_node root = doc.root();
    if (root.name() != std::string_view("VTKFile"))
        fail(path, "not a VTK XML file (root element is <" + std::string(root.name()) + ">)");
    const std::string fileType = io::attr(root, "type").value_or("");
    if (fileType != "UnstructuredGrid")
        unsupported(path, "VTK XML type '" + fileType + "' is not UnstructuredGrid");
    const io::VtkXmlPayload payload(doc, bytes, io::vtkXmlLayout(root, path));
    const VtuArrays arrays{payload, bytes.size()};

    const auto grids = io::childrenNamed(root, "UnstructuredGrid");
    if (grids.size() != 1) fail(path, "expected one <UnstructuredGrid> element");
    const auto pieces = io::childrenNamed(grids[0], "Piece");
    if (pieces.size() != 1)
        unsupported(path, std::to_string(pieces.size()) + " pieces: only single-piece files are supported");
    const pugi::xml_node piece = pieces[0];
    const std::size_t nPoints = countAttr(piece, "NumberOfPoints", path);
    const std::size_t nCells = countAttr(piece, "NumberOfCells", path);
    // Every point and cell needs at least a byte somewhere (more when compressed is impossible to say).
    const std::size_t cap = payload.layout().compressed ? bytes.size() * kMaxInflateRatio : bytes.size();
    if (nPoints > cap || nCells > cap)
        fail(path, "truncated: " + std::to_string(nPoints) + " points and " + std::to_string(nCells) +
                       " cells cannot fit in " + std::to_string(bytes.size()) + " bytes");
    // Each point's coordinates and each cell's type and offset are held as doubles (at least one
    // connectivity id per cell more): the claim is checked before any array is decoded.
    checkMemoryBudget((3 * nPoints + 3 * nCells) * sizeof(double), 0, path,
                      "its " + std::to_string(nPoints) + " points and " + std::to_string(nCells) + " cells");

    auto namedArray = [&](pugi::xml_node parent, std::string_view name) -> pugi::xml_node {
        for (pugi::xml_node c : parent.children("DataArray"))
            if (io::attr(c, "Name").value_or("") == name) return c;
        fail(path, "<Cells> has no '" + std::string(name) + "' array");
    };

    CellSoup soup;
    // Points.
    const pugi::xml_node pointsEl = piece.child("Points");
    if (!pointsEl) fail(path, "no <Points> element");
    const auto pointArrays = io::childrenNamed(pointsEl, "DataArray");
    if (pointArrays.size() != 1) fail(path, "<Points> must hold one DataArray");
    const pugi::xml_node pda = pointArrays[0];
    if (components(pda, path) != 3) fail(path, "Points need 3 components");
    {
        const std::vector<double> xyz = arrays.read(pda, io::checkedByteCount(nPoints, 3, path), "Points");
        soup.points.resize(nPoints);
        for (std::size_t i = 0; i < nPoints; ++i)
            soup.points[i] = {xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]};
    }
    // Cells.
    const pugi::xml_node cellsEl = piece.child("Cells");
    if (!cellsEl) fail(path, "no <Cells> element");
    for (pugi::xml_node c : cellsEl.children("DataArray")) {
        const std::string n = io::attr(c, "Name").value_or("");
        if (n == "faces" || n == "faceoffsets")
            unsupported(path, "polyhedron cells (faces arrays) are not supported");
    }
    soup.types = arrays.read(namedArray(cellsEl, "types"), nCells, "types");
    std::vector<double> ends = arrays.read(namedArray(cellsEl, "offsets"), nCells, "offsets");
    soup.offsets.reserve(nCells + 1);
    soup.offsets.push_back(0);
    for (std::size_t c = 0; c < nCells; ++c) {
        if (!(ends[c] >= soup.offsets.back()) || ends[c] > 1e15)
            fail(path, "cell " + std::to_string(c) + ": offset " + io::formatDouble(ends[c]) +
                           " is smaller than the previous one or impossibly large");
        soup.offsets.push_back(ends[c]);
    }
    const auto nConn = static_cast<std::size_t>(soup.offsets.back());
    if (nConn > cap) fail(path, "truncated: the offsets claim " + std::to_string(nConn) + " point ids");
    soup.connectivity = arrays.read(namedArray(cellsEl, "connectivity"), nConn, "connectivity");

    // Arrays, then the chosen scalar.
    struct Found {
        pugi::xml_node element;
        bool pointData;
    };
    std::vector<Found> found;
    for (auto [section, onPoints] : {std::pair{"PointData", true}, std::pair{"CellData", false}})
        for (pugi::xml_node s : piece.children(section))
            for (pugi::xml_node da : s.children("DataArray")) {
                soup.arrays.push_back({io::attr(da, "Name").value_or(""), onPoints, components(da, path),
                                       io::attr(da, "type").value_or("?")});
                found.push_back({da, onPoints});
            }
    const std::size_t k = chooseScalarArray(soup.arrays, options.array, path);
    soup.valuesName = soup.arrays[k].name;
    soup.valuesOnPoints = found[k].pointData;
    soup.values = arrays.read(found[k].element, soup.valuesOnPoints ? nPoints : nCells,
                              "array '" + soup.valuesName + "'");
    return soup;
}

} // namespace volcl::mesh::detail
