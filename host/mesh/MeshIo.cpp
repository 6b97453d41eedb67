// Mesh file dispatch (extension + content), array choice, and cells -> tets for the VTK readers.
#include "host/mesh/MeshIo.hpp"

#include "core/AtomicFile.hpp"
#include "core/Error.hpp"
#include "host/mesh/CellSplit.hpp"
#include "host/mesh/MeshDetail.hpp"

#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>

namespace volcl::mesh {

namespace fs = std::filesystem;
using io::endsWithI;
using io::fail;
using io::unsupported;

std::string_view meshFormatName(MeshFormat f) noexcept {
    switch (f) {
    case MeshFormat::VtkXml:
        return "VTK XML UnstructuredGrid";
    case MeshFormat::VtkLegacy:
        return "legacy VTK UNSTRUCTURED_GRID";
    case MeshFormat::Plot3d:
        return "PLOT3D";
    }
    return "unknown";
}

namespace {

std::string fileHead(const fs::path& path, std::size_t n) {
    // A FIFO would block the read below, a device never end.
    if (const std::string kind = nonRegularKind(path); !kind.empty())
        throw IoError(path.string() + ": is " + kind + ", not a regular file");
    std::ifstream in(path, std::ios::binary);
    std::string head(n, '\0');
    in.read(head.data(), static_cast<std::streamsize>(n));
    head.resize(static_cast<std::size_t>(std::max<std::streamsize>(0, in.gcount())));
    return head;
}

bool isPlot3dExtension(std::string_view name) {
    for (std::string_view e : {".xyz", ".x", ".g", ".p3d", ".bin"})
        if (endsWithI(name, e)) return true;
    return false;
}

} // namespace

std::optional<MeshFormat> detectMeshFormat(const fs::path& path) {
    std::error_code ec;
    if (!fs::is_regular_file(path, ec)) return std::nullopt;
    const std::string name = path.filename().string();
    const std::string head = fileHead(path, 1024);
    if (head.find("<VTKFile") != std::string::npos) {
        const std::size_t root = head.find("<VTKFile");
        const std::size_t close = head.find('>', root);
        const std::string_view tag =
            std::string_view(head).substr(root, close == std::string::npos ? 200 : close - root);
        if (tag.find("\"UnstructuredGrid\"") != std::string_view::npos) return MeshFormat::VtkXml;
        return std::nullopt;
    }
    if (head.starts_with("# vtk DataFile")) {
        // The DATASET line follows the title and the ASCII/BINARY line.
        for (std::size_t p = head.find("DATASET"); p != std::string::npos; p = head.find("DATASET", p + 1)) {
            const auto words = io::splitWords(std::string_view(head).substr(p, 64));
            if (words.size() >= 2 && io::iequals(words[1], "UNSTRUCTURED_GRID")) return MeshFormat::VtkLegacy;
            if (words.size() >= 2) return std::nullopt;
        }
        return std::nullopt;
    }
    if (isPlot3dExtension(name) && detail::looksLikePlot3dGrid(path)) return MeshFormat::Plot3d;
    if (endsWithI(name, ".vtu")) return MeshFormat::VtkXml; // the reader says what is wrong with it
    return std::nullopt;
}

std::optional<fs::path> plot3dSolutionFor(const fs::path& grid) {
    const std::string name = grid.filename().string();
    std::string l = io::lower(name);
    const std::size_t p = l.rfind("xyz");
    if (p == std::string::npos) return std::nullopt;
    return grid.parent_path() / (name.substr(0, p) + "q" + name.substr(p + 3));
}

TetMesh readMesh(const fs::path& path, const MeshReadOptions& options) {
    if (options.qVariable < 0 || options.qVariable > 4)
        throw UsageError("--q-var " + std::to_string(options.qVariable) +
                         " is out of range: 0 density, 1-3 momentum, 4 energy");
    std::error_code ec;
    if (!fs::is_regular_file(path, ec)) fail(path, "no such file");
    const auto format = detectMeshFormat(path);
    if (!format) unsupported(path, "not a mesh file (VTK UnstructuredGrid .vtu/.vtk or a PLOT3D grid)");
    switch (*format) {
    case MeshFormat::VtkXml:
        return detail::meshFromCells(detail::readVtuCells(path, options), path, *format);
    case MeshFormat::VtkLegacy:
        return detail::meshFromCells(detail::readLegacyCells(path, options), path, *format);
    case MeshFormat::Plot3d:
        return detail::readPlot3d(path, options);
    }
    return {};
}

namespace detail {

std::size_t chooseScalarArray(const std::vector<MeshArrayInfo>& arrays,
                              const std::optional<std::string>& name, const fs::path& file) {
    auto list = [&] {
        std::string s;
        for (const MeshArrayInfo& a : arrays)
            s += (s.empty() ? "" : ", ") +
                 ("'" + a.name + "' (" + (a.pointData ? "point" : "cell") +
                  (a.components == 1 ? "" : ", " + std::to_string(a.components) + " components") + ")");
        return s.empty() ? std::string("none") : s;
    };
    if (name) {
        for (int pass = 0; pass < 2; ++pass)
            for (std::size_t i = 0; i < arrays.size(); ++i)
                if (arrays[i].name == *name && arrays[i].pointData == (pass == 0)) {
                    if (arrays[i].components != 1)
                        unsupported(file, "array '" + *name + "' has " +
                                              std::to_string(arrays[i].components) +
                                              " components: only scalars can be rendered");
                    return i;
                }
        unsupported(file, "no array named '" + *name + "'; arrays: " + list());
    }
    for (int pass = 0; pass < 2; ++pass)
        for (std::size_t i = 0; i < arrays.size(); ++i)
            if (arrays[i].components == 1 && arrays[i].pointData == (pass == 0)) return i;
    unsupported(file, "no scalar (one-component) array; arrays: " + list());
}

std::vector<double> parseAsciiNumbers(std::string_view text, std::size_t count, const fs::path& file,
                                      std::string_view what) {
    io::requireAsciiCapacity(text, count, file);
    std::vector<double> out(count);
    const char* p = text.data();
    const char* end = p + text.size();
    auto skipSpace = [&] {
        while (p < end && std::isspace(static_cast<unsigned char>(*p)))
            ++p;
    };
    for (std::size_t i = 0; i < count; ++i) {
        skipSpace();
        if (p >= end)
            fail(file, "truncated: " + std::string(what) + " has " + std::to_string(i) +
                           " values, expected " + std::to_string(count));
        const char* q = p;
        if (*q == '+') ++q;
        auto [ptr, ec] = std::from_chars(q, end, out[i]);
        if (ec == std::errc::result_out_of_range) {
            out[i] = std::strtod(
                std::string(q, std::min<std::size_t>(64, static_cast<std::size_t>(end - q))).c_str(),
                nullptr);
        } else if (ec != std::errc() || (ptr < end && !std::isspace(static_cast<unsigned char>(*ptr)))) {
            std::size_t n = 0;
            while (p + n < end && n < 30 && !std::isspace(static_cast<unsigned char>(p[n])))
                ++n;
            fail(file, std::string(what) + " value " + std::to_string(i) + ": '" + std::string(p, n) +
                           "' is not a number");
        }
        while (ptr < end && !std::isspace(static_cast<unsigned char>(*ptr)))
            ++ptr;
        p = ptr;
    }
    skipSpace();
    if (p < end)
        fail(file,
             "oversized: " + std::string(what) + " holds more than " + std::to_string(count) + " values");
    return out;
}

TetMesh meshFromCells(CellSoup soup, const fs::path& file, MeshFormat format) {
    const std::size_t nCells = soup.types.size(), nPoints = soup.points.size();
    if (soup.offsets.size() != nCells + 1) throw Error("internal: meshFromCells needs cells + 1 offsets");
    if (nPoints > 0xFFFFFFF0u) unsupported(file, std::to_string(nPoints) + " points exceed the 2^32 limit");
    if (soup.offsets[0] != 0) fail(file, "cell 0: offsets do not start at 0");
    if (soup.offsets[nCells] != static_cast<double>(soup.connectivity.size()))
        fail(file, "the cell offsets end at " + io::formatDouble(soup.offsets[nCells]) +
                       " but the connectivity holds " + std::to_string(soup.connectivity.size()) +
                       " point ids");
    TetSoup tets;
    tets.repairs.inputPoints = nPoints;
    tets.repairs.inputCells = nCells;
    tets.tets.reserve(nCells);
    std::vector<double> sum, weight;
    if (!soup.valuesOnPoints) {
        sum.assign(nPoints, 0);
        weight.assign(nPoints, 0);
    }
    std::vector<std::uint32_t> ids;
    for (std::size_t c = 0; c < nCells; ++c) {
        const double t = soup.types[c];
        const int type = t >= 0 && t < 256 && t == std::floor(t) ? static_cast<int>(t) : -1;
        const auto need = supportedCellPoints(type);
        if (!need)
            unsupported(file,
                        "cell " + std::to_string(c) + " is a " + std::string(vtkCellTypeName(type)) +
                            " (VTK type " + io::formatDouble(t) +
                            "): only tetra (10), voxel (11), hexahedron (12), wedge (13), pyramid (14) and "
                            "quadratic tetra (24) cells are read");
        const double b = soup.offsets[c], e = soup.offsets[c + 1];
        if (!(e >= b) || e - b != static_cast<double>(*need))
            fail(file, "cell " + std::to_string(c) + ": a " + std::string(vtkCellTypeName(type)) + " needs " +
                           std::to_string(*need) + " point ids, the offsets give " + io::formatDouble(e - b));
        ids.clear();
        for (std::size_t k = static_cast<std::size_t>(b); k < static_cast<std::size_t>(e); ++k) {
            const double id = soup.connectivity[k];
            if (!(id >= 0 && id < static_cast<double>(nPoints)) || id != std::floor(id))
                fail(file, "cell " + std::to_string(c) + ": point id " + io::formatDouble(id) +
                               " is out of range (" + std::to_string(nPoints) + " points)");
            ids.push_back(static_cast<std::uint32_t>(id));
        }
        if (!soup.valuesOnPoints)
            for (std::uint32_t id : ids) {
                sum[id] += soup.values[c];
                weight[id] += 1;
            }
        if (type == static_cast<int>(VtkCellType::QuadraticTetra)) ++tets.repairs.quadraticTets;
        if (type != static_cast<int>(VtkCellType::Tetra) &&
            type != static_cast<int>(VtkCellType::QuadraticTetra))
            ++tets.repairs.splitCells;
        splitCell(static_cast<VtkCellType>(type), ids, tets.tets);
        if (tets.tets.size() > kMaxTets)
            unsupported(file, "more than " + std::to_string(kMaxTets) + " tetrahedra");
    }
    soup.types = {};
    soup.offsets = {};
    soup.connectivity = {};
    tets.scalars.resize(nPoints);
    if (soup.valuesOnPoints) {
        for (std::size_t i = 0; i < nPoints; ++i)
            tets.scalars[i] = static_cast<float>(soup.values[i]);
    } else {
        // A cell value shows as NaN on the points it touches; name the cell rather than a point.
        for (std::size_t c = 0; c < nCells; ++c)
            if (!std::isfinite(soup.values[c]))
                unsupported(file, "cell " + std::to_string(c) + ": scalar '" + soup.valuesName + "' is " +
                                      (std::isnan(soup.values[c]) ? "NaN" : "infinite"));
        for (std::size_t i = 0; i < nPoints; ++i)
            tets.scalars[i] = weight[i] > 0 ? static_cast<float>(sum[i] / weight[i]) : 0.0f;
        tets.repairs.scalarFromCells = true;
    }
    tets.points = std::move(soup.points);
    TetMesh m = buildTetMesh(std::move(tets), file.string(), soup.valuesName);
    m.arrays = std::move(soup.arrays);
    m.format = std::string(meshFormatName(format));
    return m;
}

} // namespace detail

} // namespace volcl::mesh
