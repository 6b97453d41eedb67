// Shared reader/writer helpers: sample conversion to the volume model, zlib with exact sizes, text parsing.
#include "host/io/IoDetail.hpp"

#include "core/AtomicFile.hpp"
#include "core/MemoryBudget.hpp"
#include "core/PrintableMessage.hpp"

#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <bit>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <limits>
#include <type_traits>

namespace volcl::io {

namespace fs = std::filesystem;

std::size_t sampleSize(SampleType t) noexcept {
    switch (t) {
    case SampleType::Int8:
    case SampleType::UInt8:
        return 1;
    case SampleType::Int16:
    case SampleType::UInt16:
        return 2;
    case SampleType::Int32:
    case SampleType::UInt32:
    case SampleType::Float32:
        return 4;
    case SampleType::Int64:
    case SampleType::UInt64:
    case SampleType::Float64:
        return 8;
    }
    return 1;
}

std::string_view sampleTypeName(SampleType t) noexcept {
    switch (t) {
    case SampleType::Int8:
        return "int8";
    case SampleType::UInt8:
        return "uint8";
    case SampleType::Int16:
        return "int16";
    case SampleType::UInt16:
        return "uint16";
    case SampleType::Int32:
        return "int32";
    case SampleType::UInt32:
        return "uint32";
    case SampleType::Int64:
        return "int64";
    case SampleType::UInt64:
        return "uint64";
    case SampleType::Float32:
        return "float32";
    case SampleType::Float64:
        return "float64";
    }
    return "?";
}

ScalarType volumeTypeFor(SampleType t) noexcept {
    switch (t) {
    case SampleType::UInt8:
        return ScalarType::UInt8;
    case SampleType::Int8:
    case SampleType::Int16:
        return ScalarType::Int16;
    case SampleType::UInt16:
        return ScalarType::UInt16;
    case SampleType::Float64:
        return ScalarType::Float64;
    default:
        return ScalarType::Float32;
    }
}

SampleType sampleTypeOf(ScalarType t) noexcept {
    switch (t) {
    case ScalarType::UInt8:
        return SampleType::UInt8;
    case ScalarType::UInt16:
        return SampleType::UInt16;
    case ScalarType::Int16:
        return SampleType::Int16;
    case ScalarType::Float32:
        return SampleType::Float32;
    case ScalarType::Float64:
        return SampleType::Float64;
    }
    return SampleType::UInt8;
}

std::optional<SampleType> vtkLegacyType(std::string_view name) {
    static const std::pair<std::string_view, SampleType> types[] = {
        {"unsigned_char", SampleType::UInt8},
        {"char", SampleType::Int8},
        {"signed_char", SampleType::Int8},
        {"unsigned_short", SampleType::UInt16},
        {"short", SampleType::Int16},
        {"unsigned_int", SampleType::UInt32},
        {"int", SampleType::Int32},
        {"unsigned_long", SampleType::UInt64},
        {"long", SampleType::Int64},
        {"vtktypeint8", SampleType::Int8},
        {"vtktypeuint8", SampleType::UInt8},
        {"vtktypeint16", SampleType::Int16},
        {"vtktypeuint16", SampleType::UInt16},
        {"vtktypeint32", SampleType::Int32},
        {"vtktypeuint32", SampleType::UInt32},
        {"vtktypeint64", SampleType::Int64},
        {"vtktypeuint64", SampleType::UInt64},
        {"float", SampleType::Float32},
        {"double", SampleType::Float64},
    };
    const std::string l = lower(name);
    for (const auto& [n, t] : types)
        if (n == l) return t;
    return std::nullopt;
}

// Header values quoted in `problem` may hold NUL or control bytes: escaped here, since what() is a C string
// that a NUL would cut short.
void fail(const fs::path& file, const std::string& problem) {
    throw IoError(file.string() + ": " + printableMessage(problem));
}
void unsupported(const fs::path& file, const std::string& problem) {
    throw DataError(file.string() + ": " + printableMessage(problem));
}

namespace {
// No real file holds more than 2^48 bytes; anything above is a corrupt or lying header.
constexpr std::size_t kMaxPayloadBytes = std::size_t{1} << 48;
} // namespace

ReadContext::ReadContext(fs::path file, const ReadOptions& options)
    : file_(std::move(file)), options_(options), files_{file_} {}

fs::path ReadContext::dataFile(std::string_view name) {
    if (name.find('\0') != std::string_view::npos) fail(file_, "data file name contains a NUL byte");
    const fs::path named{std::string(name)};
    const fs::path resolved = named.is_absolute() ? named : file_.parent_path() / named;
    if (!options_.allowExternalData) {
        // Compare resolved real paths, so neither `..` nor a symbolic link leads out of the directory. Both
        // absolute first: weakly_canonical leaves a relative path whose first part does not exist relative.
        std::error_code ec;
        if (headerDirectory_.empty())
            headerDirectory_ = fs::weakly_canonical(
                fs::absolute(file_.parent_path().empty() ? fs::path(".") : file_.parent_path(), ec), ec);
        const fs::path& dir = headerDirectory_;
        const fs::path target = fs::weakly_canonical(fs::absolute(resolved, ec), ec);
        const auto [d, t] = std::mismatch(dir.begin(), dir.end(), target.begin(), target.end());
        if (ec || dir.empty() || d != dir.end() || t == target.end())
            fail(file_, "data file '" + std::string(name) +
                            "' lies outside the header's directory (allow it with --allow-external-data)");
    }
    // A header may name up to a million files; the first that is missing ends the read here, not after every
    // name was resolved (a 108-byte MetaImage header naming 177,776 absent files took 1 s, 24 s under the
    // sanitizers).
    std::error_code ec;
    if (!fs::is_regular_file(resolved, ec))
        fail(file_, "data file '" + resolved.string() + "' does not exist or is not a regular file");
    files_.push_back(resolved);
    return resolved;
}

std::size_t ReadContext::voxelCount(const Dims& dims, std::size_t frames, SampleType st) const {
    const std::size_t voxels = checkedVoxelCount(dims, frames, file_);
    // The file's samples and the converted volume are both in memory at once.
    const std::size_t perVoxel = sampleSize(st) + scalarSize(volumeTypeFor(st));
    if (voxels > std::numeric_limits<std::size_t>::max() / perVoxel) fail(file_, "payload size overflows");
    claimMemory(voxels * perVoxel, "the volume");
    return voxels;
}

void ReadContext::claimMemory(std::size_t bytes, std::string_view what) const {
    checkMemoryBudget(bytes, options_.memoryBudget, file_, what);
}

namespace {
std::string dimsText(const Dims& dims, std::size_t frames) {
    std::string t = std::to_string(dims.x);
    for (std::size_t d : {dims.y, dims.z})
        t.append("x").append(std::to_string(d));
    if (frames != 1) t.append("x").append(std::to_string(frames));
    return t;
}
} // namespace

std::size_t checkedVoxelCount(const Dims& dims, std::size_t frames, const fs::path& file) {
    if (dims.x == 0 || dims.y == 0 || dims.z == 0 || frames == 0)
        fail(file, "dimensions " + dimsText(dims, frames) + " contain a zero");
    std::size_t n = 1;
    for (std::size_t d : {dims.x, dims.y, dims.z, frames}) {
        if (n > kMaxPayloadBytes / d)
            fail(file, "dimensions " + dimsText(dims, frames) + " are impossibly large");
        n *= d;
    }
    return n;
}

std::size_t checkedByteCount(std::size_t voxels, std::size_t sampleBytes, const fs::path& file) {
    if (voxels > kMaxPayloadBytes / sampleBytes) fail(file, "payload size overflows");
    return voxels * sampleBytes;
}

bool writeAll(int fd, const void* data, std::size_t n) noexcept {
    const auto* p = static_cast<const char*>(data);
    while (n > 0) {
        const ssize_t w = ::write(fd, p, n);
        if (w < 0 && errno == EINTR) continue;
        if (w <= 0) return false;
        p += w;
        n -= static_cast<std::size_t>(w);
    }
    return true;
}

bool hostIsLittleEndian() noexcept {
    return std::endian::native == std::endian::little;
}
Endian hostEndian() noexcept {
    return hostIsLittleEndian() ? Endian::Little : Endian::Big;
}

namespace {

template <class T> T loadSample(const std::byte* p, bool swap) noexcept {
    T v;
    if (!swap) {
        std::memcpy(&v, p, sizeof(T));
        return v;
    }
    std::byte tmp[sizeof(T)];
    for (std::size_t i = 0; i < sizeof(T); ++i)
        tmp[i] = p[sizeof(T) - 1 - i];
    std::memcpy(&v, tmp, sizeof(T));
    return v;
}

template <class Src, class Dst>
void convertLoop(const std::byte* src, std::size_t count, bool swap, Dst* dst) {
    if constexpr (std::is_same_v<Src, Dst>) {
        if (!swap) {
            std::memcpy(dst, src, count * sizeof(Src));
            return;
        }
    }
    for (std::size_t i = 0; i < count; ++i)
        dst[i] = static_cast<Dst>(loadSample<Src>(src + i * sizeof(Src), swap));
}

template <class Src>
void convertTo(const std::byte* src, std::size_t count, bool swap, Volume& dst, std::size_t first) {
    switch (dst.type()) {
    case ScalarType::UInt8:
        convertLoop<Src>(src, count, swap, dst.values<std::uint8_t>().data() + first);
        break;
    case ScalarType::UInt16:
        convertLoop<Src>(src, count, swap, dst.values<std::uint16_t>().data() + first);
        break;
    case ScalarType::Int16:
        convertLoop<Src>(src, count, swap, dst.values<std::int16_t>().data() + first);
        break;
    case ScalarType::Float32:
        convertLoop<Src>(src, count, swap, dst.values<float>().data() + first);
        break;
    case ScalarType::Float64:
        convertLoop<Src>(src, count, swap, dst.values<double>().data() + first);
        break;
    }
}

} // namespace

std::vector<double> decodeToDouble(std::span<const std::byte> src, SampleType st, Endian endian) {
    const std::size_t size = sampleSize(st);
    if (src.size() % size != 0) throw Error("internal: decodeToDouble called with a partial sample");
    const std::size_t count = src.size() / size;
    const bool swap = size > 1 && endian != hostEndian();
    std::vector<double> out(count);
    const std::byte* p = src.data();
    switch (st) {
    case SampleType::Int8:
        convertLoop<std::int8_t>(p, count, swap, out.data());
        break;
    case SampleType::UInt8:
        convertLoop<std::uint8_t>(p, count, swap, out.data());
        break;
    case SampleType::Int16:
        convertLoop<std::int16_t>(p, count, swap, out.data());
        break;
    case SampleType::UInt16:
        convertLoop<std::uint16_t>(p, count, swap, out.data());
        break;
    case SampleType::Int32:
        convertLoop<std::int32_t>(p, count, swap, out.data());
        break;
    case SampleType::UInt32:
        convertLoop<std::uint32_t>(p, count, swap, out.data());
        break;
    case SampleType::Int64:
        convertLoop<std::int64_t>(p, count, swap, out.data());
        break;
    case SampleType::UInt64:
        convertLoop<std::uint64_t>(p, count, swap, out.data());
        break;
    case SampleType::Float32:
        convertLoop<float>(p, count, swap, out.data());
        break;
    case SampleType::Float64:
        convertLoop<double>(p, count, swap, out.data());
        break;
    }
    return out;
}

void decodeSamples(std::span<const std::byte> src, SampleType st, Endian endian, Volume& dst,
                   std::size_t firstVoxel) {
    const std::size_t size = sampleSize(st);
    const std::size_t count = src.size() / size;
    if (dst.type() != volumeTypeFor(st) || src.size() % size != 0 || firstVoxel + count > dst.voxelCount())
        throw Error("internal: decodeSamples called with mismatched sizes or types");
    const bool swap = size > 1 && endian != hostEndian();
    const std::byte* p = src.data();
    switch (st) {
    case SampleType::Int8:
        convertTo<std::int8_t>(p, count, swap, dst, firstVoxel);
        break;
    case SampleType::UInt8:
        convertTo<std::uint8_t>(p, count, swap, dst, firstVoxel);
        break;
    case SampleType::Int16:
        convertTo<std::int16_t>(p, count, swap, dst, firstVoxel);
        break;
    case SampleType::UInt16:
        convertTo<std::uint16_t>(p, count, swap, dst, firstVoxel);
        break;
    case SampleType::Int32:
        convertTo<std::int32_t>(p, count, swap, dst, firstVoxel);
        break;
    case SampleType::UInt32:
        convertTo<std::uint32_t>(p, count, swap, dst, firstVoxel);
        break;
    case SampleType::Int64:
        convertTo<std::int64_t>(p, count, swap, dst, firstVoxel);
        break;
    case SampleType::UInt64:
        convertTo<std::uint64_t>(p, count, swap, dst, firstVoxel);
        break;
    case SampleType::Float32:
        convertTo<float>(p, count, swap, dst, firstVoxel);
        break;
    case SampleType::Float64:
        convertTo<double>(p, count, swap, dst, firstVoxel);
        break;
    }
}

TimeSeries decodeFrames(std::span<const std::byte> payload, SampleType st, Endian endian, const Dims& dims,
                        std::size_t frames, const std::array<double, 3>& spacing,
                        const std::array<double, 3>& origin) {
    TimeSeries series;
    const std::size_t frameBytes = dims.count() * sampleSize(st);
    if (payload.size() != frameBytes * frames) throw Error("internal: decodeFrames payload size mismatch");
    series.frames.reserve(frames);
    for (std::size_t f = 0; f < frames; ++f) {
        Volume v(dims, volumeTypeFor(st));
        v.spacing = spacing;
        v.origin = origin;
        decodeSamples(payload.subspan(f * frameBytes, frameBytes), st, endian, v);
        series.frames.push_back(std::move(v));
    }
    return series;
}

void requireAsciiCapacity(std::string_view text, std::size_t count, const fs::path& file) {
    if (count > text.size() / 2 + 1)
        fail(file, "truncated: " + std::to_string(text.size()) + " bytes of ASCII data cannot hold " +
                       std::to_string(count) + " values");
}

void decodeAsciiSamples(std::string_view text, SampleType st, Volume& dst, std::size_t firstVoxel,
                        std::size_t count, const fs::path& file) {
    std::size_t pos = 0, n = 0;
    auto put = [&](double v) {
        const std::size_t i = firstVoxel + n;
        switch (dst.type()) {
        case ScalarType::UInt8:
            dst.values<std::uint8_t>()[i] = static_cast<std::uint8_t>(v);
            break;
        case ScalarType::UInt16:
            dst.values<std::uint16_t>()[i] = static_cast<std::uint16_t>(v);
            break;
        case ScalarType::Int16:
            dst.values<std::int16_t>()[i] = static_cast<std::int16_t>(v);
            break;
        case ScalarType::Float32:
            dst.values<float>()[i] = static_cast<float>(v);
            break;
        case ScalarType::Float64:
            dst.values<double>()[i] = v;
            break;
        }
    };
    const bool integer = st != SampleType::Float32 && st != SampleType::Float64;
    while (true) {
        while (pos < text.size() && std::isspace(static_cast<unsigned char>(text[pos])))
            ++pos;
        if (pos >= text.size()) break;
        std::size_t end = pos;
        while (end < text.size() && !std::isspace(static_cast<unsigned char>(text[end])))
            ++end;
        const std::string_view tok = text.substr(pos, end - pos);
        if (n >= count) fail(file, "more than the expected " + std::to_string(count) + " ASCII values");
        double v = 0;
        if (integer) {
            const auto iv = parseNumber<long long>(tok);
            if (!iv) fail(file, "ASCII value '" + std::string(tok.substr(0, 32)) + "' is not an integer");
            // Range check against the file's declared type so a value never wraps silently.
            double lo = 0, hi = 0;
            switch (st) {
            case SampleType::Int8:
                lo = -128, hi = 127;
                break;
            case SampleType::UInt8:
                lo = 0, hi = 255;
                break;
            case SampleType::Int16:
                lo = -32768, hi = 32767;
                break;
            case SampleType::UInt16:
                lo = 0, hi = 65535;
                break;
            case SampleType::Int32:
                lo = -2147483648.0, hi = 2147483647.0;
                break;
            case SampleType::UInt32:
                lo = 0, hi = 4294967295.0;
                break;
            default:
                lo = -9.3e18, hi = 1.85e19;
                break;
            }
            v = static_cast<double>(*iv);
            if (v < lo || v > hi)
                fail(file, "ASCII value " + std::string(tok) + " is outside type " +
                               std::string(sampleTypeName(st)));
        } else {
            std::string t(tok);
            char* endp = nullptr;
            v = std::strtod(t.c_str(), &endp);
            if (endp != t.c_str() + t.size())
                fail(file, "ASCII value '" + std::string(tok.substr(0, 32)) + "' is not a number");
        }
        put(v);
        ++n;
        pos = end;
    }
    if (n != count)
        fail(file, "truncated: " + std::to_string(n) + " ASCII values, expected " + std::to_string(count));
}

// ---- zlib ---------------------------------------------------------------------------------------

namespace {

// Deflate cannot expand data more than ~1032:1; a header promising more than that from the bytes
// at hand is lying, and is refused before the output buffer is allocated.
constexpr std::size_t kMaxDeflateRatio = 1040;
// Bytes handed to zlib per call: zlib counts in 32-bit uInt.
constexpr std::size_t kZlibChunk = std::size_t{1} << 30;

bool isGzipMagic(std::span<const std::byte> b) noexcept {
    return b.size() >= 2 && b[0] == std::byte{0x1f} && b[1] == std::byte{0x8b};
}

class Inflater {
public:
    Inflater() {
        std::memset(&s_, 0, sizeof(s_));
        ok_ = inflateInit2(&s_, 15 + 32) == Z_OK; // 32: accept zlib and gzip headers
    }
    ~Inflater() {
        if (ok_) inflateEnd(&s_);
    }
    Inflater(const Inflater&) = delete;
    Inflater& operator=(const Inflater&) = delete;
    z_stream& s() { return s_; }
    bool ok() const { return ok_; }

private:
    z_stream s_;
    bool ok_ = false;
};

} // namespace

bool looksCompressed(std::span<const std::byte> b) noexcept {
    if (isGzipMagic(b)) return true;
    if (b.size() < 2) return false;
    const unsigned cmf = std::to_integer<unsigned>(b[0]), flg = std::to_integer<unsigned>(b[1]);
    return (cmf & 0x0f) == 8 && (cmf >> 4) <= 7 && ((cmf << 8) | flg) % 31 == 0;
}

void checkInflateRatio(std::size_t compressed, std::size_t expected, const fs::path& file,
                       std::string_view what) {
    if (expected / kMaxDeflateRatio > compressed)
        fail(file, std::string(what) + ": header promises " + std::to_string(expected) + " bytes but only " +
                       std::to_string(compressed) + " compressed bytes are present (truncated or corrupt)");
    if (expected > kInflateAnyRatioBytes && expected / kMaxInflateRatio > compressed)
        fail(file, std::string(what) + ": " + std::to_string(compressed) +
                       " compressed bytes would inflate to " + std::to_string(expected) +
                       ", more than the decompression budget of " + std::to_string(kMaxInflateRatio) +
                       ":1 above " + std::to_string(kInflateAnyRatioBytes >> 20) + " MiB");
}

std::vector<std::byte> inflateExact(std::span<const std::byte> in, std::size_t expected, const fs::path& file,
                                    std::string_view what) {
    const std::string label = std::string(what);
    if (in.empty()) fail(file, label + ": no compressed data (truncated)");
    checkInflateRatio(in.size(), expected, file, label);
    if (!looksCompressed(in)) fail(file, label + ": not a zlib/gzip stream");
    std::vector<std::byte> out(expected);
    Inflater inf;
    if (!inf.ok()) throw IoError("zlib initialisation failed");
    z_stream& s = inf.s();
    std::size_t inPos = 0, outPos = 0;
    unsigned char probe = 0;
    while (true) {
        const std::size_t inAvail = std::min(in.size() - inPos, kZlibChunk);
        s.next_in = reinterpret_cast<Bytef*>(const_cast<std::byte*>(in.data() + inPos));
        s.avail_in = static_cast<uInt>(inAvail);
        const bool outFull = outPos == out.size();
        if (outFull) {
            // Output is complete; inflating one more byte tells "ends here" from "too long".
            s.next_out = &probe;
            s.avail_out = 1;
        } else {
            s.next_out = reinterpret_cast<Bytef*>(out.data() + outPos);
            s.avail_out = static_cast<uInt>(std::min(out.size() - outPos, kZlibChunk));
        }
        const uInt outBefore = s.avail_out;
        const int rc = inflate(&s, Z_NO_FLUSH);
        inPos += inAvail - s.avail_in;
        const std::size_t produced = outBefore - s.avail_out;
        if (outFull && produced > 0)
            fail(file,
                 label + ": decompresses to more than the expected " + std::to_string(expected) + " bytes");
        outPos += outFull ? 0 : produced;
        if (rc == Z_STREAM_END) {
            const std::span<const std::byte> rest = in.subspan(inPos);
            if (rest.empty()) break;
            if (isGzipMagic(rest)) { // another gzip member follows
                inflateReset(&s);
                continue;
            }
            fail(file, label + ": " + std::to_string(rest.size()) +
                           " bytes of trailing data after the compressed stream");
        }
        if (rc == Z_DATA_ERROR)
            fail(file,
                 label + ": corrupted compressed data (" + std::string(s.msg ? s.msg : "bad stream") + ")");
        if (rc == Z_MEM_ERROR) throw IoError(file.string() + ": out of memory while decompressing");
        if (rc == Z_NEED_DICT) fail(file, label + ": compressed stream needs a preset dictionary");
        const bool stalled = produced == 0 && inAvail == s.avail_in;
        if (rc == Z_BUF_ERROR || stalled) {
            if (inPos >= in.size())
                fail(file, label + ": truncated compressed data (" + std::to_string(outPos) + " of " +
                               std::to_string(expected) + " bytes decoded)");
            if (stalled) fail(file, label + ": compressed stream makes no progress (corrupt)");
        }
    }
    if (outPos != expected)
        fail(file, label + ": decompresses to " + std::to_string(outPos) + " bytes, expected " +
                       std::to_string(expected));
    return out;
}

std::vector<std::byte> inflatePrefix(std::span<const std::byte> in, std::size_t n, const fs::path& file) {
    std::vector<std::byte> out(n);
    if (!looksCompressed(in)) fail(file, "not a gzip/zlib stream");
    Inflater inf;
    if (!inf.ok()) throw IoError("zlib initialisation failed");
    z_stream& s = inf.s();
    s.next_in = reinterpret_cast<Bytef*>(const_cast<std::byte*>(in.data()));
    s.avail_in = static_cast<uInt>(std::min<std::size_t>(in.size(), std::numeric_limits<uInt>::max()));
    s.next_out = reinterpret_cast<Bytef*>(out.data());
    s.avail_out = static_cast<uInt>(n);
    while (s.avail_out > 0) {
        const int rc = inflate(&s, Z_NO_FLUSH);
        if (rc == Z_STREAM_END) break;
        if (rc == Z_DATA_ERROR)
            fail(file, "corrupted compressed data (" + std::string(s.msg ? s.msg : "bad stream") + ")");
        if (rc != Z_OK) break;
    }
    out.resize(n - s.avail_out);
    return out;
}

std::vector<std::byte> deflateBytes(std::span<const std::byte> data, Wrapper wrapper, int level) {
    z_stream s;
    std::memset(&s, 0, sizeof(s));
    if (deflateInit2(&s, level, Z_DEFLATED, wrapper == Wrapper::Gzip ? 15 + 16 : 15, 8, Z_DEFAULT_STRATEGY) !=
        Z_OK)
        throw IoError("zlib initialisation failed");
    std::vector<std::byte> out;
    out.resize(deflateBound(&s, static_cast<uLong>(std::min<std::size_t>(data.size(), kZlibChunk))) + 64);
    std::size_t inPos = 0, outPos = 0;
    int rc = Z_OK;
    while (rc != Z_STREAM_END) {
        const std::size_t inAvail = std::min(data.size() - inPos, kZlibChunk);
        s.next_in = reinterpret_cast<Bytef*>(const_cast<std::byte*>(data.data() + inPos));
        s.avail_in = static_cast<uInt>(inAvail);
        if (out.size() - outPos < (1u << 16)) out.resize(out.size() * 2 + (1u << 16));
        s.next_out = reinterpret_cast<Bytef*>(out.data() + outPos);
        s.avail_out = static_cast<uInt>(std::min(out.size() - outPos, kZlibChunk));
        const uInt outBefore = s.avail_out;
        const bool last = inPos + inAvail == data.size();
        rc = deflate(&s, last ? Z_FINISH : Z_NO_FLUSH);
        inPos += inAvail - s.avail_in;
        outPos += outBefore - s.avail_out;
        if (rc == Z_STREAM_ERROR) {
            deflateEnd(&s);
            throw IoError("zlib compression failed");
        }
    }
    deflateEnd(&s);
    out.resize(outPos);
    return out;
}

void writeFileAtomically(const std::filesystem::path& path, std::span<const std::byte> bytes) {
    AtomicFile out(path);
    if (endsWithI(path.filename().string(), ".gz"))
        out.write(deflateBytes(bytes, Wrapper::Gzip));
    else
        out.write(bytes);
    out.commit();
}

std::vector<std::byte> bytesInOrder(const Volume& v, Endian endian) {
    std::vector<std::byte> out(v.bytes().begin(), v.bytes().end());
    const std::size_t size = scalarSize(v.type());
    if (size > 1 && endian != hostEndian())
        for (std::size_t i = 0; i + size <= out.size(); i += size)
            std::reverse(out.begin() + i, out.begin() + i + size);
    return out;
}

void writeVoxelsInOrder(AtomicFile& out, const Volume& v, Endian endian) {
    const std::span<const std::byte> bytes = v.bytes();
    const std::size_t size = scalarSize(v.type());
    if (size == 1 || endian == hostEndian()) {
        out.write(bytes);
        return;
    }
    constexpr std::size_t kChunk = std::size_t(1) << 20; // a multiple of every voxel size
    std::vector<std::byte> chunk;
    for (std::size_t at = 0; at < bytes.size(); at += kChunk) {
        const auto part = bytes.subspan(at, std::min(kChunk, bytes.size() - at));
        chunk.assign(part.begin(), part.end());
        for (std::size_t i = 0; i + size <= chunk.size(); i += size)
            std::reverse(chunk.begin() + std::ptrdiff_t(i), chunk.begin() + std::ptrdiff_t(i + size));
        out.write(chunk);
    }
}

// ---- text ---------------------------------------------------------------------------------------

std::string_view trim(std::string_view s) noexcept {
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front())))
        s.remove_prefix(1);
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back())))
        s.remove_suffix(1);
    return s;
}

std::string lower(std::string_view s) {
    std::string r(s);
    for (char& c : r)
        c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return r;
}

bool iequals(std::string_view a, std::string_view b) noexcept {
    if (a.size() != b.size()) return false;
    for (std::size_t i = 0; i < a.size(); ++i)
        if (std::tolower(static_cast<unsigned char>(a[i])) != std::tolower(static_cast<unsigned char>(b[i])))
            return false;
    return true;
}

bool endsWithI(std::string_view s, std::string_view suffix) noexcept {
    return s.size() >= suffix.size() && iequals(s.substr(s.size() - suffix.size()), suffix);
}

std::vector<std::string_view> splitWords(std::string_view s) {
    std::vector<std::string_view> words;
    std::size_t i = 0;
    while (i < s.size()) {
        while (i < s.size() && std::isspace(static_cast<unsigned char>(s[i])))
            ++i;
        std::size_t j = i;
        while (j < s.size() && !std::isspace(static_cast<unsigned char>(s[j])))
            ++j;
        if (j > i) words.push_back(s.substr(i, j - i));
        i = j;
    }
    return words;
}

std::string_view asText(std::span<const std::byte> bytes) noexcept {
    return {reinterpret_cast<const char*>(bytes.data()), bytes.size()};
}

std::optional<std::string_view> nextLine(std::string_view text, std::size_t& pos) {
    if (pos >= text.size()) return std::nullopt;
    const std::size_t nl = text.find('\n', pos);
    std::string_view line =
        text.substr(pos, nl == std::string_view::npos ? std::string_view::npos : nl - pos);
    pos = nl == std::string_view::npos ? text.size() : nl + 1;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    return line;
}

double requireDouble(std::string_view token, const fs::path& file, std::string_view what) {
    std::string t(trim(token));
    if (!t.empty() && t.size() < 64) {
        char* end = nullptr;
        const double v = std::strtod(t.c_str(), &end);
        if (end == t.c_str() + t.size()) return v;
    }
    fail(file, std::string(what) + ": '" + std::string(token.substr(0, 40)) + "' is not a number");
}

long long requireInt(std::string_view token, const fs::path& file, std::string_view what) {
    if (auto v = parseNumber<long long>(token)) return *v;
    fail(file, std::string(what) + ": '" + std::string(token.substr(0, 40)) + "' is not an integer");
}

std::array<double, 3> requireTriple(const std::vector<std::string_view>& words, std::size_t first,
                                    const fs::path& file, std::string_view what, bool positive) {
    if (words.size() < first + 3) fail(file, std::string(what) + " needs 3 values");
    std::array<double, 3> r{};
    for (int i = 0; i < 3; ++i) {
        r[i] = requireDouble(words[first + i], file, what);
        if (!std::isfinite(r[i]) || (positive && r[i] <= 0))
            fail(file, std::string(what) + ": value " + std::string(words[first + i]) + " is not " +
                           (positive ? "a positive finite number" : "finite"));
    }
    return r;
}

std::array<std::size_t, 4> requireSizes(std::string_view text, std::size_t count, const fs::path& file,
                                        std::string_view what) {
    const auto words = splitWords(text);
    if (words.size() != count)
        fail(file, std::string(what) + " has " + std::to_string(words.size()) + " entries for " +
                       std::to_string(count) + " dimensions");
    std::array<std::size_t, 4> sizes{1, 1, 1, 1};
    for (std::size_t i = 0; i < words.size() && i < 4; ++i) {
        const long long v = requireInt(words[i], file, what);
        if (v <= 0) fail(file, std::string(what) + ": size " + std::string(words[i]) + " must be positive");
        sizes[i] = static_cast<std::size_t>(v);
    }
    return sizes;
}

Dims requireDims(const std::vector<std::string_view>& words, std::size_t first, std::size_t count,
                 const fs::path& file, std::string_view what) {
    if (words.size() < first + count)
        fail(file, std::string(what) + " needs " + std::to_string(count) + " values");
    std::size_t d[3] = {1, 1, 1};
    for (std::size_t i = 0; i < count && i < 3; ++i) {
        const long long v = requireInt(words[first + i], file, what);
        if (v <= 0)
            fail(file, std::string(what) + ": size " + std::string(words[first + i]) + " must be positive");
        d[i] = static_cast<std::size_t>(v);
    }
    return {d[0], d[1], d[2]};
}

std::string formatDouble(double v) {
    char buf[64];
    auto [ptr, ec] = std::to_chars(buf, buf + sizeof(buf), v);
    return std::string(buf, ec == std::errc() ? ptr : buf);
}

std::size_t maxDataFiles(const Dims& dims, std::size_t frames) noexcept {
    constexpr std::size_t kMaxFiles = 1'000'000;
    std::size_t rows = 1;
    for (std::size_t n : {dims.y, dims.z, frames}) {
        if (n == 0) return 0;
        if (rows > kMaxFiles / n) return kMaxFiles;
        rows *= n;
    }
    return std::min(rows, kMaxFiles);
}

std::vector<std::string> expandFilePattern(std::string_view pattern, long long first, long long last,
                                           long long step, const fs::path& header, std::size_t maxFiles,
                                           std::size_t evenlyHeldBytes) {
    // Locate the single integer conversion; everything else is literal ("%%" is a literal %).
    std::string prefix, suffix;
    bool found = false, zeroPad = false, leftAlign = false;
    int width = 0;
    for (std::size_t i = 0; i < pattern.size(); ++i) {
        const char c = pattern[i];
        if (c != '%') {
            (found ? suffix : prefix) += c;
            continue;
        }
        if (i + 1 < pattern.size() && pattern[i + 1] == '%') {
            (found ? suffix : prefix) += '%';
            ++i;
            continue;
        }
        if (found)
            fail(header, "data file pattern '" + std::string(pattern) + "' has more than one % conversion");
        std::size_t j = i + 1;
        while (j < pattern.size() && (pattern[j] == '0' || pattern[j] == '-')) {
            zeroPad |= pattern[j] == '0';
            leftAlign |= pattern[j] == '-';
            ++j;
        }
        while (j < pattern.size() && std::isdigit(static_cast<unsigned char>(pattern[j])) && width < 100)
            width = width * 10 + (pattern[j++] - '0');
        if (j >= pattern.size() || (pattern[j] != 'd' && pattern[j] != 'i' && pattern[j] != 'u'))
            fail(header, "data file pattern '" + std::string(pattern) + "' needs one %d conversion");
        found = true;
        i = j;
    }
    if (!found) fail(header, "data file pattern '" + std::string(pattern) + "' has no %d conversion");
    if (step == 0 || (step > 0 && last < first) || (step < 0 && last > first))
        fail(header, "data file range " + std::to_string(first) + " " + std::to_string(last) + " " +
                         std::to_string(step) + " is empty or endless");
    // Computed in unsigned arithmetic: first - last of two huge values would overflow a long long.
    const unsigned long long span =
        step > 0 ? static_cast<unsigned long long>(last) - static_cast<unsigned long long>(first)
                 : static_cast<unsigned long long>(first) - static_cast<unsigned long long>(last);
    const unsigned long long stride =
        step > 0 ? static_cast<unsigned long long>(step) : 0ULL - static_cast<unsigned long long>(step);
    // span / stride + 1 wraps to 0 for the full long long range: compare before adding the 1.
    const unsigned long long gaps = span / stride;
    if (gaps >= maxFiles)
        fail(header, "data file range " + std::to_string(first) + " " + std::to_string(last) + " " +
                         std::to_string(step) + " lists " +
                         (gaps == ~0ULL ? std::string("2^64") : std::to_string(gaps + 1)) + " files for " +
                         std::to_string(maxFiles) + " possible (each file holds at least one slice)");
    const unsigned long long count = gaps + 1;
    // The same refusal readDetachedPayload makes, before hundreds of thousands of names are built and checked.
    if (evenlyHeldBytes != 0 && evenlyHeldBytes % count != 0)
        fail(header, std::to_string(count) + " data files cannot evenly hold " +
                         std::to_string(evenlyHeldBytes) + " bytes");
    std::vector<std::string> names;
    names.reserve(static_cast<std::size_t>(count));
    for (unsigned long long k = 0; k < count; ++k) {
        // Unsigned: first + k * step stays in [first, last] but k * step alone may not fit a long long.
        const auto v = static_cast<long long>(static_cast<unsigned long long>(first) +
                                              k * static_cast<unsigned long long>(step));
        std::string digits = std::to_string(v < 0 ? 0ULL - static_cast<unsigned long long>(v)
                                                  : static_cast<unsigned long long>(v));
        std::string number = (v < 0 ? "-" : "");
        const int len = static_cast<int>(digits.size() + number.size());
        if (zeroPad && !leftAlign && len < width)
            number += std::string(static_cast<std::size_t>(width - len), '0');
        number += digits;
        if (static_cast<int>(number.size()) < width) {
            const std::string pad(static_cast<std::size_t>(width) - number.size(), ' ');
            number = leftAlign ? number + pad : pad + number;
        }
        names.push_back(prefix + number + suffix);
    }
    return names;
}

std::vector<std::byte> readDetachedPayload(const fs::path& header, const std::vector<fs::path>& files,
                                           std::size_t totalBytes, PayloadEncoding encoding,
                                           long long byteSkip, std::size_t lineSkip) {
    if (files.empty()) fail(header, "no data files listed");
    if (encoding != PayloadEncoding::Ascii && totalBytes % files.size() != 0)
        fail(header, std::to_string(files.size()) + " data files cannot evenly hold " +
                         std::to_string(totalBytes) + " bytes");
    const std::size_t part = encoding == PayloadEncoding::Ascii ? 0 : totalBytes / files.size();
    std::vector<std::byte> out;
    if (encoding != PayloadEncoding::Ascii) out.reserve(totalBytes);
    for (const fs::path& f : files) {
        std::error_code ec;
        if (!fs::is_regular_file(f, ec))
            fail(header, "data file '" + f.string() + "' does not exist or is not a regular file");
        // Refuse before reading when a raw file cannot possibly hold its part.
        if (encoding == PayloadEncoding::Raw && fs::file_size(f, ec) < part)
            fail(f, "truncated: " + std::to_string(fs::file_size(f, ec)) + " bytes, expected " +
                        std::to_string(part));
        std::vector<std::byte> bytes = readFileBytes(f);
        std::size_t pos = 0;
        for (std::size_t l = 0; l < lineSkip; ++l) {
            while (pos < bytes.size() && bytes[pos] != std::byte{'\n'})
                ++pos;
            if (pos >= bytes.size())
                fail(f, "truncated: fewer than " + std::to_string(lineSkip) + " lines to skip");
            ++pos;
        }
        std::span<const std::byte> rest(bytes.data() + pos, bytes.size() - pos);
        if (encoding == PayloadEncoding::Ascii) {
            out.insert(out.end(), rest.begin(), rest.end());
            out.push_back(std::byte{'\n'});
            continue;
        }
        std::vector<std::byte> inflated;
        if (encoding == PayloadEncoding::Compressed) {
            // byte skip counts decoded bytes here; the decoded size is part + skip (skip -1 is raw-only).
            if (byteSkip < 0) fail(header, "byte skip -1 is only valid for raw data");
            inflated = inflateExact(rest, part + static_cast<std::size_t>(byteSkip), f, "compressed data");
            rest = std::span<const std::byte>(inflated).subspan(static_cast<std::size_t>(byteSkip));
        } else if (byteSkip < 0) {
            if (rest.size() < part)
                fail(f, "truncated: " + std::to_string(rest.size()) + " bytes, expected " +
                            std::to_string(part));
            rest = rest.subspan(rest.size() - part);
        } else {
            const std::size_t skip = static_cast<std::size_t>(byteSkip);
            if (rest.size() < skip + part)
                fail(f, "truncated: " + std::to_string(rest.size()) + " bytes, expected " +
                            std::to_string(skip + part));
            if (rest.size() > skip + part)
                fail(f, "oversized: " + std::to_string(rest.size() - skip - part) +
                            " unexpected trailing bytes");
            rest = rest.subspan(skip);
        }
        out.insert(out.end(), rest.begin(), rest.end());
    }
    return out;
}

TimeSeries channelsAsRequested(std::vector<Volume> channels, ReadContext& ctx, std::string_view kind,
                               bool color) {
    const std::size_t count = channels.size();
    ctx.noteChannels(count, color);
    TimeSeries series;
    const ReadOptions& o = ctx.options();
    if (count == 1) {
        series.frames = std::move(channels);
        return series;
    }
    if (o.channel) {
        if (*o.channel >= count)
            throw UsageError(ctx.file().string() + ": --channel " + std::to_string(*o.channel) +
                             " is past the " + std::to_string(count) + " channels (0 to " +
                             std::to_string(count - 1) + ")");
        series.frames.push_back(std::move(channels[*o.channel]));
        return series;
    }
    requireChannelsWanted(ctx, count, kind);
    series.frames = std::move(channels);
    return series;
}

void requireChannelsWanted(const ReadContext& ctx, std::size_t count, std::string_view kind) {
    const ReadOptions& o = ctx.options();
    if (count > 1 && !o.channel && !o.allChannels)
        unsupported(ctx.file(), "has " + std::to_string(count) + " channels (" + std::string(kind) +
                                    "): choose one with --channel K (0 to " + std::to_string(count - 1) +
                                    "), or render them all with a scene's \"channels\"");
}

void refuseFramesWithComponents(std::size_t frames, std::size_t components, const fs::path& file) {
    if (frames > 1 && components > 1)
        unsupported(file, std::to_string(frames) + " time frames of " + std::to_string(components) +
                              " components each: multi-channel series are not supported");
}

} // namespace volcl::io
