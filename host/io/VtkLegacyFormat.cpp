// Legacy VTK STRUCTURED_POINTS (.vtk): ASCII or BINARY (big-endian) SCALARS point data.
#include "core/AtomicFile.hpp"
#include "host/io/IoDetail.hpp"

#include <cctype>

namespace volcl::io {

namespace fs = std::filesystem;

namespace {

// Keywords that may follow the scalars (further attributes); anything else after the data is garbage.
bool startsWithSectionKeyword(std::string_view s) {
    static const std::string_view keywords[] = {
        "scalars",    "vectors",       "normals",      "tensors", "texture_coordinates", "field", "cell_data",
        "point_data", "color_scalars", "lookup_table", "metadata"};
    const auto words = splitWords(s.substr(0, 64));
    if (words.empty()) return false;
    for (std::string_view k : keywords)
        if (iequals(words[0], k)) return true;
    return false;
}

} // namespace

TimeSeries readVtkLegacy(ReadContext& ctx) {
    const fs::path& path = ctx.file();
    const std::vector<std::byte> bytes = readFileBytes(path);
    const std::string_view text = asText(bytes);
    std::size_t pos = 0;
    auto line1 = nextLine(text, pos);
    if (!line1 || !line1->starts_with("# vtk DataFile Version"))
        fail(path, "not a legacy VTK file (bad first line)");
    if (!nextLine(text, pos)) fail(path, "truncated: no title line");
    auto modeLine = nextLine(text, pos);
    while (modeLine && trim(*modeLine).empty())
        modeLine = nextLine(text, pos); // some writers leave a blank line
    if (!modeLine) fail(path, "truncated: no ASCII/BINARY line");
    const std::string mode = lower(trim(*modeLine));
    if (mode != "ascii" && mode != "binary")
        fail(path,
             "third line must be ASCII or BINARY, not '" + std::string(trim(*modeLine).substr(0, 30)) + "'");
    const bool binary = mode == "binary";

    std::optional<Dims> dims;
    std::array<double, 3> spacing{1, 1, 1}, origin{0, 0, 0};
    bool datasetSeen = false;
    std::optional<std::size_t> pointCount;
    std::optional<SampleType> st;
    std::string scalarName;
    while (auto line = nextLine(text, pos)) {
        // A header line without its newline means the file was cut inside the header.
        if (text[pos - 1] != '\n') fail(path, "truncated inside the header");
        const auto w = splitWords(*line);
        if (w.empty()) continue;
        const std::string key = lower(w[0]);
        if (key == "dataset") {
            if (w.size() < 2 || !iequals(w[1], "structured_points"))
                unsupported(path, "dataset " + (w.size() > 1 ? std::string(w[1]) : std::string("?")) +
                                      " is not STRUCTURED_POINTS (a regular grid)");
            datasetSeen = true;
        } else if (key == "dimensions") {
            dims = requireDims(w, 1, 3, path, "DIMENSIONS");
        } else if (key == "spacing" || key == "aspect_ratio") {
            spacing = requireTriple(w, 1, path, "SPACING", true);
        } else if (key == "origin") {
            origin = requireTriple(w, 1, path, "ORIGIN", false);
        } else if (key == "cell_data") {
            unsupported(path, "CELL_DATA before POINT_DATA: only point scalars are supported");
        } else if (key == "point_data") {
            if (w.size() < 2) fail(path, "POINT_DATA needs a count");
            const long long n = requireInt(w[1], path, "POINT_DATA");
            if (n <= 0) fail(path, "POINT_DATA count must be positive");
            pointCount = static_cast<std::size_t>(n);
        } else if (key == "scalars") {
            if (!pointCount) unsupported(path, "SCALARS outside POINT_DATA");
            if (w.size() < 3) fail(path, "SCALARS needs a name and a type");
            scalarName = std::string(w[1]);
            st = vtkLegacyType(w[2]);
            if (!st) unsupported(path, "SCALARS type '" + std::string(w[2]) + "' is not supported");
            if (w.size() >= 4 && requireInt(w[3], path, "SCALARS components") != 1)
                unsupported(path,
                            "SCALARS with " + std::string(w[3]) + " components: only scalars are supported");
            // LOOKUP_TABLE is optional in practice; the data starts after it when present.
            std::size_t peek = pos;
            if (auto next = nextLine(text, peek); next && iequals(trim(*next).substr(0, 12), "lookup_table"))
                pos = peek;
            break;
        } else if (pointCount) {
            unsupported(path, "point data attribute '" + std::string(w[0]) +
                                  "' precedes SCALARS: only SCALARS is supported");
        } else if (key != "field") {
            fail(path, "unexpected line '" + std::string(line->substr(0, 40)) + "'");
        } else {
            unsupported(path, "FIELD data before the point data is not supported");
        }
    }
    if (!datasetSeen) fail(path, "no DATASET line (truncated or not a volume)");
    if (!dims) fail(path, "no DIMENSIONS line");
    if (!st) fail(path, "no SCALARS point data (truncated?)");
    const std::size_t voxels = ctx.voxelCount(*dims, 1, *st);
    if (*pointCount != voxels)
        fail(path, "POINT_DATA " + std::to_string(*pointCount) + " does not match DIMENSIONS (" +
                       std::to_string(voxels) + " points)");

    std::size_t after = 0;
    Volume v;
    if (binary) {
        const std::size_t need = checkedByteCount(voxels, sampleSize(*st), path);
        if (bytes.size() - pos < need)
            fail(path, "truncated: " + std::to_string(bytes.size() - pos) + " data bytes, SCALARS need " +
                           std::to_string(need));
        v = Volume(*dims, volumeTypeFor(*st));
        decodeSamples(std::span<const std::byte>(bytes).subspan(pos, need), *st, Endian::Big, v);
        after = pos + need;
    } else {
        // Find the end of the first `voxels` tokens, then parse exactly those.
        std::size_t p = pos, count = 0;
        while (count < voxels) {
            while (p < text.size() && std::isspace(static_cast<unsigned char>(text[p])))
                ++p;
            if (p >= text.size()) break;
            while (p < text.size() && !std::isspace(static_cast<unsigned char>(text[p])))
                ++p;
            ++count;
        }
        if (count < voxels)
            fail(path, "truncated: " + std::to_string(count) + " ASCII values, SCALARS need " +
                           std::to_string(voxels));
        v = Volume(*dims, volumeTypeFor(*st));
        decodeAsciiSamples(text.substr(pos, p - pos), *st, v, 0, voxels, path);
        after = p;
    }
    v.spacing = spacing;
    v.origin = origin;
    const std::string_view rest = trim(text.substr(after));
    if (!rest.empty() && !startsWithSectionKeyword(rest))
        fail(path,
             "oversized: " + std::to_string(text.size() - after) + " unexpected bytes after the scalars");
    TimeSeries series;
    series.frames.push_back(std::move(v));
    return series;
}

} // namespace volcl::io
