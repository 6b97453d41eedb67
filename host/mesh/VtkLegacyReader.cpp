// Legacy VTK UNSTRUCTURED_GRID (.vtk) reader: ASCII or big-endian BINARY, file versions 2 to 5.1.
#include "core/AtomicFile.hpp"
#include "host/mesh/MeshDetail.hpp"

#include <cctype>
#include <cstring>

namespace volcl::mesh::detail {

namespace fs = std::filesystem;
using io::fail;
using io::SampleType;
using io::unsupported;

namespace {

// Walks a legacy file: keyword lines as text, data blocks as ASCII tokens or raw big-endian bytes.
class LegacyCursor {
public:
    LegacyCursor(std::string_view text, bool binary, const fs::path& file)
        : text_(text), binary_(binary), file_(file) {}

    /// The next non-empty line split into words; empty at the end of the file.
    std::vector<std::string_view> keywordLine() {
        while (pos_ < text_.size()) {

            const auto line = io::nextLine(text_, pos_);
            const auto words = io::splitWords(*line);
            if (words.empty()) continue;
            if (text_[pos_ - 1] != '\n')
                fail(file_, "truncated after '" + std::string(line->substr(0, 40)) + "'");
            return words;
        }
        return {};
    }
    std::size_t position() const noexcept { return pos_; }
    void seek(std::size_t pos) noexcept { pos_ = pos; }
    /// Skips a METADATA block, which ends with an empty line.
    void skipMetadata() {
        while (pos_ < text_.size()) {
            const auto l = io::nextLine(text_, pos_);
            if (io::trim(*l).empty()) break;
        }
    }

    /// Skips (or with `out`, decodes) `count` values of type `st` starting at the cursor.
    void values(std::size_t count, SampleType st, const std::string& what, std::vector<double>* out) {
        if (binary_) {
            const std::size_t bytes = io::checkedByteCount(count, io::sampleSize(st), file_);
            if (text_.size() - pos_ < bytes)
                fail(file_, "truncated: " + what + " needs " + std::to_string(bytes) + " bytes, " +
                                std::to_string(text_.size() - pos_) + " remain");
            if (out)
                *out = io::decodeToDouble(
                    std::span(reinterpret_cast<const std::byte*>(text_.data() + pos_), bytes), st,
                    Endian::Big);
            pos_ += bytes;
            return;
        }
        // Refuse before scanning when the text cannot hold the values (each needs a digit and a space).
        if (count > (text_.size() - pos_ + 1) / 2)
            fail(file_, "truncated: " + what + " needs " + std::to_string(count) +
                            " values, the rest of the file " + "cannot hold them");
        std::size_t p = pos_, n = 0;
        while (n < count) {
            while (p < text_.size() && std::isspace(static_cast<unsigned char>(text_[p])))
                ++p;
            if (p >= text_.size()) break;
            while (p < text_.size() && !std::isspace(static_cast<unsigned char>(text_[p])))
                ++p;
            ++n;
        }
        if (n < count)
            fail(file_, "truncated: " + what + " has " + std::to_string(n) + " values, expected " +
                            std::to_string(count));
        if (out) *out = parseAsciiNumbers(text_.substr(pos_, p - pos_), count, file_, what);
        pos_ = p;
    }

private:
    std::string_view text_;
    bool binary_;
    const fs::path& file_;
    std::size_t pos_ = 0;
};

std::size_t requireCount(const std::vector<std::string_view>& w, std::size_t i, const fs::path& file,
                         std::string_view what) {
    if (w.size() <= i) fail(file, std::string(what) + " needs a count");
    const long long n = io::requireInt(w[i], file, what);
    if (n < 0) fail(file, std::string(what) + " count " + std::to_string(n) + " is negative");
    return static_cast<std::size_t>(n);
}

SampleType requireType(const std::vector<std::string_view>& w, std::size_t i, const fs::path& file,
                       std::string_view what) {
    if (w.size() <= i) fail(file, std::string(what) + " needs a data type");
    const auto st = io::vtkLegacyType(w[i]);
    if (!st)
        unsupported(file, std::string(what) + ": data type '" + std::string(w[i]) + "' is not supported");
    return *st;
}

// An attribute array's place in the file, decoded only if it is the chosen scalar.
struct ArrayPlace {
    std::size_t pos;
    std::size_t count;
    SampleType type;
};

// The three lines before the data: version, title, ASCII or BINARY.
struct LegacyPreamble {
    double version = 2.0;
    bool binary = false;
    std::size_t end = 0; ///< where the keyword lines start
};

LegacyPreamble readPreamble(std::string_view text, const fs::path& path) {
    LegacyPreamble p;
    std::size_t pos = 0;
    const auto line1 = io::nextLine(text, pos);
    if (!line1 || !line1->starts_with("# vtk DataFile Version"))
        fail(path, "not a legacy VTK file (bad first line)");
    p.version = io::parseNumber<double>(io::trim(line1->substr(22))).value_or(2.0);
    if (!io::nextLine(text, pos)) fail(path, "truncated: no title line");
    auto modeLine = io::nextLine(text, pos);
    while (modeLine && io::trim(*modeLine).empty())
        modeLine = io::nextLine(text, pos);
    if (!modeLine) fail(path, "truncated: no ASCII/BINARY line");
    const std::string mode = io::lower(io::trim(*modeLine));
    if (mode != "ascii" && mode != "binary")
        fail(path, "third line must be ASCII or BINARY, not '" +
                       std::string(io::trim(*modeLine).substr(0, 30)) + "'");
    p.binary = mode == "binary";
    p.end = pos;
    return p;
}

// File version 5: CELLS <offsets> <connectivity>, then OFFSETS <type> and CONNECTIVITY <type> blocks.
// Returns the cell count.
std::size_t readOffsetCells(LegacyCursor& cur, const std::vector<std::string_view>& w, const fs::path& path,
                            CellSoup& soup) {
    const std::size_t nOffsets = requireCount(w, 1, path, "CELLS");
    const std::size_t nConn = requireCount(w, 2, path, "CELLS");
    if (nOffsets == 0) fail(path, "CELLS needs at least one offset");
    const std::size_t nCells = nOffsets - 1;
    const auto wo = cur.keywordLine();
    if (wo.empty() || !io::iequals(wo[0], "offsets")) fail(path, "CELLS: OFFSETS block missing");
    cur.values(nOffsets, requireType(wo, 1, path, "OFFSETS"), "OFFSETS", &soup.offsets);
    const auto wc = cur.keywordLine();
    if (wc.empty() || !io::iequals(wc[0], "connectivity")) fail(path, "CELLS: CONNECTIVITY block missing");
    cur.values(nConn, requireType(wc, 1, path, "CONNECTIVITY"), "CONNECTIVITY", &soup.connectivity);
    for (std::size_t c = 0; c < nCells; ++c)
        if (!(soup.offsets[c + 1] >= soup.offsets[c]))
            fail(path, "cell " + std::to_string(c) + ": OFFSETS decrease");
    return nCells;
}

// Versions before 5: CELLS <cells> <size>, per cell its point count, then the ids. Returns the cell count.
std::size_t readCountedCells(LegacyCursor& cur, const std::vector<std::string_view>& w, const fs::path& path,
                             CellSoup& soup) {
    const std::size_t nCells = requireCount(w, 1, path, "CELLS");
    const std::size_t size = requireCount(w, 2, path, "CELLS");
    // Each cell states at least its point count: more cells than values is a forged header, refused
    // before the cell list is reserved (2^40 cells made an "out of memory" that named no file).
    if (nCells > size)
        fail(path, "CELLS claims " + std::to_string(nCells) + " cells in " + std::to_string(size) +
                       " values (each cell needs at least its point count)");
    std::vector<double> data;
    cur.values(size, SampleType::Int32, "CELLS", &data);
    soup.offsets.assign(1, 0);
    soup.offsets.reserve(nCells + 1);
    soup.connectivity.reserve(size >= nCells ? size - nCells : 0);
    std::size_t p = 0;
    for (std::size_t c = 0; c < nCells; ++c) {
        if (p >= size)
            fail(path, "cell " + std::to_string(c) + ": CELLS data ends (size " + std::to_string(size) + ")");
        const double k = data[p++];
        if (!(k >= 0) || k > static_cast<double>(size - p))
            fail(path, "cell " + std::to_string(c) + ": point count " + io::formatDouble(k) +
                           " runs past the CELLS data");
        for (std::size_t i = 0; i < static_cast<std::size_t>(k); ++i)
            soup.connectivity.push_back(data[p++]);
        soup.offsets.push_back(static_cast<double>(soup.connectivity.size()));
    }
    if (p != size)
        fail(path, "CELLS size " + std::to_string(size) + " disagrees with its " + std::to_string(nCells) +
                       " cells (" + std::to_string(p) + " values used)");
    return nCells;
}

} // namespace

CellSoup readLegacyCells(const fs::path& path, const MeshReadOptions& options) {
    const std::vector<std::byte> bytes = readFileBytes(path);
    const std::string_view text = io::asText(bytes);
    const LegacyPreamble preamble = readPreamble(text, path);
    const bool binary = preamble.binary;
    LegacyCursor cur(text, binary, path);
    cur.seek(preamble.end);

    CellSoup soup;
    bool dataset = false, havePoints = false, haveCells = false, haveTypes = false;
    std::size_t nPoints = 0, nCells = 0;
    std::optional<bool> section; // POINT_DATA (true) or CELL_DATA (false), once seen
    std::size_t sectionCount = 0;
    std::vector<ArrayPlace> places;
    auto attribute = [&](std::string name, std::size_t comps, std::size_t count, SampleType st,
                         std::string type) {
        if (!section) fail(path, "attribute '" + name + "' outside POINT_DATA or CELL_DATA");
        soup.arrays.push_back({std::move(name), *section, static_cast<int>(comps), std::move(type)});
        places.push_back({cur.position(), count, st});
        cur.values(io::checkedByteCount(count, comps, path), st, "array '" + soup.arrays.back().name + "'",
                   nullptr);
    };
    while (true) {
        const auto w = cur.keywordLine();
        if (w.empty()) break;
        const std::string key = io::lower(w[0]);
        if (key == "dataset") {
            if (w.size() < 2 || !io::iequals(w[1], "unstructured_grid"))
                unsupported(path, "dataset " + (w.size() > 1 ? std::string(w[1]) : std::string("?")) +
                                      " is not UNSTRUCTURED_GRID");
            dataset = true;
        } else if (!dataset) {
            fail(path, "expected DATASET UNSTRUCTURED_GRID, found '" + std::string(w[0]) + "'");
        } else if (key == "points") {
            nPoints = requireCount(w, 1, path, "POINTS");
            const SampleType st = requireType(w, 2, path, "POINTS");
            std::vector<double> xyz;
            cur.values(io::checkedByteCount(nPoints, 3, path), st, "POINTS", &xyz);
            soup.points.resize(nPoints);
            for (std::size_t i = 0; i < nPoints; ++i)
                soup.points[i] = {xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]};
            havePoints = true;
        } else if (key == "cells") {
            nCells = preamble.version >= 5.0 ? readOffsetCells(cur, w, path, soup)
                                             : readCountedCells(cur, w, path, soup);
            haveCells = true;
        } else if (key == "cell_types") {
            const std::size_t n = requireCount(w, 1, path, "CELL_TYPES");
            if (!haveCells) fail(path, "CELL_TYPES before CELLS");
            if (n != nCells)
                fail(path,
                     "CELL_TYPES " + std::to_string(n) + " disagrees with CELLS " + std::to_string(nCells));
            cur.values(n, SampleType::Int32, "CELL_TYPES", &soup.types);
            haveTypes = true;
        } else if (key == "point_data" || key == "cell_data") {
            section = key == "point_data";
            sectionCount = requireCount(w, 1, path, w[0]);
            const std::size_t expect = *section ? nPoints : nCells;
            if (sectionCount != expect)
                fail(path, std::string(w[0]) + " " + std::to_string(sectionCount) + " disagrees with the " +
                               std::to_string(expect) + (*section ? " points" : " cells"));
        } else if (key == "scalars") {
            if (w.size() < 3) fail(path, "SCALARS needs a name and a type");
            const SampleType st = requireType(w, 2, path, "SCALARS");
            const std::size_t comps = w.size() >= 4 ? requireCount(w, 3, path, "SCALARS components") : 1;
            if (comps < 1 || comps > 4) fail(path, "SCALARS components must be 1 to 4");
            // The LOOKUP_TABLE line is optional in practice.
            const std::size_t save = cur.position();
            const auto lt = cur.keywordLine();
            if (lt.empty() || !io::iequals(lt[0], "lookup_table")) cur.seek(save);
            attribute(std::string(w[1]), comps, sectionCount, st, std::string(w[2]));
        } else if (key == "vectors" || key == "normals" || key == "tensors" || key == "tensors6") {
            if (w.size() < 3) fail(path, std::string(w[0]) + " needs a name and a type");
            const std::size_t comps = key == "tensors" ? 9 : key == "tensors6" ? 6 : 3;
            attribute(std::string(w[1]), comps, sectionCount, requireType(w, 2, path, w[0]),
                      std::string(w[2]));
        } else if (key == "texture_coordinates") {
            if (w.size() < 4) fail(path, "TEXTURE_COORDINATES needs a name, a dimension and a type");
            const std::size_t dim = requireCount(w, 2, path, "TEXTURE_COORDINATES");
            if (dim < 1 || dim > 3) fail(path, "TEXTURE_COORDINATES dimension must be 1 to 3");
            attribute(std::string(w[1]), dim, sectionCount, requireType(w, 3, path, w[0]), std::string(w[3]));
        } else if (key == "color_scalars") {
            const std::size_t n = requireCount(w, 2, path, "COLOR_SCALARS");
            if (n < 1 || n > 4) fail(path, "COLOR_SCALARS needs 1 to 4 values");
            attribute(std::string(w[1]), n, sectionCount, binary ? SampleType::UInt8 : SampleType::Float32,
                      "color");
        } else if (key == "lookup_table") {
            const std::size_t n = requireCount(w, 2, path, "LOOKUP_TABLE");
            cur.values(io::checkedByteCount(n, 4, path), binary ? SampleType::UInt8 : SampleType::Float32,
                       "LOOKUP_TABLE", nullptr);
        } else if (key == "field") {
            const std::size_t n = requireCount(w, 2, path, "FIELD");
            for (std::size_t a = 0; a < n; ++a) {
                const auto fw = cur.keywordLine();
                if (fw.size() < 4)
                    fail(path, "FIELD array " + std::to_string(a) + " needs name, components, tuples, type");
                const std::size_t comps = requireCount(fw, 1, path, "FIELD components");
                const std::size_t tuples = requireCount(fw, 2, path, "FIELD tuples");
                const SampleType st = requireType(fw, 3, path, "FIELD");
                if (section && tuples == sectionCount && comps >= 1) {
                    attribute(std::string(fw[0]), comps, tuples, st, std::string(fw[3]));
                } else {
                    cur.values(io::checkedByteCount(tuples, comps, path), st, "FIELD array", nullptr);
                }
            }
        } else if (key == "metadata") {
            cur.skipMetadata();
        } else {
            fail(path, "unexpected line '" + std::string(w[0].substr(0, 40)) + "'");
        }
    }
    if (!dataset) fail(path, "no DATASET line");
    if (!havePoints) fail(path, "no POINTS (truncated?)");
    if (!haveCells) fail(path, "no CELLS (truncated?)");
    if (!haveTypes) fail(path, "no CELL_TYPES (truncated?)");

    const std::size_t k = chooseScalarArray(soup.arrays, options.array, path);
    soup.valuesName = soup.arrays[k].name;
    soup.valuesOnPoints = soup.arrays[k].pointData;
    cur.seek(places[k].pos);
    cur.values(places[k].count, places[k].type, "array '" + soup.valuesName + "'", &soup.values);
    return soup;
}

} // namespace volcl::mesh::detail
