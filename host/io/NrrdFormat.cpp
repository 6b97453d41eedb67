// NRRD (.nrrd attached / .nhdr detached): raw, gzip and ascii encodings, data file patterns; writer.
#include "core/AtomicFile.hpp"
#include "core/Channels.hpp"
#include "host/io/IoDetail.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <map>
#include <optional>
#include <random>
#include <string_view>

#include <signal.h>
#include <unistd.h>

namespace volcl::io {

namespace fs = std::filesystem;

namespace {

std::optional<SampleType> nrrdType(std::string_view name) {
    static const std::map<std::string, SampleType> types = {
        {"signed char", SampleType::Int8},
        {"int8", SampleType::Int8},
        {"int8_t", SampleType::Int8},
        {"uchar", SampleType::UInt8},
        {"unsigned char", SampleType::UInt8},
        {"uint8", SampleType::UInt8},
        {"uint8_t", SampleType::UInt8},
        {"short", SampleType::Int16},
        {"short int", SampleType::Int16},
        {"signed short", SampleType::Int16},
        {"signed short int", SampleType::Int16},
        {"int16", SampleType::Int16},
        {"int16_t", SampleType::Int16},
        {"ushort", SampleType::UInt16},
        {"unsigned short", SampleType::UInt16},
        {"unsigned short int", SampleType::UInt16},
        {"uint16", SampleType::UInt16},
        {"uint16_t", SampleType::UInt16},
        {"int", SampleType::Int32},
        {"signed int", SampleType::Int32},
        {"int32", SampleType::Int32},
        {"int32_t", SampleType::Int32},
        {"uint", SampleType::UInt32},
        {"unsigned int", SampleType::UInt32},
        {"uint32", SampleType::UInt32},
        {"uint32_t", SampleType::UInt32},
        {"longlong", SampleType::Int64},
        {"long long", SampleType::Int64},
        {"long long int", SampleType::Int64},
        {"signed long long", SampleType::Int64},
        {"signed long long int", SampleType::Int64},
        {"int64", SampleType::Int64},
        {"int64_t", SampleType::Int64},
        {"ulonglong", SampleType::UInt64},
        {"unsigned long long", SampleType::UInt64},
        {"unsigned long long int", SampleType::UInt64},
        {"uint64", SampleType::UInt64},
        {"uint64_t", SampleType::UInt64},
        {"float", SampleType::Float32},
        {"double", SampleType::Float64},
    };
    std::string key;
    for (std::string_view w : splitWords(name)) {
        if (!key.empty()) key.push_back(' ');
        key.append(lower(w));
    }
    auto it = types.find(key);
    if (it == types.end()) return std::nullopt;
    return it->second;
}

// "(1.5,0,0)" -> {1.5, 0, 0}; "none" -> nullopt.
std::optional<std::array<double, 3>> parseVector(std::string_view token, const fs::path& file,
                                                 std::string_view what) {
    token = trim(token);
    if (iequals(token, "none")) return std::nullopt;
    if (token.size() < 2 || token.front() != '(' || token.back() != ')')
        fail(file,
             std::string(what) + ": '" + std::string(token.substr(0, 60)) + "' is not a (x,y,z) vector");
    token = token.substr(1, token.size() - 2);
    std::array<double, 3> v{};
    std::size_t i = 0;
    while (true) {
        const std::size_t comma = token.find(',');
        if (i >= 3) fail(file, std::string(what) + ": only 3D space vectors are supported");
        v[i++] = requireDouble(token.substr(0, comma), file, what);
        if (!std::isfinite(v[i - 1])) fail(file, std::string(what) + ": non-finite component");
        if (comma == std::string_view::npos) break;
        token.remove_prefix(comma + 1);
    }
    if (i != 3) fail(file, std::string(what) + ": only 3D space vectors are supported");
    return v;
}

// Vector-valued tokens like "(1,0,0) (0,1,0) none" may contain spaces inside parentheses.
std::vector<std::string> splitVectors(std::string_view s) {
    std::vector<std::string> out;
    std::string cur;
    int depth = 0;
    for (char c : s) {
        if (c == '(') ++depth;
        if (c == ')') --depth;
        if ((c == ' ' || c == '\t') && depth == 0) {
            if (!cur.empty()) out.push_back(cur);
            cur.clear();
        } else if (c != ' ' && c != '\t') {
            cur += c;
        }
    }
    if (!cur.empty()) out.push_back(cur);
    return out;
}

// Axis kinds that make a sample non-scalar (vectors, colours, tensors).
const char* const kNonScalarKinds[] = {"vector",
                                       "covariant-vector",
                                       "normal",
                                       "complex",
                                       "2-vector",
                                       "3-color",
                                       "rgb-color",
                                       "hsv-color",
                                       "xyz-color",
                                       "4-color",
                                       "rgba-color",
                                       "3-vector",
                                       "3-gradient",
                                       "3-normal",
                                       "4-vector",
                                       "quaternion",
                                       "2d-symmetric-matrix",
                                       "2d-masked-symmetric-matrix",
                                       "2d-matrix",
                                       "2d-masked-matrix",
                                       "3d-symmetric-matrix",
                                       "3d-masked-symmetric-matrix",
                                       "3d-matrix",
                                       "3d-masked-matrix"};

// The header's fields (keys lower-case, "datafile" stored as "data file"), the names listed after
// "data file: LIST", and where the attached data starts.
struct NrrdHeader {
    std::map<std::string, std::string> fields;
    std::vector<std::string> listFiles;
    bool blankLineSeen = false;
    std::size_t dataStart = 0;

    std::optional<std::string> field(const std::string& key) const {
        auto it = fields.find(key);
        if (it == fields.end()) return std::nullopt;
        return it->second;
    }
    std::string require(const std::string& key, const fs::path& path) const {
        auto v = field(key);
        if (!v) fail(path, "header has no '" + key + "' field (truncated or not a volume)");
        return *v;
    }
};

NrrdHeader parseNrrdHeader(std::string_view text, const fs::path& path) {
    std::size_t pos = 0;
    auto magic = nextLine(text, pos);
    if (!magic || !magic->starts_with("NRRD000") || magic->size() != 8)
        fail(path, "not a NRRD file (no NRRD000x magic line)");
    // Versions 1 to 5 are the ones the NRRD format defines; anything else is not a file we understand.
    if ((*magic)[7] < '1' || (*magic)[7] > '5')
        fail(path, "unsupported NRRD version '" + std::string(*magic) + "' (NRRD0001 to NRRD0005 are read)");

    NrrdHeader h;
    bool listMode = false;
    while (auto line = nextLine(text, pos)) {
        if (listMode) {
            const std::string_view name = trim(*line);
            if (name.empty()) break;
            h.listFiles.emplace_back(name);
            continue;
        }
        if (line->empty()) {
            h.blankLineSeen = true;
            break;
        }
        if (line->front() == '#') continue;
        if (line->find(":=") != std::string_view::npos) continue; // key/value pairs carry no geometry
        const std::size_t colon = line->find(": ");
        if (colon == std::string_view::npos)
            fail(path, "malformed header line '" + std::string(line->substr(0, 60)) + "'");
        const std::string key = lower(trim(line->substr(0, colon)));
        const std::string value(trim(line->substr(colon + 2)));
        if (key.size() > 64 || value.size() > 100000) fail(path, "header line too long");
        h.fields[key == "datafile" ? "data file" : key] = value;
        if (key == "data file" || key == "datafile") {
            const auto w = splitWords(value);
            listMode = !w.empty() && w[0] == "LIST";
        }
    }
    // Structure before content: a cut header must read as truncated, not as an odd field value.
    if (!h.fields.contains("data file") && !h.blankLineSeen)
        fail(path, "truncated: header does not end with a blank line and names no data file");
    h.dataStart = pos;
    return h;
}

PayloadEncoding nrrdEncoding(const NrrdHeader& h, const fs::path& path) {
    const std::string encodingName = lower(h.require("encoding", path));
    if (encodingName == "raw") return PayloadEncoding::Raw;
    if (encodingName == "gzip" || encodingName == "gz") return PayloadEncoding::Compressed;
    if (encodingName == "ascii" || encodingName == "text" || encodingName == "txt")
        return PayloadEncoding::Ascii;
    unsupported(path, "encoding '" + encodingName + "' is not supported (raw, gzip, ascii)");
}

struct Geometry {
    std::array<double, 3> spacing{1, 1, 1}, origin{0, 0, 0};
    Direction3 direction = kIdentityDirection; ///< origin and direction in RAS when the space is anatomical
    bool anatomical = false;

    void applyTo(TimeSeries& series) const {
        for (Volume& v : series.frames) {
            v.direction = direction;
            v.anatomical = anatomical;
        }
    }
};

// Signs that turn an anatomical `space` into RAS (LPS: x and y flip), or nullopt for a space that is not
// patient-based (scanner-xyz, 3D-right-handed, ...), whose directions are kept as given.
std::optional<std::array<double, 3>> rasSigns(std::string_view space) {
    std::string s = lower(trim(space));
    if (s.size() > 5 && s.compare(s.size() - 5, 5, "-time") == 0) s.resize(s.size() - 5);
    if (s == "right-anterior-superior" || s == "ras") return std::array<double, 3>{1, 1, 1};
    if (s == "left-anterior-superior" || s == "las") return std::array<double, 3>{-1, 1, 1};
    if (s == "left-posterior-superior" || s == "lps") return std::array<double, 3>{-1, -1, 1};
    return std::nullopt;
}

// Spacings or space directions (their lengths), space origin or axis mins.
Geometry nrrdGeometry(const NrrdHeader& h, long long dimension, const std::array<std::size_t, 4>& sizes,
                      const fs::path& path) {
    Geometry g;
    if (auto sp = h.field("spacings")) {
        const auto w = splitWords(*sp);
        for (std::size_t i = 0; i < w.size() && i < 3; ++i) {
            const double v = requireDouble(w[i], path, "spacings");
            if (!std::isfinite(v) || v == 0)
                fail(path, "spacings: value " + std::string(w[i]) + " is not a non-zero finite number");
            g.spacing[i] = std::abs(v);
        }
    }
    std::optional<std::array<double, 3>> signs;
    if (auto space = h.field("space")) signs = rasSigns(*space);
    g.anatomical = signs.has_value();
    const std::array<double, 3> toRas = signs.value_or(std::array<double, 3>{1, 1, 1});
    for (int a = 0; a < 3; ++a)
        g.direction[std::size_t(4 * a)] = toRas[std::size_t(a)];
    if (auto dirs = h.field("space directions")) {
        const auto vecs = splitVectors(*dirs);
        Direction3 m = g.direction;
        if (vecs.size() != static_cast<std::size_t>(dimension))
            fail(path, "'space directions' has " + std::to_string(vecs.size()) + " entries for dimension " +
                           std::to_string(dimension));
        for (std::size_t i = 0; i < 3 && i < vecs.size(); ++i) {
            if (auto v = parseVector(vecs[i], path, "space directions")) {
                // hypot: squaring underflowed 1e-200 to a length of 0 (then read as spacing 1).
                const double len = std::hypot((*v)[0], (*v)[1], (*v)[2]);
                if (!std::isfinite(len) || !(len > 0))
                    fail(path, "space directions: axis " + std::to_string(i) + " has length " +
                                   formatDouble(len) + ", not a positive finite spacing");
                g.spacing[i] = len;
                for (std::size_t row = 0; row < 3; ++row)
                    m[3 * row + i] = toRas[row] * (*v)[row] / len;
            } else if (sizes[i] > 1) {
                unsupported(path,
                            "axis " + std::to_string(i) +
                                " is not spatial ('none' direction): only scalar volumes are supported");
            }
        }
        try {
            g.direction = orthonormalDirection(m);
        } catch (const DataError& e) {
            fail(path, std::string("space directions: ") + e.what());
        }
    }
    if (auto o = h.field("space origin")) {
        if (auto v = parseVector(*o, path, "space origin"))
            for (std::size_t a = 0; a < 3; ++a)
                g.origin[a] = toRas[a] * (*v)[a]; // an LPS origin in RAS, like the directions
    } else if (auto mins = h.field("axis mins")) {
        const auto w = splitWords(*mins);
        for (std::size_t i = 0; i < w.size() && i < 3; ++i) {
            const double v = requireDouble(w[i], path, "axis mins");
            if (!std::isfinite(v)) fail(path, "axis mins: value " + std::string(w[i]) + " is not finite");
            g.origin[i] = v;
        }
    }
    return g;
}

// The files named by "data file": one name, LIST (the names after the header) or a printf pattern with
// min, max, step and an optional subdim that must match the file count.
std::vector<fs::path> nrrdDataFiles(ReadContext& ctx, const NrrdHeader& h, std::string_view dataFile,
                                    long long dimension, const std::array<std::size_t, 4>& sizes,
                                    std::size_t evenlyHeldBytes) {
    const fs::path& path = ctx.file();
    const auto w = splitWords(dataFile);
    std::vector<fs::path> files;
    if (w.empty()) fail(path, "empty 'data file' field");
    if (w[0] == "LIST") {
        for (const std::string& f : h.listFiles)
            files.push_back(ctx.dataFile(f));
        return files;
    }
    if (w.size() < 4) {
        files.push_back(ctx.dataFile(dataFile));
        return files;
    }
    const Dims dims{sizes[0], sizes[1], sizes[2]};
    const auto names = expandFilePattern(
        w[0], requireInt(w[1], path, "data file min"), requireInt(w[2], path, "data file max"),
        requireInt(w[3], path, "data file step"), path, maxDataFiles(dims, sizes[3]), evenlyHeldBytes);
    for (const std::string& n : names)
        files.push_back(ctx.dataFile(n));
    if (w.size() >= 5) {
        const long long subdim = requireInt(w[4], path, "data file subdim");
        std::size_t expectFiles = 1;
        for (long long a = subdim; a < dimension && a >= 0; ++a)
            expectFiles *= sizes[a];
        if (subdim < 1 || subdim > dimension || expectFiles != files.size())
            fail(path, "data file subdim " + std::to_string(subdim) + " does not match " +
                           std::to_string(files.size()) + " files");
    }
    return files;
}

// The data after the header of an attached .nrrd: `lineSkip` lines, then `byteSkip` bytes (-1: the data
// sits at the end of the file) before `payload` raw bytes, gzip data or ascii text.
std::vector<std::byte> attachedPayload(std::span<const std::byte> bytes, const NrrdHeader& h,
                                       std::size_t payload, PayloadEncoding encoding, long long byteSkip,
                                       std::size_t lineSkip, const fs::path& path) {
    if (!h.blankLineSeen)
        fail(path, "truncated: header does not end with a blank line and names no data file");
    const std::string_view text = asText(bytes);
    std::size_t pos = h.dataStart;
    for (std::size_t l = 0; l < lineSkip; ++l)
        if (!nextLine(text, pos)) fail(path, "truncated: fewer lines than 'line skip'");
    std::span<const std::byte> rest = bytes.subspan(pos);
    if (encoding == PayloadEncoding::Compressed) {
        std::vector<std::byte> data =
            inflateExact(rest, payload + static_cast<std::size_t>(byteSkip), path, "gzip data");
        data.erase(data.begin(), data.begin() + byteSkip);
        return data;
    }
    if (encoding == PayloadEncoding::Raw) {
        if (byteSkip == -1) {
            if (rest.size() < payload)
                fail(path, "truncated: " + std::to_string(rest.size()) + " data bytes, expected " +
                               std::to_string(payload));
            rest = rest.subspan(rest.size() - payload);
        } else {
            const std::size_t need = payload + static_cast<std::size_t>(byteSkip);
            if (rest.size() < need)
                fail(path, "truncated: " + std::to_string(rest.size()) + " data bytes, expected " +
                               std::to_string(need));
            if (rest.size() > need)
                fail(path, "oversized: " + std::to_string(rest.size() - need) + " bytes after the data");
            rest = rest.subspan(static_cast<std::size_t>(byteSkip));
        }
    }
    return {rest.begin(), rest.end()};
}

// Ascii samples of every frame, parsed once through a flat volume holding all frames.
TimeSeries asciiFrames(std::string_view asciiText, SampleType st, const Dims& dims, std::size_t frames,
                       std::size_t voxels, const Geometry& g, const fs::path& path) {
    TimeSeries series;
    requireAsciiCapacity(asciiText, voxels, path);
    const std::size_t frameVoxels = dims.count();
    Volume all(Dims{dims.x, dims.y, dims.z * frames}, volumeTypeFor(st));
    decodeAsciiSamples(asciiText, st, all, 0, voxels, path);
    for (std::size_t f = 0; f < frames; ++f) {
        Volume v(dims, all.type());
        const std::size_t b = frameVoxels * scalarSize(all.type());
        std::copy_n(all.bytes().begin() + static_cast<std::ptrdiff_t>(f * b), b, v.bytes().begin());
        v.spacing = g.spacing;
        v.origin = g.origin;
        series.frames.push_back(std::move(v));
    }
    return series;
}

// The kind of axis 0 when it holds a voxel's components (vector, RGB-color, ...) of a 4D header, else empty.
std::string componentAxisKind(const NrrdHeader& h, long long dimension) {
    if (dimension != 4) return {};
    const auto kinds = h.field("kinds");
    if (!kinds) return {};
    const auto k = splitWords(*kinds);
    if (k.empty()) return {};
    for (const char* kind : kNonScalarKinds)
        if (iequals(k[0], kind)) return std::string(k[0]);
    return {};
}

// The header without its axis 0 (the component axis): per-axis fields lose their first entry.
NrrdHeader withoutFirstAxis(NrrdHeader h) {
    // Entries 1.. of a field's list, joined by spaces.
    auto dropFirst = [](const auto& entries) {
        std::string rest;
        for (std::size_t i = 1; i < entries.size(); ++i) {
            if (i > 1) rest += ' ';
            rest += entries[i];
        }
        return rest;
    };
    for (const char* key :
         {"sizes", "spacings", "axis mins", "axis maxs", "kinds", "centers", "centerings", "thicknesses"})
        if (auto it = h.fields.find(key); it != h.fields.end())
            it->second = dropFirst(splitWords(it->second));
    if (auto it = h.fields.find("space directions"); it != h.fields.end())
        it->second = dropFirst(splitVectors(it->second));
    h.fields.erase("labels");
    h.fields.erase("units");
    h.fields["dimension"] = "3";
    return h;
}

} // namespace

TimeSeries readNrrd(ReadContext& ctx) {
    const fs::path& path = ctx.file();
    const std::vector<std::byte> bytes = readFileBytes(path);
    const NrrdHeader full = parseNrrdHeader(asText(bytes), path);
    const long long fullDimension = requireInt(full.require("dimension", path), path, "dimension");
    // A leading component axis (kinds: vector, RGB-color, ...) becomes channels; the rest is a 3D header.
    const std::string componentKind = componentAxisKind(full, fullDimension);
    std::size_t components = 1;
    if (!componentKind.empty()) components = requireSizes(full.require("sizes", path), 4, path, "sizes")[0];
    requireChannelsWanted(ctx, components, componentKind);
    const NrrdHeader h = componentKind.empty() ? full : withoutFirstAxis(full);

    const long long dimension = requireInt(h.require("dimension", path), path, "dimension");
    if (dimension < 1 || dimension > 4)
        unsupported(path, "dimension " + std::to_string(dimension) + " (1 to 4 supported)");
    const std::string typeName = h.require("type", path);
    const auto st = nrrdType(typeName);
    if (!st) unsupported(path, "type '" + typeName + "' is not supported");
    const auto sizes =
        requireSizes(h.require("sizes", path), static_cast<std::size_t>(dimension), path, "sizes");
    if (auto kinds = h.field("kinds")) {
        const auto k = splitWords(*kinds);
        for (std::size_t i = 0; i < k.size() && i < 3; ++i)
            for (const char* bad : kNonScalarKinds)
                if (iequals(k[i], bad))
                    unsupported(path, "axis " + std::to_string(i) + " has kind '" + std::string(k[i]) +
                                          "': only scalar volumes are supported");
    }
    const Dims dims{sizes[0], sizes[1], sizes[2]};
    const std::size_t frames = sizes[3] * components; // components: one frame of interleaved samples
    const std::size_t voxels = ctx.voxelCount(dims, frames, *st);
    const std::size_t payload = checkedByteCount(voxels, sampleSize(*st), path);

    Endian endian = Endian::Little;
    if (auto e = h.field("endian")) {
        if (iequals(*e, "big"))
            endian = Endian::Big;
        else if (!iequals(*e, "little"))
            fail(path, "endian '" + *e + "' is neither little nor big");
    }
    const PayloadEncoding encoding = nrrdEncoding(h, path);
    const Geometry g = nrrdGeometry(h, dimension, sizes, path);

    long long byteSkip = 0;
    std::size_t lineSkip = 0;
    if (auto b = h.field("byte skip")) byteSkip = requireInt(*b, path, "byte skip");
    if (auto l = h.field("line skip")) {
        const long long v = requireInt(*l, path, "line skip");
        if (v < 0) fail(path, "line skip must not be negative");
        lineSkip = static_cast<std::size_t>(v);
    }
    if (byteSkip < -1) fail(path, "byte skip must be -1 or more");
    if (byteSkip == -1 && encoding != PayloadEncoding::Raw)
        fail(path, "byte skip -1 is only valid for raw encoding");

    std::vector<std::byte> data;
    if (auto df = h.field("data file")) {
        const std::vector<fs::path> files =
            nrrdDataFiles(ctx, h, *df, dimension, sizes, encoding == PayloadEncoding::Ascii ? 0 : payload);
        if (files.size() > voxels) fail(path, "more data files than voxels");
        data = readDetachedPayload(path, files, payload, encoding, byteSkip, lineSkip);
    } else {
        data = attachedPayload(bytes, h, payload, encoding, byteSkip, lineSkip, path);
    }
    if (components > 1) {
        // Interleaved components decode as one frame {components, nx * ny, nz}, then split per channel.
        const Dims packed{components, dims.x * dims.y, dims.z};
        TimeSeries whole = encoding == PayloadEncoding::Ascii
                               ? asciiFrames(asText(data), *st, packed, 1, voxels, g, path)
                               : decodeFrames(data, *st, endian, packed, 1, g.spacing, g.origin);
        Volume grid(dims, ScalarType::UInt8);
        grid.spacing = g.spacing;
        grid.origin = g.origin;
        grid.direction = g.direction;
        grid.anatomical = g.anatomical;
        const bool color = iequals(componentKind, "RGB-color") || iequals(componentKind, "RGBA-color");
        return channelsAsRequested(splitInterleaved(whole.frames.front(), components, grid), ctx,
                                   componentKind, color);
    }
    TimeSeries series = encoding == PayloadEncoding::Ascii
                            ? asciiFrames(asText(data), *st, dims, frames, voxels, g, path)
                            : decodeFrames(data, *st, endian, dims, frames, g.spacing, g.origin);
    g.applyTo(series);
    return series;
}

std::optional<SlabLayout> nrrdSlabLayout(ReadContext& ctx) {
    const fs::path& path = ctx.file();
    // The header is text before the data: 1 MiB holds any header a writer makes; a longer one is read whole.
    constexpr std::size_t kHeaderPrefix = std::size_t(1) << 20;
    const std::vector<std::byte> prefix = readFilePrefix(path, kHeaderPrefix, false);
    const NrrdHeader h = parseNrrdHeader(asText(prefix), path);
    if (!h.fields.contains("data file") && (!h.blankLineSeen || h.dataStart >= prefix.size()) &&
        prefix.size() == kHeaderPrefix)
        return std::nullopt;
    const long long dimension = requireInt(h.require("dimension", path), path, "dimension");
    if (dimension != 3) return std::nullopt;
    const auto st = nrrdType(h.require("type", path));
    if (!st) return std::nullopt;
    const auto sizes = requireSizes(h.require("sizes", path), 3, path, "sizes");
    if (auto kinds = h.field("kinds"))
        for (const auto k : splitWords(*kinds))
            for (const char* bad : kNonScalarKinds)
                if (iequals(k, bad)) return std::nullopt;
    const PayloadEncoding encoding = nrrdEncoding(h, path);
    if (encoding == PayloadEncoding::Ascii || h.field("line skip")) return std::nullopt;
    SlabLayout l;
    l.sampleType = *st;
    l.dims = {sizes[0], sizes[1], sizes[2]};
    if (auto e = h.field("endian")) {
        if (iequals(*e, "big"))
            l.endian = Endian::Big;
        else if (!iequals(*e, "little"))
            fail(path, "endian '" + *e + "' is neither little nor big");
    }
    const Geometry g = nrrdGeometry(h, dimension, sizes, path);
    l.spacing = g.spacing;
    l.origin = g.origin;
    l.direction = g.direction;
    l.anatomical = g.anatomical;
    long long byteSkip = 0;
    if (auto b = h.field("byte skip")) byteSkip = requireInt(*b, path, "byte skip");
    if (byteSkip < -1) fail(path, "byte skip must be -1 or more");
    if (byteSkip == -1 && encoding != PayloadEncoding::Raw)
        fail(path, "byte skip -1 is only valid for raw encoding");
    l.gzip = encoding == PayloadEncoding::Compressed;
    const std::size_t payload = checkedByteCount(checkedVoxelCount(l.dims, 1, path), sampleSize(*st), path);
    if (auto df = h.field("data file")) {
        const auto w = splitWords(*df);
        if (w.size() != 1 || w[0] == "LIST") return std::nullopt; // several files: read whole
        l.dataFile = ctx.dataFile(*df);
    } else {
        if (!h.blankLineSeen)
            fail(path, "truncated: header does not end with a blank line and names no data file");
        l.dataFile = path;
        l.fileOffset = h.dataStart;
    }
    if (l.gzip) {
        l.skip = std::uint64_t(byteSkip);
        return l;
    }
    std::error_code ec;
    const std::uintmax_t size = fs::file_size(l.dataFile, ec);
    if (ec) fail(path, "cannot determine the data size: " + ec.message());
    const std::uint64_t rest = size - std::min<std::uint64_t>(size, l.fileOffset);
    if (byteSkip == -1) {
        if (rest < payload)
            fail(path,
                 "truncated: " + std::to_string(rest) + " data bytes, expected " + std::to_string(payload));
        l.fileOffset = size - payload;
        return l;
    }
    const std::uint64_t need = payload + std::uint64_t(byteSkip);
    if (rest < need)
        fail(path, "truncated: " + std::to_string(rest) + " data bytes, expected " + std::to_string(need));
    if (rest > need) fail(path, "oversized: " + std::to_string(rest - need) + " bytes after the data");
    l.fileOffset += std::uint64_t(byteSkip);
    return l;
}

namespace {

constexpr std::string_view kWrittenByVolcl = "NRRD0004\n# written by volcl;";

// The part of a detached header's name its data files repeat: the name without `.nhdr`, cut so that
// `STEM.<16 hex>.raw` stays within NAME_MAX (255 bytes).
std::string dataStem(const fs::path& header) {
    std::string stem = header.filename().string();
    stem.resize(stem.size() - std::min<std::size_t>(stem.size(), 5)); // ".nhdr"
    if (stem.size() > 234) stem.resize(234);
    return stem;
}

// `STEM.<8 hex digits of the writer's PID><8 random hex digits>.raw` beside the header: every run's data
// file has its own name, and the PID tells whether its writer can still move a header naming it in.
fs::path uniqueDataPath(const fs::path& header) {
    static constexpr char kHex[] = "0123456789abcdef";
    std::random_device rd;
    const std::uint64_t r = (std::uint64_t(static_cast<std::uint32_t>(::getpid())) << 32) | rd();
    std::string name = dataStem(header) + ".";
    for (int shift = 60; shift >= 0; shift -= 4)
        name += kHex[(r >> shift) & 15];
    name += ".raw";
    return header.parent_path() / name;
}

// The writer's PID in a data file name of the unique form, 0 when `name` does not have that form.
pid_t dataFileWriter(const fs::path& header, const std::string& name) {
    const std::string stem = dataStem(header);
    if (name.size() != stem.size() + 21 || !name.starts_with(stem + ".") || !name.ends_with(".raw")) return 0;
    std::uint64_t pid = 0;
    for (std::size_t i = stem.size() + 1; i < stem.size() + 17; ++i) {
        const char c = name[i];
        if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return 0;
        if (i < stem.size() + 9)
            pid = pid * 16 + static_cast<std::uint64_t>(c <= '9' ? c - '0' : c - 'a' + 10);
    }
    return pid > 0 && pid <= 0x7fffffff ? static_cast<pid_t>(pid) : 0;
}

// The data file the header text at `readFrom` names, when volcl wrote that header for `header`'s name
// and the data file has the unique-name form: only files volcl made are ever removed.
std::optional<fs::path> ownedDataFile(const fs::path& header, const fs::path& readFrom) {
    std::ifstream in(readFrom, std::ios::binary);
    std::string text(4096, '\0');
    in.read(text.data(), static_cast<std::streamsize>(text.size()));
    text.resize(static_cast<std::size_t>(std::max<std::streamsize>(in.gcount(), 0)));
    if (!text.starts_with(kWrittenByVolcl)) return std::nullopt;
    const std::size_t at = text.find("\ndata file: ");
    if (at == std::string::npos) return std::nullopt;
    const std::size_t begin = at + 12, end = text.find('\n', begin);
    if (end == std::string::npos) return std::nullopt;
    const std::string name = text.substr(begin, end - begin);
    if (dataFileWriter(header, name) == 0) return std::nullopt;
    return header.parent_path() / name;
}

// Removes the data files of runs killed between moving their data file and their header into place: files
// of the unique form whose writer no longer exists and that the present header does not name. The header
// is read after the PID check: a writer that has exited has moved its header in already, so a data file
// still named is seen as named.
void removeOrphanedDataFiles(const fs::path& header) {
    const fs::path dir = header.parent_path().empty() ? fs::path(".") : header.parent_path();
    std::vector<fs::path> orphans;
    std::error_code ec;
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
        const std::string name = it->path().filename().string();
        const pid_t writer = dataFileWriter(header, name);
        if (writer == 0 || writer == ::getpid()) continue;
        if (::kill(writer, 0) != 0 && errno == ESRCH) orphans.push_back(header.parent_path() / name);
    }
    if (orphans.empty()) return;
    // A header volcl did not write may name files in its own syntax: then nothing goes.
    std::error_code existsEc;
    const std::optional<fs::path> named = ownedDataFile(header, header);
    if (!named && fs::exists(header, existsEc)) return;
    for (const fs::path& orphan : orphans)
        if (!named || named->filename() != orphan.filename()) ::unlink(orphan.c_str());
}

} // namespace

std::optional<fs::path> nhdrOwnedDataFile(const fs::path& header) {
    return ownedDataFile(header, header);
}

namespace {

// One NRRD writer for a volume, a series (frames after one another on a fourth axis) and channels (`frames`
// is then the one interleaved volume; `grid` gives dims and geometry, `componentKind` axis 0's kind).
void writeNrrdPayload(std::span<const Volume> frames, const Volume& volume, std::size_t components,
                      std::string_view componentKind, const fs::path& path, const WriteOptions& options) {
    const bool detached = endsWithI(path.filename().string(), ".nhdr");
    const char* type = "uchar";
    switch (volume.type()) {
    case ScalarType::UInt8:
        type = "uchar";
        break;
    case ScalarType::UInt16:
        type = "ushort";
        break;
    case ScalarType::Int16:
        type = "short";
        break;
    case ScalarType::Float32:
        type = "float";
        break;
    case ScalarType::Float64:
        type = "double";
        break;
    }
    const Dims& d = volume.dims();
    const auto& s = volume.spacing;
    const auto& o = volume.origin;
    const bool gzip = options.compress && !detached;
    // A series is a fourth, non-spatial axis of kind "list" (direction none), frames one after another.
    const bool series = frames.size() > 1;
    std::string header =
        "NRRD0004\n# written by volcl; format: http://teem.sourceforge.net/nrrd/format.html\n";
    // An anatomical volume keeps its orientation as RAS space directions (origin and directions are RAS
    // in the volume model); `space` replaces `space dimension`, as the format requires.
    const bool channels = components > 1;
    header += "type: " + std::string(type) + "\ndimension: " + (series || channels ? "4" : "3") +
              (volume.anatomical ? "\nspace: right-anterior-superior\n" : "\nspace dimension: 3\n");
    header += "sizes: " + (channels ? std::to_string(components) + " " : std::string()) +
              std::to_string(d.x) + " " + std::to_string(d.y) + " " + std::to_string(d.z) +
              (series ? " " + std::to_string(frames.size()) : "") + "\n";
    header += std::string("space directions:") + (channels ? " none" : "");
    for (std::size_t c = 0; c < 3; ++c) {
        const Direction3& m = volume.direction;
        // The identity writes (s,0,0) exactly: products with 0 and 1 are exact.
        header += " (" + formatDouble(m[c] * s[c]) + "," + formatDouble(m[3 + c] * s[c]) + "," +
                  formatDouble(m[6 + c] * s[c]) + ")";
    }
    header += std::string(series ? " none" : "") + "\n";
    header +=
        "space origin: (" + formatDouble(o[0]) + "," + formatDouble(o[1]) + "," + formatDouble(o[2]) + ")\n";
    header += "kinds: " + (channels ? std::string(componentKind) + " " : std::string()) +
              "domain domain domain" + (series ? " list" : "") + "\n";
    if (scalarSize(volume.type()) > 1)
        header += std::string("endian: ") + (options.endian == Endian::Little ? "little" : "big") + "\n";
    header += std::string("encoding: ") + (gzip ? "gzip" : "raw") + "\n";
    if (detached) {
        // The data goes under a name no other run uses, then the header that names it replaces the old
        // header in one step: a reader sees the old pair or the new pair, never old header over new data
        // (or the reverse), whatever runs write the same .nhdr at once. The old header's data file goes last.
        removeOrphanedDataFiles(path);
        const fs::path dataPath = uniqueDataPath(path);
        header += "data file: " + dataPath.filename().string() + "\n";
        AtomicFile dataOut(dataPath);
        try {
            for (const Volume& v : frames)
                writeVoxelsInOrder(dataOut, v, options.endian);
        } catch (const IoError& e) { // the user named the header: say which output failed
            throw IoError(path.string() + ": cannot write its data file: " + e.what());
        }
        AtomicFile headerOut(path);
        headerOut.write(header);
        headerOut.onReplaced([path](const fs::path& oldHeader) {
            if (const auto oldData = ownedDataFile(path, oldHeader)) ::unlink(oldData->c_str());
        });
        try {
            dataOut.commit();
        } catch (const IoError& e) {
            throw IoError(path.string() + ": cannot write its data file: " + e.what());
        }
        try {
            headerOut.commit();
        } catch (...) {
            ::unlink(dataPath.c_str()); // named by no header
            throw;
        }
        return;
    }
    header += "\n";
    AtomicFile out(path);
    out.write(header);
    if (gzip) {
        std::vector<std::byte> all;
        for (const Volume& v : frames) {
            const std::vector<std::byte> b = bytesInOrder(v, options.endian);
            all.insert(all.end(), b.begin(), b.end());
        }
        out.write(deflateBytes(all, Wrapper::Gzip));
    } else {
        for (const Volume& v : frames)
            writeVoxelsInOrder(out, v, options.endian);
    }
    out.commit();
}

} // namespace

void writeNrrdSeries(std::span<const Volume> frames, const fs::path& path, const WriteOptions& options) {
    const Volume& volume = frames.front();
    for (const Volume& v : frames)
        if (v.dims() != volume.dims() || v.type() != volume.type())
            throw UsageError(path.string() + ": the frames of a 4D NRRD must share dims and voxel type");
    writeNrrdPayload(frames, volume, 1, {}, path, options);
}

void writeNrrdChannels(const ChannelVolume& channels, const fs::path& path, const WriteOptions& options) {
    const std::size_t k = channels.count();
    const std::string_view kind = channels.color && k == 3   ? "RGB-color"
                                  : channels.color && k == 4 ? "RGBA-color"
                                                             : "vector";
    const Volume interleaved = interleaveChannels(channels.channels);
    writeNrrdPayload(std::span<const Volume>(&interleaved, 1), channels.channels.front(), k, kind, path,
                     options);
}

void writeNrrd(const Volume& volume, const fs::path& path, const WriteOptions& options) {
    writeNrrdSeries(std::span<const Volume>(&volume, 1), path, options);
}

} // namespace volcl::io
