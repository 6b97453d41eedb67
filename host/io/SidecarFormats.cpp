// Text/XML headers that describe a separate raw file: Inviwo/Roettger .dat and Voreen .vvd.
#include "core/AtomicFile.hpp"
#include "host/io/IoDetail.hpp"
#include "host/io/Series.hpp"
#include "host/io/XmlDocument.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

namespace volcl::io {

namespace fs = std::filesystem;

namespace {

// Reads `frames` volumes stored back to back in one raw file; its size must match exactly.
TimeSeries readSidecarRaw(const ReadContext& ctx, const fs::path& data, const Dims& dims, std::size_t frames,
                          SampleType st, Endian endian, std::size_t byteOffset,
                          const std::array<double, 3>& spacing, const std::array<double, 3>& origin) {
    const fs::path& header = ctx.file();
    const std::size_t payload = checkedByteCount(ctx.voxelCount(dims, frames, st), sampleSize(st), header);
    std::error_code ec;
    if (!fs::is_regular_file(data, ec)) fail(header, "data file '" + data.string() + "' does not exist");
    const std::uintmax_t size = fs::file_size(data, ec);
    if (size != byteOffset + payload)
        fail(data, std::string(size < byteOffset + payload ? "truncated" : "oversized") + ": file has " +
                       std::to_string(size) + " bytes, header " + header.filename().string() + " needs " +
                       std::to_string(byteOffset + payload));
    const std::vector<std::byte> bytes = readFileBytes(data);
    if (bytes.size() != byteOffset + payload) fail(data, "file changed while reading");
    return decodeFrames(std::span<const std::byte>(bytes).subspan(byteOffset), st, endian, dims, frames,
                        spacing, origin);
}

std::optional<SampleType> inviwoType(std::string_view name) {
    static const std::map<std::string, SampleType> types = {
        {"uchar", SampleType::UInt8},      {"char", SampleType::Int8},     {"ushort", SampleType::UInt16},
        {"ushort_12", SampleType::UInt16}, {"short", SampleType::Int16},   {"uint", SampleType::UInt32},
        {"int", SampleType::Int32},        {"float", SampleType::Float32}, {"double", SampleType::Float64},
        {"uint8", SampleType::UInt8},      {"int8", SampleType::Int8},     {"uint16", SampleType::UInt16},
        {"int16", SampleType::Int16},      {"uint32", SampleType::UInt32}, {"int32", SampleType::Int32},
        {"uint64", SampleType::UInt64},    {"int64", SampleType::Int64},   {"float32", SampleType::Float32},
        {"float64", SampleType::Float64},
    };
    auto it = types.find(lower(trim(name)));
    if (it == types.end()) return std::nullopt;
    return it->second;
}

std::optional<SampleType> voreenType(std::string_view name) {
    static const std::map<std::string, SampleType> types = {
        {"uint8", SampleType::UInt8},    {"int8", SampleType::Int8},     {"uint16", SampleType::UInt16},
        {"int16", SampleType::Int16},    {"uint32", SampleType::UInt32}, {"int32", SampleType::Int32},
        {"uint64", SampleType::UInt64},  {"int64", SampleType::Int64},   {"float", SampleType::Float32},
        {"double", SampleType::Float64},
    };
    auto it = types.find(lower(trim(name)));
    if (it == types.end()) return std::nullopt;
    return it->second;
}

} // namespace

TimeSeries readInviwoDat(ReadContext& ctx) {
    const fs::path& path = ctx.file();
    const std::vector<std::byte> bytes = readFileBytes(path);
    const std::string_view text = asText(bytes);
    std::map<std::string, std::string> fields;
    std::size_t pos = 0;
    while (auto line = nextLine(text, pos)) {
        const std::string_view l = trim(*line);
        if (l.empty() || l.front() == '#') continue;
        const std::size_t colon = l.find(':');
        if (colon == std::string_view::npos)
            fail(path, "malformed line '" + std::string(l.substr(0, 60)) + "' (expected Key: value)");
        const std::string key = lower(trim(l.substr(0, colon)));
        if (key.size() > 64 || l.size() > 100000) fail(path, "header line too long");
        fields[key] = std::string(trim(l.substr(colon + 1)));
    }
    auto field = [&](const std::string& k) -> std::optional<std::string> {
        auto it = fields.find(k);
        if (it == fields.end()) return std::nullopt;
        return it->second;
    };
    const auto rawName = field("objectfilename");
    if (!rawName || rawName->empty()) fail(path, "no ObjectFileName (truncated or not an Inviwo .dat file)");
    const auto res = field("resolution");
    if (!res) fail(path, "no Resolution");
    const Dims dims = requireDims(splitWords(*res), 0, 3, path, "Resolution");
    const auto format = field("format");
    if (!format) fail(path, "no Format");
    const auto st = inviwoType(*format);
    if (!st)
        unsupported(path, "Format " + *format + " is not supported (vector formats are not scalar volumes)");
    Endian endian = Endian::Little;
    if (auto bo = field("byteorder")) {
        if (iequals(*bo, "bigendian"))
            endian = Endian::Big;
        else if (!iequals(*bo, "littleendian"))
            fail(path, "ByteOrder '" + *bo + "' is unknown");
    }
    std::size_t byteOffset = 0;
    if (auto off = field("byteoffset")) {
        const long long v = requireInt(*off, path, "ByteOffset");
        if (v < 0) fail(path, "ByteOffset must not be negative");
        byteOffset = static_cast<std::size_t>(v);
    }
    std::size_t frames = 1;
    if (auto seq = field("sequences")) {
        const long long v = requireInt(*seq, path, "Sequences");
        if (v < 1) fail(path, "Sequences must be positive");
        frames = static_cast<std::size_t>(v);
    }
    std::array<double, 3> spacing{1, 1, 1}, origin{0, 0, 0};
    if (auto st3 = field("slicethickness")) {
        spacing = requireTriple(splitWords(*st3), 0, path, "SliceThickness", true);
    } else if (field("basisvector1") && field("basisvector2") && field("basisvector3")) {
        // Inviwo basis vectors span the whole volume; per-voxel spacing is their length over the size.
        const std::size_t n[3] = {dims.x, dims.y, dims.z};
        for (int a = 0; a < 3; ++a) {
            const auto b = requireTriple(splitWords(*field("basisvector" + std::to_string(a + 1))), 0, path,
                                         "BasisVector", false);
            const double len = std::sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
            if (len > 0) spacing[a] = len / static_cast<double>(n[a]);
        }
    } else if (auto sp = field("spacing")) {
        spacing = requireTriple(splitWords(*sp), 0, path, "Spacing", true);
    }
    if (auto off = field("offset")) origin = requireTriple(splitWords(*off), 0, path, "Offset", false);
    return readSidecarRaw(ctx, ctx.dataFile(*rawName), dims, frames, *st, endian, byteOffset, spacing,
                          origin);
}

TimeSeries readVoreenVvd(ReadContext& ctx) {
    const fs::path& path = ctx.file();
    const std::vector<std::byte> bytes = readFileBytes(path);
    pugi::xml_document doc;
    parseXml(doc, asText(bytes), path);
    const pugi::xml_node root = doc.document_element();
    if (root.name() != std::string_view("VoreenData"))
        fail(path, "not a Voreen .vvd file (root is <" + std::string(root.name()) + ">)");
    struct Member {
        fs::path file;
        SampleType type;
        Dims dims;
        std::array<double, 3> spacing, origin;
    };
    std::vector<Member> members;
    for (pugi::xml_node volume : elementsNamed(root, "Volume")) {
        const auto raws = childrenNamed(volume, "RawData");
        if (raws.size() != 1) fail(path, "a <Volume> needs exactly one <RawData>");
        const pugi::xml_node raw = raws[0];
        const auto file = attr(raw, "filename");
        const auto format = attr(raw, "format");
        if (!file || !format) fail(path, "<RawData> needs filename and format");
        const auto st = voreenType(*format);
        if (!st) unsupported(path, "RawData format '" + *format + "' is not supported (only scalar formats)");
        std::vector<std::string_view> sizeWords;
        const std::string x = attr(raw, "x").value_or(""), y = attr(raw, "y").value_or(""),
                          z = attr(raw, "z").value_or("");
        sizeWords = {x, y, z};
        const Dims dims = requireDims(sizeWords, 0, 3, path, "RawData x/y/z");
        std::array<double, 3> spacing{1, 1, 1}, origin{0, 0, 0};
        for (pugi::xml_node meta : childrenNamed(volume, "MetaData")) {
            for (pugi::xml_node item : childrenNamed(meta, "MetaItem")) {
                const std::string name = attr(item, "name").value_or("");
                if (name != "Spacing" && name != "Offset") continue;
                const pugi::xml_node val = item.child("value");
                if (!val) fail(path, "MetaItem " + name + " has no <value>");
                const std::string vx = attr(val, "x").value_or(""), vy = attr(val, "y").value_or(""),
                                  vz = attr(val, "z").value_or("");
                const auto t = requireTriple({vx, vy, vz}, 0, path, name, name == "Spacing");
                (name == "Spacing" ? spacing : origin) = t;
            }
        }
        if (members.size() >= kMaxCollectionMembers)
            fail(path, "more than " + std::to_string(kMaxCollectionMembers) +
                           " <Volume> elements (the budget of a collection's members)");
        members.push_back({ctx.dataFile(*file), *st, dims, spacing, origin});
    }
    // The volumes together against the memory budget before any is read: every frame's voxels stay, one
    // file's samples at a time are read beside them.
    std::size_t kept = 0, largestRead = 0;
    for (const Member& m : members) {
        const std::size_t voxels = checkedVoxelCount(m.dims, 1, path);
        const std::size_t frameBytes = checkedByteCount(voxels, scalarSize(volumeTypeFor(m.type)), path);
        if (frameBytes > std::numeric_limits<std::size_t>::max() - kept) fail(path, "payload size overflows");
        kept += frameBytes;
        largestRead = std::max(largestRead, checkedByteCount(voxels, sampleSize(m.type), path));
    }
    if (largestRead > std::numeric_limits<std::size_t>::max() - kept) fail(path, "payload size overflows");
    ctx.claimMemory(kept + largestRead, "the " + std::to_string(members.size()) + " volumes it lists");
    // Each raw file once: a <RawData> has no offset, so a file named again is the same volume again
    // (3,001 <Volume>s naming one 2.8 MB file, 8.4 GB within the budget, took minutes and 12.3 GB).
    std::vector<const fs::path*> byName;
    for (const Member& m : members)
        byName.push_back(&m.file);
    std::sort(byName.begin(), byName.end(), [](const fs::path* a, const fs::path* b) { return *a < *b; });
    for (std::size_t i = 1; i < byName.size(); ++i)
        if (*byName[i] == *byName[i - 1])
            fail(path, "raw file '" + byName[i]->filename().string() +
                           "' is named by more than one <Volume> (each volume needs its own file)");
    TimeSeries series;
    for (const Member& m : members) {
        TimeSeries one =
            readSidecarRaw(ctx, m.file, m.dims, 1, m.type, Endian::Little, 0, m.spacing, m.origin);
        series.frames.push_back(std::move(one.frames.front()));
    }
    if (series.frames.empty()) fail(path, "no <Volume> element");
    return series;
}

} // namespace volcl::io
