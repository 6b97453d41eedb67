// numpy .npy files (format versions 1.0, 2.0, 3.0): 3D a[z, y, x] volumes and 4D a[t, z, y, x] series.
#include "core/AtomicFile.hpp"
#include "host/io/IoDetail.hpp"

#include <cstring>

namespace volcl::io {

namespace fs = std::filesystem;

namespace {

constexpr char kMagic[] = "\x93NUMPY";
constexpr std::size_t kMagicSize = 6;

struct NpyHeader {
    SampleType type = SampleType::UInt8;
    Endian endian = Endian::Little;
    bool fortranOrder = false;
    std::vector<std::size_t> shape;
    std::size_t dataOffset = 0;
};

// The value text of `'key':` in the header's dict literal, up to the next top-level comma or brace.
std::string_view dictValue(std::string_view dict, std::string_view key, const fs::path& file) {
    for (const char quote : {'\'', '"'}) {
        const std::string quoted = std::string(1, quote) + std::string(key) + quote;
        std::size_t at = dict.find(quoted);
        if (at == std::string_view::npos) continue;
        at = dict.find(':', at + quoted.size());
        if (at == std::string_view::npos) break;
        std::size_t end = at + 1;
        int depth = 0;
        while (end < dict.size()) {
            const char c = dict[end];
            if (c == '(' || c == '[') ++depth;
            if (c == ')' || c == ']') --depth;
            if (depth == 0 && (c == ',' || c == '}')) break;
            if (depth < 0) break;
            ++end;
        }
        return trim(dict.substr(at + 1, end - at - 1));
    }
    fail(file, "the .npy header has no '" + std::string(key) + "'");
}

SampleType npyType(std::string_view descr, Endian& endian, const fs::path& file) {
    std::string_view d = descr;
    if (d.size() >= 2 && (d.front() == '\'' || d.front() == '"') && d.back() == d.front())
        d = d.substr(1, d.size() - 2);
    else
        unsupported(file,
                    "dtype " + std::string(descr) + " is not a plain numeric type (a structured dtype)");
    if (d.size() < 3) fail(file, "dtype '" + std::string(d) + "' is not a numpy type string");
    const char order = d[0];
    if (order == '<' || order == '|')
        endian = Endian::Little;
    else if (order == '>')
        endian = Endian::Big;
    else if (order == '=')
        endian = hostEndian();
    else
        fail(file, "dtype '" + std::string(d) + "' has no byte order");
    static const std::pair<std::string_view, SampleType> types[] = {
        {"u1", SampleType::UInt8},   {"i1", SampleType::Int8},   {"u2", SampleType::UInt16},
        {"i2", SampleType::Int16},   {"u4", SampleType::UInt32}, {"i4", SampleType::Int32},
        {"u8", SampleType::UInt64},  {"i8", SampleType::Int64},  {"f4", SampleType::Float32},
        {"f8", SampleType::Float64},
    };
    for (const auto& [code, t] : types)
        if (d.substr(1) == code) return t;
    unsupported(file, "dtype '" + std::string(d) +
                          "' is not a volume type (numpy uint8, int8, uint16, int16, uint32, int32, uint64, "
                          "int64, float32, float64)");
}

std::vector<std::size_t> npyShape(std::string_view text, const fs::path& file) {
    if (text.size() < 2 || text.front() != '(' || text.back() != ')')
        fail(file, "the .npy shape " + std::string(text) + " is not a tuple");
    std::vector<std::size_t> shape;
    std::string_view rest = text.substr(1, text.size() - 2);
    while (!trim(rest).empty()) {
        const std::size_t comma = rest.find(',');
        const std::string_view item = trim(rest.substr(0, comma));
        if (!item.empty()) {
            const auto n = parseNumber<std::size_t>(item);
            if (!n) fail(file, "the .npy shape " + std::string(text) + " is not a tuple of sizes");
            shape.push_back(*n);
        }
        if (comma == std::string_view::npos) break;
        rest.remove_prefix(comma + 1);
    }
    return shape;
}

NpyHeader parseHeader(std::span<const std::byte> bytes, const fs::path& file) {
    if (bytes.size() < 10 || std::memcmp(bytes.data(), kMagic, kMagicSize) != 0)
        fail(file, "not a .npy file (no \\x93NUMPY magic)");
    const auto major = std::to_integer<unsigned>(bytes[6]);
    std::size_t headerLength = 0;
    std::size_t start = 0;
    if (major == 1) {
        headerLength = std::to_integer<std::size_t>(bytes[8]) | std::to_integer<std::size_t>(bytes[9]) << 8;
        start = 10;
    } else if (major == 2 || major == 3) {
        if (bytes.size() < 12) fail(file, "truncated .npy header");
        for (int i = 0; i < 4; ++i)
            headerLength |= std::to_integer<std::size_t>(bytes[8 + i]) << (8 * i);
        start = 12;
    } else {
        fail(file, ".npy format version " + std::to_string(major) + "." +
                       std::to_string(std::to_integer<unsigned>(bytes[7])) + " is not 1.0, 2.0 or 3.0");
    }
    if (headerLength > bytes.size() - start) fail(file, "truncated .npy header");
    const std::string_view dict = asText(bytes.subspan(start, headerLength));
    NpyHeader h;
    h.dataOffset = start + headerLength;
    h.type = npyType(dictValue(dict, "descr", file), h.endian, file);
    const std::string_view fortran = dictValue(dict, "fortran_order", file);
    if (fortran != "True" && fortran != "False")
        fail(file, "fortran_order " + std::string(fortran) + " is not True or False");
    h.fortranOrder = fortran == "True";
    h.shape = npyShape(dictValue(dict, "shape", file), file);
    if (h.shape.size() != 3 && h.shape.size() != 4)
        unsupported(file,
                    "a .npy volume is a 3D array a[z, y, x] or a 4D series a[t, z, y, x]; this one has " +
                        std::to_string(h.shape.size()) + " dimensions");
    return h;
}

} // namespace

TimeSeries readNpy(ReadContext& ctx) {
    const fs::path& path = ctx.file();
    const std::vector<std::byte> bytes = readFileBytes(path);
    const NpyHeader h = parseHeader(bytes, path);
    const bool series = h.shape.size() == 4;
    const std::size_t frames = series ? h.shape[0] : 1;
    const std::size_t* s = h.shape.data() + (series ? 1 : 0);
    const Dims dims{s[2], s[1], s[0]};
    const std::size_t voxels = ctx.voxelCount(dims, frames, h.type);
    const std::size_t payload = checkedByteCount(voxels, sampleSize(h.type), path);
    const std::size_t have = bytes.size() - h.dataOffset;
    if (have != payload)
        fail(path, std::string(have < payload ? "truncated" : "oversized") + ": the data has " +
                       std::to_string(have) + " bytes, a " + sampleTypeName(h.type).data() + " array of " +
                       std::to_string(voxels) + " elements needs " + std::to_string(payload));
    const auto data = std::span<const std::byte>(bytes).subspan(h.dataOffset);
    const std::array<double, 3> spacing{1.0, 1.0, 1.0}, origin{0.0, 0.0, 0.0};
    if (!h.fortranOrder) return decodeFrames(data, h.type, h.endian, dims, frames, spacing, origin);
    // Fortran order: the first index varies fastest, so element [t, k, j, i] sits at
    // t + nt (k + nz (j + ny i)). Decoded in file order, then gathered into x-fastest frames.
    Volume all(Dims{voxels, 1, 1}, volumeTypeFor(h.type));
    decodeSamples(data, h.type, h.endian, all);
    const std::size_t size = scalarSize(all.type());
    const std::span<const std::byte> from = all.bytes();
    TimeSeries out;
    for (std::size_t t = 0; t < frames; ++t) {
        Volume v(dims, all.type());
        std::span<std::byte> to = v.bytes();
        for (std::size_t k = 0; k < dims.z; ++k)
            for (std::size_t j = 0; j < dims.y; ++j)
                for (std::size_t i = 0; i < dims.x; ++i) {
                    const std::size_t src = t + frames * (k + dims.z * (j + dims.y * i));
                    std::memcpy(to.data() + v.index(i, j, k) * size, from.data() + src * size, size);
                }
        out.frames.push_back(std::move(v));
    }
    return out;
}

void writeNpy(std::span<const Volume> frames, const fs::path& path, const WriteOptions& options) {
    const Volume& first = frames.front();
    const char* descr = "|u1";
    switch (first.type()) {
    case ScalarType::UInt8:
        break;
    case ScalarType::UInt16:
        descr = options.endian == Endian::Little ? "<u2" : ">u2";
        break;
    case ScalarType::Int16:
        descr = options.endian == Endian::Little ? "<i2" : ">i2";
        break;
    case ScalarType::Float32:
        descr = options.endian == Endian::Little ? "<f4" : ">f4";
        break;
    case ScalarType::Float64:
        descr = options.endian == Endian::Little ? "<f8" : ">f8";
        break;
    }
    const Dims& d = first.dims();
    std::string shape = "(";
    if (frames.size() > 1) shape += std::to_string(frames.size()) + ", ";
    shape += std::to_string(d.z) + ", " + std::to_string(d.y) + ", " + std::to_string(d.x) + ")";
    std::string header =
        std::string("{'descr': '") + descr + "', 'fortran_order': False, 'shape': " + shape + ", }";
    // Version 1.0 while the header fits its 16-bit length, else 2.0; the data starts on a 64-byte boundary.
    const bool v1 = header.size() + 1 + 10 < 65536;
    const std::size_t prefix = v1 ? 10 : 12;
    header.append((64 - (prefix + header.size() + 1) % 64) % 64, ' ');
    header += '\n';
    std::string head(kMagic, kMagicSize);
    head += char(v1 ? 1 : 2);
    head += char(0);
    for (std::size_t i = 0; i < prefix - 8; ++i)
        head += char((header.size() >> (8 * i)) & 0xFF);
    head += header;
    AtomicFile out(path);
    out.write(std::as_bytes(std::span<const char>(head.data(), head.size())));
    for (const Volume& v : frames)
        writeVoxelsInOrder(out, v, options.endian);
    out.commit();
}

} // namespace volcl::io
