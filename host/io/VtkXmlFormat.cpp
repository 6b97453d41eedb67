// VTK XML ImageData (.vti): inline ascii/base64 and appended raw/base64 arrays, zlib blocks, TimeStep.
#include "host/io/AtomicFile.hpp"
#include "host/io/IoDetail.hpp"
#include "host/io/XmlScan.hpp"

#include <algorithm>
#include <cctype>
#include <cstring>

namespace volcl::io {

namespace fs = std::filesystem;

namespace {

std::optional<SampleType> vtkType(std::string_view name) {
    static const std::pair<std::string_view, SampleType> types[] = {
        {"Int8", SampleType::Int8},       {"UInt8", SampleType::UInt8},   {"Int16", SampleType::Int16},
        {"UInt16", SampleType::UInt16},   {"Int32", SampleType::Int32},   {"UInt32", SampleType::UInt32},
        {"Int64", SampleType::Int64},     {"UInt64", SampleType::UInt64}, {"Float32", SampleType::Float32},
        {"Float64", SampleType::Float64}, {"Char", SampleType::Int8},     {"UChar", SampleType::UInt8},
    };
    for (const auto& [n, t] : types)
        if (n == name) return t;
    return std::nullopt;
}

int base64Value(char c) {
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    if (c == '+') return 62;
    if (c == '/') return 63;
    return -1;
}

// Strict base64 of whole 4-character groups; '=' padding only in the last group.
std::vector<std::byte> base64Decode(std::string_view chars, const fs::path& file) {
    if (chars.size() % 4 != 0) fail(file, "truncated base64 data");
    std::vector<std::byte> out;
    out.reserve(chars.size() / 4 * 3);
    for (std::size_t i = 0; i < chars.size(); i += 4) {
        int v[4];
        int pad = 0;
        for (int k = 0; k < 4; ++k) {
            const char c = chars[i + k];
            if (c == '=' && k >= 2 && i + 4 == chars.size()) {
                v[k] = 0;
                ++pad;
                continue;
            }
            if (pad > 0) fail(file, "malformed base64 padding");
            v[k] = base64Value(c);
            if (v[k] < 0) fail(file, "invalid base64 character");
        }
        const unsigned triple =
            (unsigned(v[0]) << 18) | (unsigned(v[1]) << 12) | (unsigned(v[2]) << 6) | unsigned(v[3]);
        out.push_back(std::byte(triple >> 16));
        if (pad < 2) out.push_back(std::byte((triple >> 8) & 0xff));
        if (pad < 1) out.push_back(std::byte(triple & 0xff));
    }
    return out;
}

std::size_t base64Chars(std::size_t bytes) {
    return (bytes + 2) / 3 * 4;
}

struct VtiLayout {
    fs::path file;
    bool swap = false; // file byte order differs from the host
    Endian endian = Endian::Little;
    std::size_t headerWord = 4; // UInt32 or UInt64 block headers
    bool compressed = false;
};

std::uint64_t headerWordAt(std::span<const std::byte> b, std::size_t index, const VtiLayout& L) {
    std::byte tmp[8] = {};
    std::memcpy(tmp, b.data() + index * L.headerWord, L.headerWord);
    if (L.swap) std::reverse(tmp, tmp + L.headerWord);
    if (L.headerWord == 4) {
        std::uint32_t v;
        std::memcpy(&v, tmp, 4);
        return v;
    }
    std::uint64_t v;
    std::memcpy(&v, tmp, 8);
    return v;
}

struct BlockHeader {
    std::size_t headerBytes = 0;  // size of the header itself
    std::size_t storedBytes = 0;  // bytes after the header (compressed sizes summed, or the raw byte count)
    std::size_t decodedBytes = 0; // bytes after decompression
};

// Reads the array header from the start of `b` (which may be only a prefix of the array).
BlockHeader parseBlockHeader(std::span<const std::byte> b, const VtiLayout& L, std::string_view name) {
    const fs::path& f = L.file;
    const std::string what = "array '" + std::string(name) + "'";
    BlockHeader h;
    const std::size_t W = L.headerWord;
    if (!L.compressed) {
        if (b.size() < W) fail(f, "truncated: " + what + " has no size header");
        const std::uint64_t n = headerWordAt(b, 0, L);
        if (n > (std::uint64_t{1} << 48)) fail(f, what + ": impossible byte count " + std::to_string(n));
        h.headerBytes = W;
        h.storedBytes = h.decodedBytes = static_cast<std::size_t>(n);
        return h;
    }
    if (b.size() < 3 * W) fail(f, "truncated: " + what + " has no compression header");
    const std::uint64_t nb = headerWordAt(b, 0, L), bs = headerWordAt(b, 1, L), last = headerWordAt(b, 2, L);
    if (nb > b.size() / W)
        fail(f, "truncated or corrupt: " + what + " claims " + std::to_string(nb) + " blocks");
    if (b.size() < (3 + nb) * W) fail(f, "truncated: " + what + " compression header is cut off");
    if (last > bs || bs > (std::uint64_t{1} << 40)) fail(f, what + ": inconsistent compression block sizes");
    h.headerBytes = static_cast<std::size_t>((3 + nb) * W);
    std::uint64_t sum = 0;
    for (std::uint64_t i = 0; i < nb; ++i) {
        const std::uint64_t c = headerWordAt(b, static_cast<std::size_t>(3 + i), L);
        if (c > (std::uint64_t{1} << 40)) fail(f, what + ": impossible compressed block size");
        sum += c;
    }
    h.storedBytes = static_cast<std::size_t>(sum);
    h.decodedBytes = nb == 0 ? 0 : static_cast<std::size_t>((nb - 1) * bs + (last ? last : bs));
    return h;
}

// Decodes a complete array (header + stored data at the start of `b`) into its uncompressed bytes.
std::vector<std::byte> decodeBlocks(std::span<const std::byte> b, const VtiLayout& L, std::string_view name,
                                    std::size_t expected) {
    const fs::path& f = L.file;
    const std::string what = "array '" + std::string(name) + "'";
    const BlockHeader h = parseBlockHeader(b, L, name);
    if (h.decodedBytes != expected)
        fail(f, what + " holds " + std::to_string(h.decodedBytes) + " bytes, the grid needs " +
                    std::to_string(expected));
    if (b.size() < h.headerBytes + h.storedBytes)
        fail(f, "truncated: " + what + " needs " + std::to_string(h.headerBytes + h.storedBytes) +
                    " bytes, " + std::to_string(b.size()) + " present");
    if (!L.compressed) {
        const auto d = b.subspan(h.headerBytes, h.storedBytes);
        return {d.begin(), d.end()};
    }
    std::vector<std::byte> out(expected);
    const std::uint64_t nb = headerWordAt(b, 0, L), bs = headerWordAt(b, 1, L), last = headerWordAt(b, 2, L);
    std::size_t in = h.headerBytes, o = 0;
    for (std::uint64_t i = 0; i < nb; ++i) {
        const auto c = static_cast<std::size_t>(headerWordAt(b, static_cast<std::size_t>(3 + i), L));
        const auto size = static_cast<std::size_t>(i + 1 == nb && last ? last : bs);
        const auto block = inflateExact(b.subspan(in, c), size, f, what + " block " + std::to_string(i));
        std::memcpy(out.data() + o, block.data(), size);
        in += c;
        o += size;
    }
    return out;
}

// Base64 arrays: VTK encodes the header and the data as separate base64 runs (each padded), other
// writers as one run. Which one is used shows in the padding at the end of the header run.
std::vector<std::byte> decodeBase64Array(std::string_view chars, const VtiLayout& L, std::string_view name,
                                         std::size_t expected, std::size_t* consumedChars) {
    const fs::path& f = L.file;
    const std::size_t W = L.headerWord;
    const std::size_t probeBytes = L.compressed ? 3 * W : W;
    const std::size_t probeChars = base64Chars(probeBytes);
    if (chars.size() < probeChars) fail(f, "truncated base64 array '" + std::string(name) + "'");
    std::vector<std::byte> probe = base64Decode(chars.substr(0, probeChars), f);
    std::size_t headerLen = W;
    if (L.compressed) {
        const std::uint64_t nb = headerWordAt(probe, 0, L);
        if (nb > chars.size()) fail(f, "corrupt base64 array '" + std::string(name) + "' block count");
        headerLen = static_cast<std::size_t>((3 + nb) * W);
    }
    const std::size_t headerChars = base64Chars(headerLen);
    if (chars.size() < headerChars) fail(f, "truncated base64 array '" + std::string(name) + "'");
    const bool separate = headerLen % 3 != 0 && chars[headerChars - 1] == '=';
    std::vector<std::byte> logical;
    if (separate) {
        logical = base64Decode(chars.substr(0, headerChars), f);
        const BlockHeader h = parseBlockHeader(logical, L, name);
        if (h.storedBytes > chars.size()) fail(f, "truncated base64 array '" + std::string(name) + "'");
        const std::size_t dataChars = base64Chars(h.storedBytes);
        if (chars.size() < headerChars + dataChars)
            fail(f, "truncated base64 array '" + std::string(name) + "'");
        const auto data = base64Decode(chars.substr(headerChars, dataChars), f);
        logical.insert(logical.end(), data.begin(), data.end());
        *consumedChars = headerChars + dataChars;
    } else {
        // Decode enough whole groups to hold the header, then the whole run.
        const std::size_t groups = (headerLen + 2) / 3;
        std::vector<std::byte> headPart = base64Decode(chars.substr(0, groups * 4), f);
        const BlockHeader h = parseBlockHeader(headPart, L, name);
        const std::size_t total = h.headerBytes + h.storedBytes;
        if (h.storedBytes > chars.size() || base64Chars(total) > chars.size())
            fail(f, "truncated base64 array '" + std::string(name) + "'");
        logical = base64Decode(chars.substr(0, base64Chars(total)), f);
        logical.resize(std::min(logical.size(), total));
        *consumedChars = base64Chars(total);
    }
    return decodeBlocks(logical, L, name, expected);
}

template <class T> double loadAsDouble(std::span<const std::byte> b, bool swap) {
    std::byte tmp[sizeof(T)];
    std::memcpy(tmp, b.data(), sizeof(T));
    if (swap) std::reverse(tmp, tmp + sizeof(T));
    T v;
    std::memcpy(&v, tmp, sizeof(T));
    return static_cast<double>(v);
}

// First value of a decoded array at full precision (TimeStep is usually Float64).
double firstValue(std::span<const std::byte> b, SampleType t, bool swap) {
    switch (t) {
    case SampleType::Int8:
        return loadAsDouble<std::int8_t>(b, swap);
    case SampleType::UInt8:
        return loadAsDouble<std::uint8_t>(b, swap);
    case SampleType::Int16:
        return loadAsDouble<std::int16_t>(b, swap);
    case SampleType::UInt16:
        return loadAsDouble<std::uint16_t>(b, swap);
    case SampleType::Int32:
        return loadAsDouble<std::int32_t>(b, swap);
    case SampleType::UInt32:
        return loadAsDouble<std::uint32_t>(b, swap);
    case SampleType::Int64:
        return loadAsDouble<std::int64_t>(b, swap);
    case SampleType::UInt64:
        return loadAsDouble<std::uint64_t>(b, swap);
    case SampleType::Float32:
        return loadAsDouble<float>(b, swap);
    case SampleType::Float64:
        return loadAsDouble<double>(b, swap);
    }
    return 0;
}

std::string stripSpaces(std::string_view s) {
    std::string out;
    out.reserve(s.size());
    for (char c : s)
        if (!std::isspace(static_cast<unsigned char>(c))) out += c;
    return out;
}

} // namespace

TimeSeries readVtkXmlImage(ReadContext& ctx) {
    const fs::path& path = ctx.file();
    const std::vector<std::byte> bytes = readFileBytes(path);
    const std::string_view text = asText(bytes);
    const XmlDocument doc = scanXml(text, path, "AppendedData");
    const XmlElement& root = doc.elements[0];
    if (root.name != "VTKFile") fail(path, "not a VTK XML file (root element is <" + root.name + ">)");
    const std::string fileType = root.attr("type").value_or("");
    if (fileType != "ImageData") unsupported(path, "VTK XML type '" + fileType + "' is not ImageData");

    VtiLayout L;
    L.file = path;
    const std::string order = root.attr("byte_order").value_or("LittleEndian");
    if (order != "LittleEndian" && order != "BigEndian") fail(path, "byte_order '" + order + "' is unknown");
    L.endian = order == "BigEndian" ? Endian::Big : Endian::Little;
    L.swap = L.endian != hostEndian();
    const std::string headerType = root.attr("header_type").value_or("UInt32");
    if (headerType == "UInt64")
        L.headerWord = 8;
    else if (headerType != "UInt32")
        fail(path, "header_type '" + headerType + "' is unknown");
    if (auto comp = root.attr("compressor")) {
        if (*comp == "vtkZLibDataCompressor")
            L.compressed = true;
        else if (!comp->empty())
            unsupported(path, "compressor " + *comp + " is not supported (only vtkZLibDataCompressor)");
    }

    const auto images = doc.childrenNamed(0, "ImageData");
    if (images.size() != 1) fail(path, "expected one <ImageData> element");
    const XmlElement& image = doc.elements[static_cast<std::size_t>(images[0])];
    const std::string extentText = image.attr("WholeExtent").value_or("");
    const auto extentWords = splitWords(extentText);
    if (extentWords.size() != 6) fail(path, "ImageData WholeExtent needs 6 values");
    long long ext[6];
    for (int i = 0; i < 6; ++i)
        ext[i] = requireInt(extentWords[static_cast<std::size_t>(i)], path, "WholeExtent");
    std::size_t n[3];
    for (int a = 0; a < 3; ++a) {
        if (ext[2 * a + 1] < ext[2 * a]) fail(path, "WholeExtent is empty along axis " + std::to_string(a));
        n[a] = static_cast<std::size_t>(ext[2 * a + 1] - ext[2 * a]) + 1;
    }
    const Dims dims{n[0], n[1], n[2]};
    // The sample type is only known per array; the largest (8 bytes, converted to float32) bounds it.
    const std::size_t voxels = ctx.voxelCount(dims, 1, SampleType::Float64);
    std::array<double, 3> spacing{1, 1, 1}, origin{0, 0, 0};
    if (auto sp = image.attr("Spacing")) spacing = requireTriple(splitWords(*sp), 0, path, "Spacing", true);
    if (auto o = image.attr("Origin")) origin = requireTriple(splitWords(*o), 0, path, "Origin", false);
    for (int a = 0; a < 3; ++a)
        origin[a] += static_cast<double>(ext[2 * a]) * spacing[a]; // extent may not start at 0

    const auto pieces = doc.childrenNamed(images[0], "Piece");
    if (pieces.size() != 1)
        unsupported(path, std::to_string(pieces.size()) + " pieces: only single-piece files are supported");
    const XmlElement& piece = doc.elements[static_cast<std::size_t>(pieces[0])];
    if (const auto pe = piece.attr("Extent"); pe && splitWords(*pe) != extentWords)
        unsupported(path, "Piece Extent differs from WholeExtent");

    // Appended section: "_" then raw bytes or base64 text up to the closing tags at the end of the file.
    std::span<const std::byte> appended;
    bool appendedBase64 = false;
    const int appIndex = doc.find("AppendedData");
    if (appIndex >= 0) {
        const std::string enc =
            doc.elements[static_cast<std::size_t>(appIndex)].attr("encoding").value_or("raw");
        if (enc != "raw" && enc != "base64") fail(path, "AppendedData encoding '" + enc + "' is unknown");
        appendedBase64 = enc == "base64";
        std::size_t p = doc.stopOffset;
        while (p < text.size() && std::isspace(static_cast<unsigned char>(text[p])))
            ++p;
        if (p >= text.size() || text[p] != '_') fail(path, "truncated: AppendedData has no '_' marker");
        const std::size_t begin = p + 1;
        const std::size_t close = text.rfind("</AppendedData>");
        if (close == std::string_view::npos || close < begin)
            fail(path, "truncated: </AppendedData> is missing");
        const std::string_view tail = trim(text.substr(close + std::string_view("</AppendedData>").size()));
        if (tail != "</VTKFile>")
            fail(path, "truncated or trailing garbage: the file must end with </VTKFile>");
        appended = std::span<const std::byte>(bytes).subspan(begin, close - begin);
    }

    std::size_t appendedEnd = 0; // furthest byte used by any appended array (raw encoding)
    auto decodeArray = [&](const XmlElement& da, std::size_t expectedBytes) -> std::vector<std::byte> {
        const std::string name = da.attr("Name").value_or("?");
        const std::string format = da.attr("format").value_or("ascii");
        if (format == "binary") {
            std::size_t used = 0;
            return decodeBase64Array(stripSpaces(da.content), L, name, expectedBytes, &used);
        }
        if (format != "appended") fail(path, "array '" + name + "': format '" + format + "' is unknown");
        if (appIndex < 0) fail(path, "array '" + name + "' is appended but the file has no AppendedData");
        const long long off = requireInt(da.attr("offset").value_or(""), path, "DataArray offset");
        if (off < 0 || static_cast<std::size_t>(off) > appended.size())
            fail(path, "truncated: array '" + name + "' offset " + std::to_string(off) +
                           " is outside the appended data");
        if (appendedBase64) {
            const std::string chars = stripSpaces(asText(appended.subspan(static_cast<std::size_t>(off))));
            std::size_t used = 0;
            return decodeBase64Array(chars, L, name, expectedBytes, &used);
        }
        const auto b = appended.subspan(static_cast<std::size_t>(off));
        const BlockHeader h = parseBlockHeader(b, L, name);
        appendedEnd = std::max(appendedEnd, static_cast<std::size_t>(off) + h.headerBytes + h.storedBytes);
        return decodeBlocks(b, L, name, expectedBytes);
    };
    auto arrayValues = [&](const XmlElement& da) -> std::size_t {
        const std::size_t comps = static_cast<std::size_t>(std::max<long long>(
            1, requireInt(da.attr("NumberOfComponents").value_or("1"), path, "NumberOfComponents")));
        return comps;
    };

    // Raw appended data must be fully accounted for: every array's stored span ends inside it and
    // nothing but whitespace follows the last one.
    if (appIndex >= 0 && !appendedBase64) {
        for (const XmlElement& e : doc.elements) {
            if (e.name != "DataArray" || e.attr("format").value_or("") != "appended") continue;
            const long long off = requireInt(e.attr("offset").value_or(""), path, "DataArray offset");
            if (off < 0 || static_cast<std::size_t>(off) > appended.size())
                fail(path,
                     "truncated: array offset " + std::to_string(off) + " is outside the appended data");
            const BlockHeader h = parseBlockHeader(appended.subspan(static_cast<std::size_t>(off)), L,
                                                   e.attr("Name").value_or("?"));
            const std::size_t end = static_cast<std::size_t>(off) + h.headerBytes + h.storedBytes;
            if (end > appended.size())
                fail(path, "truncated: array '" + e.attr("Name").value_or("?") +
                               "' runs past the end of the appended data");
            appendedEnd = std::max(appendedEnd, end);
        }
        if (!trim(asText(appended.subspan(appendedEnd))).empty())
            fail(path, "oversized: " + std::to_string(appended.size() - appendedEnd) +
                           " unexpected bytes after the appended arrays");
    }

    // The scalar array: PointData's active Scalars, else its first one-component array.
    const auto pointData = doc.childrenNamed(pieces[0], "PointData");
    if (pointData.empty()) unsupported(path, "no point data (cell data is not supported)");
    const XmlElement& pd = doc.elements[static_cast<std::size_t>(pointData[0])];
    const std::string active = pd.attr("Scalars").value_or("");
    const XmlElement* chosen = nullptr;
    for (int c : doc.childrenNamed(pointData[0], "DataArray")) {
        const XmlElement& da = doc.elements[static_cast<std::size_t>(c)];
        if (!active.empty() ? da.attr("Name").value_or("") == active : arrayValues(da) == 1) {
            chosen = &da;
            break;
        }
    }
    if (!chosen)
        unsupported(path, "no scalar point-data array" +
                              (active.empty() ? std::string() : " named '" + active + "'"));
    if (arrayValues(*chosen) != 1)
        unsupported(path, "array '" + active + "' has " + chosen->attr("NumberOfComponents").value_or("?") +
                              " components: only scalars are supported");
    const std::string typeName = chosen->attr("type").value_or("");
    const auto st = vtkType(typeName);
    if (!st) unsupported(path, "array type '" + typeName + "' is not supported");

    // The payload is validated against the extent before the volume is allocated.
    Volume v;
    if (chosen->attr("format").value_or("ascii") == "ascii") {
        requireAsciiCapacity(chosen->content, voxels, path);
        v = Volume(dims, volumeTypeFor(*st));
        decodeAsciiSamples(chosen->content, *st, v, 0, voxels, path);
    } else {
        const std::vector<std::byte> data =
            decodeArray(*chosen, checkedByteCount(voxels, sampleSize(*st), path));
        v = Volume(dims, volumeTypeFor(*st));
        decodeSamples(data, *st, L.endian, v);
    }
    v.spacing = spacing;
    v.origin = origin;

    TimeSeries series;
    series.frames.push_back(std::move(v));
    // FieldData TimeStep (ParaView/TTK convention) gives the frame's time.
    for (int fd : doc.childrenNamed(images[0], "FieldData")) {
        for (int c : doc.childrenNamed(fd, "DataArray")) {
            const XmlElement& da = doc.elements[static_cast<std::size_t>(c)];
            if (da.attr("Name").value_or("") != "TimeStep") continue;
            const auto tt = vtkType(da.attr("type").value_or(""));
            if (!tt) fail(path, "TimeStep array has an unknown type");
            if (da.attr("format").value_or("ascii") == "ascii") {
                const auto words = splitWords(da.content);
                if (words.empty()) fail(path, "TimeStep array is empty");
                series.times.push_back(requireDouble(words[0], path, "TimeStep"));
            } else {
                const long long tuples =
                    requireInt(da.attr("NumberOfTuples").value_or("1"), path, "NumberOfTuples");
                if (tuples < 1 || tuples > 1'000'000) fail(path, "TimeStep NumberOfTuples is invalid");
                const std::vector<std::byte> data =
                    decodeArray(da, static_cast<std::size_t>(tuples) * sampleSize(*tt));
                series.times.push_back(firstValue(data, *tt, L.swap));
            }
        }
    }
    return series;
}

} // namespace volcl::io
