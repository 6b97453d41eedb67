// VolVis SLC (.slc): ASCII header, RGB icon, then 8-bit slices stored raw or run-length encoded.
#include "core/AtomicFile.hpp"
#include "host/io/IoDetail.hpp"

#include <cctype>
#include <cmath>
#include <cstring>

namespace volcl::io {

namespace fs = std::filesystem;

namespace {

// Scanner for the fscanf-style header: whitespace-separated numbers and literal 'X' markers.
class SlcScanner {
public:
    SlcScanner(std::span<const std::byte> b, const fs::path& f) : text_(asText(b)), file_(f) {}
    std::string_view word(std::string_view what) {
        while (pos_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[pos_])))
            ++pos_;
        const std::size_t begin = pos_;
        while (pos_ < text_.size() && !std::isspace(static_cast<unsigned char>(text_[pos_])) &&
               pos_ - begin < 32 &&
               (std::isdigit(static_cast<unsigned char>(text_[pos_])) || std::strchr("+-.eE", text_[pos_])))
            ++pos_;
        if (begin == pos_) fail(file_, "truncated or malformed header: " + std::string(what) + " missing");
        return text_.substr(begin, pos_ - begin);
    }
    long long integer(std::string_view what) { return requireInt(word(what), file_, what); }
    double real(std::string_view what) { return requireDouble(word(what), file_, what); }
    // "%d X": the marker follows after optional whitespace and the binary data starts right after it.
    void marker(std::string_view what) {
        while (pos_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[pos_])))
            ++pos_;
        if (pos_ >= text_.size() || text_[pos_] != 'X')
            fail(file_, "truncated or malformed: 'X' marker missing after " + std::string(what));
        ++pos_;
    }
    std::size_t pos() const { return pos_; }
    void skip(std::size_t n, std::string_view what) {
        if (text_.size() - pos_ < n) fail(file_, "truncated: " + std::string(what) + " is cut off");
        pos_ += n;
    }
    std::size_t remaining() const { return text_.size() - pos_; }

private:
    std::string_view text_;
    const fs::path& file_;
    std::size_t pos_ = 0;
};

// VolVis run-length code: a byte n|0x80 copies n literal bytes, n alone repeats the next byte n times,
// 0 ends the slice.
void decodeRle(std::span<const std::byte> in, std::span<std::byte> out, const fs::path& file,
               std::size_t slice) {
    std::size_t i = 0, o = 0;
    const std::string where = "slice " + std::to_string(slice);
    while (true) {
        if (i >= in.size()) fail(file, where + ": run-length data ends without a terminator");
        const unsigned c = std::to_integer<unsigned>(in[i++]);
        const std::size_t n = c & 0x7f;
        if (n == 0) break;
        if (o + n > out.size()) fail(file, where + ": run-length data decodes to more than the slice size");
        if (c & 0x80) {
            if (i + n > in.size()) fail(file, where + ": run-length literal runs past the slice data");
            std::memcpy(out.data() + o, in.data() + i, n);
            i += n;
        } else {
            if (i >= in.size()) fail(file, where + ": run-length repeat has no value");
            std::memset(out.data() + o, std::to_integer<int>(in[i++]), n);
        }
        o += n;
    }
    if (o != out.size())
        fail(file,
             where + ": decodes to " + std::to_string(o) + " voxels, expected " + std::to_string(out.size()));
}

} // namespace

TimeSeries readSlc(ReadContext& ctx) {
    const fs::path& path = ctx.file();
    const std::vector<std::byte> bytes = readFileBytes(path);
    SlcScanner s(bytes, path);
    if (s.integer("magic") != 11111) fail(path, "not a VolVis SLC file (magic is not 11111)");
    long long size[3];
    for (long long& v : size) {
        v = s.integer("dimensions");
        if (v <= 0) fail(path, "dimension " + std::to_string(v) + " must be positive");
    }
    const long long bits = s.integer("bits per voxel");
    if (bits != 8)
        unsupported(path, std::to_string(bits) + " bits per voxel: only 8-bit SLC files exist in VolVis");
    std::array<double, 3> spacing{};
    for (double& u : spacing) {
        u = s.real("voxel size");
        if (!std::isfinite(u) || !(u > 0))
            fail(path, "voxel size " + formatDouble(u) + " is not a positive finite number");
    }
    s.integer("unit type");
    s.integer("data source");
    s.integer("data modification");
    const long long compression = s.integer("compression");
    if (compression != 0 && compression != 1)
        unsupported(path, "compression " + std::to_string(compression) + " (0 or 1 supported)");
    const long long iconW = s.integer("icon width"), iconH = s.integer("icon height");
    if (iconW < 0 || iconH < 0 || iconW > 65536 || iconH > 65536) fail(path, "icon size is invalid");
    s.marker("icon size");
    s.skip(static_cast<std::size_t>(3 * iconW * iconH), "the icon");

    const Dims dims{static_cast<std::size_t>(size[0]), static_cast<std::size_t>(size[1]),
                    static_cast<std::size_t>(size[2])};
    const std::size_t voxels = ctx.voxelCount(dims, 1, SampleType::UInt8);
    const std::size_t plane = dims.x * dims.y;
    // Even run-length data needs 2 bytes per 127 voxels, so a lying header is caught before allocating.
    if ((compression == 0 ? voxels : voxels / 64) > s.remaining() + 1)
        fail(path, "truncated: " + std::to_string(s.remaining()) + " bytes cannot hold " +
                       std::to_string(voxels) + " voxels");
    Volume v(dims, ScalarType::UInt8);
    v.spacing = spacing;
    auto out = v.bytes();
    for (std::size_t z = 0; z < dims.z; ++z) {
        const auto slice = out.subspan(z * plane, plane);
        if (compression == 0) {
            const std::size_t at = s.pos();
            s.skip(plane, "slice " + std::to_string(z));
            std::memcpy(slice.data(), bytes.data() + at, plane);
        } else {
            const long long n = s.integer("slice size");
            if (n <= 0) fail(path, "slice " + std::to_string(z) + " has invalid size " + std::to_string(n));
            s.marker("slice size");
            const std::size_t at = s.pos();
            s.skip(static_cast<std::size_t>(n), "slice " + std::to_string(z));
            decodeRle(std::span<const std::byte>(bytes).subspan(at, static_cast<std::size_t>(n)), slice, path,
                      z);
        }
    }
    if (!trim(asText(std::span<const std::byte>(bytes).subspan(s.pos()))).empty())
        fail(path, "oversized: " + std::to_string(s.remaining()) + " unexpected bytes after the last slice");
    TimeSeries series;
    series.frames.push_back(std::move(v));
    return series;
}

} // namespace volcl::io
