// MetaImage (.mhd header + data file, .mha with LOCAL data): raw or zlib, byte order, spacing, offset.
#include "core/AtomicFile.hpp"
#include "core/Channels.hpp"
#include "host/io/IoDetail.hpp"

#include <cmath>
#include <map>

namespace volcl::io {

namespace fs = std::filesystem;

namespace {

std::optional<SampleType> metaType(std::string_view name) {
    static const std::map<std::string, SampleType> types = {
        {"met_char", SampleType::Int8},       {"met_uchar", SampleType::UInt8},
        {"met_short", SampleType::Int16},     {"met_ushort", SampleType::UInt16},
        {"met_int", SampleType::Int32},       {"met_uint", SampleType::UInt32},
        {"met_long", SampleType::Int32},      {"met_ulong", SampleType::UInt32},
        {"met_long_long", SampleType::Int64}, {"met_ulong_long", SampleType::UInt64},
        {"met_float", SampleType::Float32},   {"met_double", SampleType::Float64},
    };
    auto it = types.find(lower(trim(name)));
    if (it == types.end()) return std::nullopt;
    return it->second;
}

bool parseBool(std::string_view v, const fs::path& file, std::string_view key) {
    if (iequals(v, "true") || v == "1") return true;
    if (iequals(v, "false") || v == "0") return false;
    fail(file, std::string(key) + ": '" + std::string(v.substr(0, 20)) + "' is not True/False");
}

} // namespace

TimeSeries readMetaImage(ReadContext& ctx) {
    const fs::path& path = ctx.file();
    const std::vector<std::byte> bytes = readFileBytes(path);
    const std::string_view text = asText(bytes);
    std::size_t pos = 0;
    std::map<std::string, std::string> fields;
    std::vector<std::string> listFiles;
    bool dataFileSeen = false;
    while (auto line = nextLine(text, pos)) {
        const std::string_view l = trim(*line);
        if (l.empty()) continue;
        const std::size_t eq = l.find('=');
        if (eq == std::string_view::npos)
            fail(path, "malformed header line '" + std::string(l.substr(0, 60)) + "' (expected Key = Value)");
        const std::string key = lower(trim(l.substr(0, eq)));
        const std::string value(trim(l.substr(eq + 1)));
        if (key.size() > 64 || value.size() > 100000) fail(path, "header line too long");
        fields[key] = value;
        if (key == "elementdatafile") {
            dataFileSeen = true;
            const auto w = splitWords(value);
            if (!w.empty() && iequals(w[0], "LIST")) // the remaining lines are file names
                while (auto f = nextLine(text, pos))
                    if (!trim(*f).empty()) listFiles.emplace_back(trim(*f));
            break; // ElementDataFile is always the last header field; LOCAL data starts here
        }
    }
    if (!dataFileSeen) fail(path, "header has no ElementDataFile (truncated or not a MetaImage)");
    auto field = [&](const std::string& key) -> std::optional<std::string> {
        auto it = fields.find(key);
        if (it == fields.end()) return std::nullopt;
        return it->second;
    };
    auto require = [&](const std::string& key, std::string_view display) {
        auto v = field(key);
        if (!v) fail(path, "header has no " + std::string(display));
        return *v;
    };

    const long long ndims = requireInt(require("ndims", "NDims"), path, "NDims");
    if (ndims < 1 || ndims > 4) unsupported(path, "NDims " + std::to_string(ndims) + " (1 to 4 supported)");
    const auto sizes =
        requireSizes(require("dimsize", "DimSize"), static_cast<std::size_t>(ndims), path, "DimSize");
    std::size_t components = 1; // ElementNumberOfChannels: interleaved per voxel
    if (auto ch = field("elementnumberofchannels")) {
        const long long n = requireInt(*ch, path, "ElementNumberOfChannels");
        if (n < 1 || n > 4096) fail(path, "ElementNumberOfChannels " + *ch + " is not 1 to 4096");
        components = static_cast<std::size_t>(n);
    }
    const std::string typeName = require("elementtype", "ElementType");
    const auto st = metaType(typeName);
    if (!st) unsupported(path, "ElementType " + typeName + " is not supported");

    Endian endian = Endian::Little;
    if (auto msb = field("elementbyteordermsb"))
        endian = parseBool(*msb, path, "ElementByteOrderMSB") ? Endian::Big : Endian::Little;
    else if (auto bmsb = field("binarydatabyteordermsb"))
        endian = parseBool(*bmsb, path, "BinaryDataByteOrderMSB") ? Endian::Big : Endian::Little;
    if (auto binary = field("binarydata"); binary && !parseBool(*binary, path, "BinaryData"))
        unsupported(path, "ASCII MetaImage data (BinaryData = False) is not supported");
    const bool compressed =
        field("compresseddata") && parseBool(*field("compresseddata"), path, "CompressedData");

    std::array<double, 3> spacing{1, 1, 1}, origin{0, 0, 0};
    const auto sp = field("elementspacing") ? field("elementspacing") : field("elementsize");
    if (sp) {
        const auto w = splitWords(*sp);
        for (std::size_t i = 0; i < w.size() && i < 3; ++i) {
            const double v = requireDouble(w[i], path, "ElementSpacing");
            if (!(v > 0) || !std::isfinite(v))
                fail(path, "ElementSpacing " + std::string(w[i]) + " must be positive");
            spacing[i] = v;
        }
    }
    for (const char* key : {"offset", "origin", "position"}) {
        if (auto o = field(key)) {
            const auto w = splitWords(*o);
            for (std::size_t i = 0; i < w.size() && i < 3; ++i) {
                origin[i] = requireDouble(w[i], path, "Offset");
                if (!std::isfinite(origin[i]))
                    fail(path, "Offset: value " + std::string(w[i]) + " is not finite");
            }
            break;
        }
    }

    // World is LPS, as ITK writes it: TransformMatrix (alias Rotation, Orientation) lists each index axis's
    // direction in turn; AnatomicalOrientation (used only without a matrix) names the side each axis
    // comes from (ITK's RAI is the identity). Both become RAS directions and the Offset a RAS origin;
    // without either the volume keeps the identity and the Offset as written, and is not anatomical.
    Direction3 direction = kIdentityDirection;
    bool anatomical = false;
    std::optional<std::string> matrix = field("transformmatrix");
    if (!matrix) matrix = field("rotation");
    if (!matrix) matrix = field("orientation");
    const std::array<double, 3> lpsToRas{-1, -1, 1};
    if (matrix && ndims >= 3) {
        const auto w = splitWords(*matrix);
        const std::size_t n = static_cast<std::size_t>(ndims);
        if (w.size() != n * n)
            fail(path, "TransformMatrix has " + std::to_string(w.size()) + " values, NDims " +
                           std::to_string(n) + " needs " + std::to_string(n * n));
        Direction3 m{};
        for (std::size_t axis = 0; axis < 3; ++axis)
            for (std::size_t row = 0; row < 3; ++row) {
                const double v = requireDouble(w[axis * n + row], path, "TransformMatrix");
                if (!std::isfinite(v))
                    fail(path, "TransformMatrix: value " + std::string(w[axis * n + row]) + " is not finite");
                m[3 * row + axis] = lpsToRas[row] * v;
            }
        try {
            direction = orthonormalDirection(m);
        } catch (const DataError& e) {
            fail(path, std::string("TransformMatrix: ") + e.what());
        }
        anatomical = true;
    } else if (auto code = field("anatomicalorientation"); code && ndims >= 3) {
        const std::string letters = lower(trim(*code));
        Direction3 m{};
        bool known = letters.size() >= 3;
        for (std::size_t axis = 0; known && axis < 3; ++axis) {
            // RAS row and sign of the direction away from the named side.
            const char c = letters[axis];
            const int row = (c == 'r' || c == 'l')   ? 0
                            : (c == 'a' || c == 'p') ? 1
                            : (c == 's' || c == 'i') ? 2
                                                     : -1;
            if (row < 0) {
                known = false;
                break;
            }
            m[std::size_t(3 * row) + axis] = (c == 'l' || c == 'p' || c == 'i') ? 1.0 : -1.0;
        }
        // A code naming one side twice ("RLI") or unknown letters ("???", written by some tools) is ignored.
        if (known && std::abs(determinant(m)) > 0.5) {
            direction = m;
            anatomical = true;
        }
    }

    if (anatomical) // the LPS offset in RAS, like the directions
        for (std::size_t a = 0; a < 2; ++a)
            origin[a] = -origin[a];

    const Dims dims{sizes[0], sizes[1], sizes[2]};
    refuseFramesWithComponents(sizes[3], components, path);
    requireChannelsWanted(ctx, components, "ElementNumberOfChannels");
    const std::size_t frames = sizes[3] * components;
    const std::size_t payload = checkedByteCount(ctx.voxelCount(dims, frames, *st), sampleSize(*st), path);
    long long headerSize = 0;
    if (auto hs = field("headersize")) headerSize = requireInt(*hs, path, "HeaderSize");
    if (headerSize < -1) fail(path, "HeaderSize must be -1 or more");

    std::vector<std::byte> data;
    const std::string dataFile = require("elementdatafile", "ElementDataFile");
    const auto w = splitWords(dataFile);
    if (iequals(dataFile, "LOCAL")) {
        std::span<const std::byte> rest(bytes.data() + pos, bytes.size() - pos);
        if (compressed) {
            // CompressedDataSize is ignored on purpose: real files carry wrong values (frogtissue).
            data = inflateExact(rest, payload, path, "zlib data");
        } else {
            if (rest.size() < payload)
                fail(path, "truncated: " + std::to_string(rest.size()) + " data bytes, expected " +
                               std::to_string(payload));
            if (rest.size() > payload)
                fail(path, "oversized: " + std::to_string(rest.size() - payload) + " bytes after the data");
            data.assign(rest.begin(), rest.end());
        }
    } else {
        std::vector<fs::path> files;
        if (!w.empty() && iequals(w[0], "LIST")) {
            for (const std::string& f : listFiles)
                files.push_back(ctx.dataFile(f));
        } else if (w.size() >= 4 && dataFile.find('%') != std::string::npos) {
            for (const std::string& n : expandFilePattern(w[0], requireInt(w[1], path, "ElementDataFile min"),
                                                          requireInt(w[2], path, "ElementDataFile max"),
                                                          requireInt(w[3], path, "ElementDataFile step"),
                                                          path, maxDataFiles(dims, frames), payload))
                files.push_back(ctx.dataFile(n));
        } else {
            files.push_back(ctx.dataFile(dataFile));
        }
        if (files.size() > payload) fail(path, "more data files than voxels");
        data = readDetachedPayload(path, files, payload,
                                   compressed ? PayloadEncoding::Compressed : PayloadEncoding::Raw,
                                   compressed ? 0 : headerSize, 0);
    }
    if (components > 1) {
        TimeSeries whole =
            decodeFrames(data, *st, endian, {components, dims.x * dims.y, dims.z}, 1, spacing, origin);
        Volume grid(dims, ScalarType::UInt8);
        grid.spacing = spacing;
        grid.origin = origin;
        grid.direction = direction;
        grid.anatomical = anatomical;
        return channelsAsRequested(splitInterleaved(whole.frames.front(), components, grid), ctx,
                                   "ElementNumberOfChannels");
    }
    TimeSeries series = decodeFrames(data, *st, endian, dims, frames, spacing, origin);
    for (Volume& v : series.frames) {
        v.direction = direction;
        v.anatomical = anatomical;
    }
    return series;
}

} // namespace volcl::io
