// VTK XML DataArray payloads: base64 (one run or VTK's separate header and data runs), zlib blocks, appended
// data.
#include "host/io/VtkXmlArrays.hpp"

#include <algorithm>
#include <cctype>
#include <cstring>

namespace volcl::io {

namespace fs = std::filesystem;

std::optional<SampleType> vtkXmlType(std::string_view name) {
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

namespace {

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

std::uint64_t headerWordAt(std::span<const std::byte> b, std::size_t index, const VtkXmlLayout& L) {
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
BlockHeader parseBlockHeader(std::span<const std::byte> b, const VtkXmlLayout& L, std::string_view name) {
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
std::vector<std::byte> decodeBlocks(std::span<const std::byte> b, const VtkXmlLayout& L,
                                    std::string_view name, std::size_t expected) {
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
    checkInflateRatio(h.storedBytes, expected, f, what); // the whole array, before its blocks
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
std::vector<std::byte> decodeBase64Array(std::string_view chars, const VtkXmlLayout& L, std::string_view name,
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

} // namespace

std::string stripSpaces(std::string_view s) {
    std::string out;
    out.reserve(s.size());
    for (char c : s)
        if (!std::isspace(static_cast<unsigned char>(c))) out += c;
    return out;
}

std::string base64Encode(std::span<const std::byte> bytes) {
    static constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    out.reserve(base64Chars(bytes.size()));
    for (std::size_t i = 0; i < bytes.size(); i += 3) {
        const std::size_t n = std::min<std::size_t>(3, bytes.size() - i);
        unsigned triple = 0;
        for (std::size_t k = 0; k < 3; ++k)
            triple = (triple << 8) | (k < n ? std::to_integer<unsigned>(bytes[i + k]) : 0u);
        out += kAlphabet[(triple >> 18) & 63];
        out += kAlphabet[(triple >> 12) & 63];
        out += n > 1 ? kAlphabet[(triple >> 6) & 63] : '=';
        out += n > 2 ? kAlphabet[triple & 63] : '=';
    }
    return out;
}

VtkXmlLayout vtkXmlLayout(pugi::xml_node root, const fs::path& path) {
    VtkXmlLayout L;
    L.file = path;
    const std::string order = attr(root, "byte_order").value_or("LittleEndian");
    if (order != "LittleEndian" && order != "BigEndian") fail(path, "byte_order '" + order + "' is unknown");
    L.endian = order == "BigEndian" ? Endian::Big : Endian::Little;
    L.swap = L.endian != hostEndian();
    const std::string headerType = attr(root, "header_type").value_or("UInt32");
    if (headerType == "UInt64")
        L.headerWord = 8;
    else if (headerType != "UInt32")
        fail(path, "header_type '" + headerType + "' is unknown");
    if (auto comp = attr(root, "compressor")) {
        if (*comp == "vtkZLibDataCompressor")
            L.compressed = true;
        else if (!comp->empty())
            unsupported(path, "compressor " + *comp + " is not supported (only vtkZLibDataCompressor)");
    }
    return L;
}

VtkXmlPayload::VtkXmlPayload(const VtkXmlDocument& doc, std::span<const std::byte> bytes, VtkXmlLayout layout)
    : layout_(std::move(layout)), text_(asText(bytes)) {
    const fs::path& path = layout_.file;
    const std::string_view text = text_;
    // Appended section: "_" then raw bytes or base64 text up to the closing tags at the end of the file.
    const std::vector<pugi::xml_node> sections = elementsNamed(doc.xml, "AppendedData");
    if (sections.empty()) return;
    hasAppended_ = true;
    const std::string enc = attr(sections.front(), "encoding").value_or("raw");
    if (enc != "raw" && enc != "base64") fail(path, "AppendedData encoding '" + enc + "' is unknown");
    appendedBase64_ = enc == "base64";
    std::size_t p = doc.appendedStart;
    while (p < text.size() && std::isspace(static_cast<unsigned char>(text[p])))
        ++p;
    if (p >= text.size() || text[p] != '_') fail(path, "truncated: AppendedData has no '_' marker");
    const std::size_t begin = p + 1;
    const std::size_t close = text.rfind("</AppendedData>");
    if (close == std::string_view::npos || close < begin) fail(path, "truncated: </AppendedData> is missing");
    const std::string_view tail = trim(text.substr(close + std::string_view("</AppendedData>").size()));
    if (tail != "</VTKFile>") fail(path, "truncated or trailing garbage: the file must end with </VTKFile>");
    appended_ = bytes.subspan(begin, close - begin);
    if (appendedBase64_) return;

    // Raw appended data must be fully accounted for: every array's stored span ends inside it and
    // nothing but whitespace follows the last one.
    std::size_t appendedEnd = 0;
    for (pugi::xml_node e : elementsNamed(doc.xml, "DataArray")) {
        if (attr(e, "format").value_or("") != "appended") continue;
        const long long off = requireInt(attr(e, "offset").value_or(""), path, "DataArray offset");
        if (off < 0 || static_cast<std::size_t>(off) > appended_.size())
            fail(path, "truncated: array offset " + std::to_string(off) + " is outside the appended data");
        const BlockHeader h = parseBlockHeader(appended_.subspan(static_cast<std::size_t>(off)), layout_,
                                               attr(e, "Name").value_or("?"));
        const std::size_t end = static_cast<std::size_t>(off) + h.headerBytes + h.storedBytes;
        if (end > appended_.size())
            fail(path, "truncated: array '" + attr(e, "Name").value_or("?") +
                           "' runs past the end of the appended data");
        appendedEnd = std::max(appendedEnd, end);
    }
    if (!trim(asText(appended_.subspan(appendedEnd))).empty())
        fail(path, "oversized: " + std::to_string(appended_.size() - appendedEnd) +
                       " unexpected bytes after the appended arrays");
}

std::vector<std::byte> VtkXmlPayload::decode(pugi::xml_node da, std::size_t expectedBytes) const {
    const fs::path& path = layout_.file;
    const std::string name = attr(da, "Name").value_or("?");
    const std::string format = attr(da, "format").value_or("ascii");
    if (format == "binary") {
        std::size_t used = 0;
        return decodeBase64Array(stripSpaces(elementText(da)), layout_, name, expectedBytes, &used);
    }
    if (format != "appended") fail(path, "array '" + name + "': format '" + format + "' is unknown");
    if (!hasAppended_) fail(path, "array '" + name + "' is appended but the file has no AppendedData");
    const long long off = requireInt(attr(da, "offset").value_or(""), path, "DataArray offset");
    if (off < 0 || static_cast<std::size_t>(off) > appended_.size())
        fail(path, "truncated: array '" + name + "' offset " + std::to_string(off) +
                       " is outside the appended data");
    if (appendedBase64_) {
        const std::string chars = stripSpaces(asText(appended_.subspan(static_cast<std::size_t>(off))));
        std::size_t used = 0;
        return decodeBase64Array(chars, layout_, name, expectedBytes, &used);
    }
    return decodeBlocks(appended_.subspan(static_cast<std::size_t>(off)), layout_, name, expectedBytes);
}

VtkXmlEncodedArray encodeVtkXmlArray(std::span<const std::byte> raw, bool zlib) {
    constexpr std::size_t kZlibBlock = 32768;
    VtkXmlEncodedArray e;
    if (!zlib) {
        appendLittle<std::uint64_t>(e.header, raw.size());
        e.data.assign(raw.begin(), raw.end());
        return e;
    }
    const std::size_t blocks = (raw.size() + kZlibBlock - 1) / kZlibBlock;
    const std::size_t last = raw.size() - (blocks ? (blocks - 1) * kZlibBlock : 0);
    appendLittle<std::uint64_t>(e.header, blocks);
    appendLittle<std::uint64_t>(e.header, kZlibBlock);
    appendLittle<std::uint64_t>(e.header, blocks ? last : 0);
    for (std::size_t b = 0; b < blocks; ++b) {
        const std::size_t n = b + 1 == blocks ? last : kZlibBlock;
        const auto c = deflateBytes(raw.subspan(b * kZlibBlock, n), Wrapper::Zlib);
        appendLittle<std::uint64_t>(e.header, c.size());
        e.data.insert(e.data.end(), c.begin(), c.end());
    }
    return e;
}

std::string xmlEscape(std::string_view s) {
    std::string out;
    for (char c : s) {
        switch (c) {
        case '&':
            out += "&amp;";
            break;
        case '<':
            out += "&lt;";
            break;
        case '>':
            out += "&gt;";
            break;
        case '"':
            out += "&quot;";
            break;
        default:
            out += c;
        }
    }
    return out;
}

} // namespace volcl::io
