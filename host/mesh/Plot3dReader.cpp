// PLOT3D single-block 3D grid (x, y, z [, iblank]) + q solution reader; hexahedra split into tetrahedra.
#include "core/AtomicFile.hpp"
#include "host/mesh/CellSplit.hpp"
#include "host/mesh/MeshDetail.hpp"

#include <cmath>
#include <cstring>
#include <fstream>

namespace volcl::mesh::detail {

namespace fs = std::filesystem;
using io::fail;
using io::unsupported;

namespace {

// One way a PLOT3D file can be laid out; the reader tries them all and keeps the one whose sizes add
// up to exactly the file's size.
struct Plot3dLayout {
    Endian endian = Endian::Big;
    bool recordMarkers = false; ///< Fortran sequential records: 4-byte length before and after each
    bool blockCount = false;    ///< a leading block count (which must be 1)
    std::size_t realBytes = 4;  ///< 4 or 8
    bool iblank = false;
    std::size_t ni = 0, nj = 0, nk = 0;
};

std::uint32_t loadU32(const std::byte* p, Endian e) {
    std::uint32_t v;
    std::memcpy(&v, p, 4);
    if (e != io::hostEndian()) v = __builtin_bswap32(v);
    return v;
}

std::size_t headerBytes(const Plot3dLayout& L) {
    std::size_t h = 12;
    if (L.recordMarkers) h += 8;
    if (L.blockCount) h += L.recordMarkers ? 12 : 4;
    return h;
}

// Reads the dims of layout candidate `L` from `head` (at least 40 bytes); false when implausible.
bool readDims(std::span<const std::byte> head, Plot3dLayout& L) {
    std::size_t p = 0;
    auto word = [&] {
        const std::uint32_t v = loadU32(head.data() + p, L.endian);
        p += 4;
        return v;
    };
    if (L.blockCount) {
        if (L.recordMarkers && word() != 4) return false;
        if (word() != 1) return false;
        if (L.recordMarkers && word() != 4) return false;
    }
    if (L.recordMarkers && word() != 12) return false;
    const std::uint32_t d[3] = {word(), word(), word()};
    if (L.recordMarkers && word() != 12) return false;
    for (std::uint32_t v : d)
        if (v < 1 || v > (1u << 24)) return false;
    L.ni = d[0];
    L.nj = d[1];
    L.nk = d[2];
    return true;
}

std::size_t gridBytes(const Plot3dLayout& L) {
    const std::size_t n = L.ni * L.nj * L.nk;
    const std::size_t data = n * (3 * L.realBytes + (L.iblank ? 4 : 0));
    return headerBytes(L) + data + (L.recordMarkers ? 8 : 0);
}

std::optional<Plot3dLayout> gridLayout(std::span<const std::byte> head, std::uintmax_t fileSize) {
    if (head.size() < 40) return std::nullopt;
    for (Endian e : {Endian::Big, Endian::Little})
        for (bool markers : {false, true})
            for (bool count : {false, true})
                for (std::size_t real : {4, 8})
                    for (bool iblank : {false, true}) {
                        Plot3dLayout L{e, markers, count, real, iblank};
                        if (!readDims(head, L)) continue;
                        if (static_cast<double>(L.ni) * double(L.nj) * double(L.nk) > 1e12) continue;
                        if (gridBytes(L) == fileSize) return L;
                    }
    return std::nullopt;
}

std::vector<std::byte> fileHead(const fs::path& path, std::size_t n) {
    // A FIFO would block the read below, a device never end.
    if (const std::string kind = nonRegularKind(path); !kind.empty())
        throw IoError(path.string() + ": is " + kind + ", not a regular file");
    std::ifstream in(path, std::ios::binary);
    std::vector<std::byte> head(n);
    in.read(reinterpret_cast<char*>(head.data()), static_cast<std::streamsize>(n));
    head.resize(static_cast<std::size_t>(std::max<std::streamsize>(0, in.gcount())));
    return head;
}

std::vector<double> reals(std::span<const std::byte> bytes, std::size_t offset, std::size_t count,
                          const Plot3dLayout& L) {
    return io::decodeToDouble(bytes.subspan(offset, count * L.realBytes),
                              L.realBytes == 4 ? io::SampleType::Float32 : io::SampleType::Float64, L.endian);
}

const char* const kQNames[5] = {"density", "x momentum", "y momentum", "z momentum", "energy"};

// "q0 (density)" ... "q4 (energy)".
std::string qName(int k) {
    std::string s = "q";
    s += static_cast<char>('0' + k);
    s.append(" (").append(kQNames[k]).append(")");
    return s;
}

} // namespace

bool looksLikePlot3dGrid(const fs::path& path) {
    std::error_code ec;
    const auto size = fs::file_size(path, ec);
    return !ec && gridLayout(fileHead(path, 64), size).has_value();
}

TetMesh readPlot3d(const fs::path& path, const MeshReadOptions& options) {
    const std::vector<std::byte> grid = readFileBytes(path);
    const auto layout =
        gridLayout(std::span(grid).first(std::min<std::size_t>(64, grid.size())), grid.size());
    if (!layout) fail(path, "not a single-block 3D PLOT3D grid (no header layout matches the file size)");
    const Plot3dLayout& L = *layout;
    const std::size_t n = io::checkedVoxelCount({L.ni, L.nj, L.nk}, 1, path);
    if (n > 0xFFFFFFF0u) unsupported(path, std::to_string(n) + " points exceed the 2^32 limit");
    if (L.ni < 2 || L.nj < 2 || L.nk < 2)
        unsupported(path, "grid " + std::to_string(L.ni) + "x" + std::to_string(L.nj) + "x" +
                              std::to_string(L.nk) + " has no 3D cells");

    // Grid: x, y, z arrays, then iblank (int32).
    std::size_t off = headerBytes(L) + (L.recordMarkers ? 4 : 0);
    TetSoup soup;
    soup.points.resize(n);
    for (int a = 0; a < 3; ++a) {
        const std::vector<double> c = reals(grid, off, n, L);
        for (std::size_t i = 0; i < n; ++i)
            soup.points[i][a] = c[i];
        off += n * L.realBytes;
    }
    std::vector<std::uint8_t> keep;
    if (L.iblank) {
        keep.resize(n);
        for (std::size_t i = 0; i < n; ++i)
            keep[i] = loadU32(grid.data() + off + 4 * i, L.endian) != 0;
    }

    // Solution: the same header, 4 reals (Mach, alpha, Reynolds number, time), then 5 arrays.
    const fs::path qPath = options.qFile ? *options.qFile : plot3dSolutionFor(path).value_or(fs::path());
    std::error_code ec;
    if (qPath.empty() || !fs::is_regular_file(qPath, ec)) {
        std::string what = "PLOT3D solution file ";
        if (qPath.empty()) {
            what += "not given";
        } else {
            what += '\'';
            what += qPath.string();
            what += "' not found";
        }
        fail(path, what + " (name it with --q FILE)");
    }
    const std::vector<std::byte> q = readFileBytes(qPath);
    {
        Plot3dLayout Q = L;
        if (q.size() < 40 || !readDims(q, Q) || Q.ni != L.ni || Q.nj != L.nj || Q.nk != L.nk)
            fail(qPath, "q file header does not describe the grid's " + std::to_string(L.ni) + "x" +
                            std::to_string(L.nj) + "x" + std::to_string(L.nk) + " points");
    }
    std::size_t qOff = headerBytes(L) + (L.recordMarkers ? 4 : 0);
    const std::size_t qData = qOff + 4 * L.realBytes + (L.recordMarkers ? 8 : 0);
    const std::size_t qNeed = qData + 5 * n * L.realBytes + (L.recordMarkers ? 4 : 0);
    if (q.size() < qNeed)
        fail(qPath, "truncated: " + std::to_string(q.size()) + " bytes, the grid's solution needs " +
                        std::to_string(qNeed));
    // Some writers pad the file (the NASA blunt-fin q file carries 484 zero bytes): zeros are accepted.
    for (std::size_t i = qNeed; i < q.size(); ++i)
        if (q[i] != std::byte{0})
            fail(qPath, "oversized: " + std::to_string(q.size() - qNeed) +
                            " bytes after the solution are not padding");
    const std::vector<double> value =
        reals(q, qData + static_cast<std::size_t>(options.qVariable) * n * L.realBytes, n, L);
    soup.scalars.resize(n);
    for (std::size_t i = 0; i < n; ++i)
        soup.scalars[i] = static_cast<float>(value[i]);

    soup.repairs.inputPoints = n;
    soup.repairs.inputCells = (L.ni - 1) * (L.nj - 1) * (L.nk - 1);
    splitStructuredGrid(L.ni, L.nj, L.nk, keep, soup.tets, soup.repairs.blankedCells);
    soup.repairs.splitCells = soup.repairs.inputCells - soup.repairs.blankedCells;
    // A left-handed grid (i x j pointing against k) gives negative tets everywhere: re-order the whole
    // grid rather than report every cell as inverted.
    std::size_t negative = 0, positive = 0;
    for (const Tet& t : soup.tets) {
        const Point3 &a = soup.points[t[0]], &b = soup.points[t[1]], &c = soup.points[t[2]],
                     &d = soup.points[t[3]];
        const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]},
                     v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]},
                     w[3] = {d[0] - a[0], d[1] - a[1], d[2] - a[2]};
        const double o = u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) +
                         u[2] * (v[0] * w[1] - v[1] * w[0]);
        negative += o < 0;
        positive += o > 0;
    }
    if (negative > positive) {
        for (Tet& t : soup.tets)
            std::swap(t[1], t[2]);
        soup.repairs.leftHandedGrid = true;
    }
    const std::string name = qName(options.qVariable);
    TetMesh m = buildTetMesh(std::move(soup), path.string(), name);
    for (int k = 0; k < 5; ++k)
        m.arrays.push_back({qName(k), true, 1, L.realBytes == 4 ? "float32" : "float64"});
    m.format = std::string(meshFormatName(MeshFormat::Plot3d)) + (L.iblank ? " with iblank" : "") +
               (L.recordMarkers ? ", Fortran records" : "") +
               (L.endian == Endian::Big ? ", big-endian" : ", little-endian");
    return m;
}

} // namespace volcl::mesh::detail
