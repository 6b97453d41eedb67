// Walks OpenEXR headers with bounded reads and refuses claims the file cannot back (see the header).
#include "host/image/ExrHeaderCheck.hpp"

#include "core/Error.hpp"
#include "core/MemoryBudget.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <optional>
#include <string>
#include <vector>

namespace volcl {
namespace {

constexpr std::uint32_t kExrMagic = 20000630;
constexpr std::uint32_t kTiledFlag = 0x200, kLongNamesFlag = 0x400, kMultipartFlag = 0x1000;
// A channel list larger than this (thousands of channels) is not an image volcl reads.
constexpr std::int32_t kMaxChannelListBytes = 1 << 16;

// What one part's header says about its size.
struct PartClaims {
    std::optional<std::array<std::int32_t, 4>> dataWindow;
    int compression = 3; // without the attribute OpenEXR uses its header's default, ZIP
    std::uint32_t tileX = 0, tileY = 0;
    bool tiled = false;
    std::int64_t chunkCount = -1; // multi-part files state it
    std::size_t channels = 0;
    std::uint64_t bytesPerPixel = 0; // stored bytes of one pixel over all channels (2 for half, 4 otherwise)
};

// OpenEXR's readers of these attribute types read their fixed layout whatever size the file states, so a
// stated size that differs would put OpenEXR at another place in the header than this walker: it would
// then read the bytes the walker took for a value as the next attribute, and a size there (a fuzzed file
// made it allocate 846 MB) would never have been checked. A valid file states each type's own size.
std::optional<std::int32_t> fixedAttributeSize(const std::string& type) {
    struct Fixed {
        const char* type;
        std::int32_t bytes;
    };
    static constexpr Fixed kFixed[] = {{"box2f", 16},
                                       {"box2i", 16},
                                       {"chromaticities", 32},
                                       {"compression", 1},
                                       {"deepImageState", 1},
                                       {"double", 8},
                                       {"envmap", 1},
                                       {"float", 4},
                                       {"int", 4},
                                       {"keycode", 28},
                                       {"lineOrder", 1},
                                       {"m33d", 72},
                                       {"m33f", 36},
                                       {"m44d", 128},
                                       {"m44f", 64},
                                       {"rational", 8},
                                       {"tiledesc", 9},
                                       {"timecode", 8},
                                       {"v2d", 16},
                                       {"v2f", 8},
                                       {"v2i", 8},
                                       {"v3d", 24},
                                       {"v3f", 12},
                                       {"v3i", 12}};
    for (const Fixed& f : kFixed)
        if (type == f.type) return f.bytes;
    return std::nullopt;
}

// Lines of a scan-line chunk per compression method, as OpenEXR defines them.
int linesPerChunk(int compression) {
    switch (compression) {
    case 3:
    case 5:
        return 16; // ZIP, PXR24
    case 4:
    case 6:
    case 7:
    case 8:
        return 32; // PIZ, B44, B44A, DWAA
    case 9:
        return 256; // DWAB
    default:
        return 1; // none, RLE, ZIPS and unknown (the largest table)
    }
}

class HeaderWalker {
public:
    HeaderWalker(const std::filesystem::path& path, std::uintmax_t fileSize)
        : name_(path.string()), size_(fileSize), in_(path, std::ios::binary) {
        if (!in_) throw IoError(name_ + ": cannot open image");
    }

    [[noreturn]] void corrupt(const std::string& why) const {
        throw IoError(name_ + ": corrupt EXR header: " + why);
    }

    // The walker counts its own position: the stream's tellg is a system call, and names are read a byte
    // at a time (a 20 KB header cost 20,000 lseek calls).
    std::uint64_t position() const { return pos_; }
    std::uint64_t remaining() const { return size_ - pos_; }

    void read(void* out, std::size_t n) {
        if (n > remaining() || !in_.read(static_cast<char*>(out), static_cast<std::streamsize>(n)))
            corrupt("ends inside a header");
        pos_ += n;
    }
    template <class T> T value() {
        T v{};
        read(&v, sizeof(T));
        return v;
    }
    // A NUL-terminated string of at most `maxLength` characters.
    std::string cstring(std::size_t maxLength, const char* what) {
        std::string s;
        for (;;) {
            const char c = value<char>();
            if (c == '\0') return s;
            if (s.size() == maxLength)
                corrupt(std::string(what) + " longer than " + std::to_string(maxLength));
            s.push_back(c);
        }
    }
    void skip(std::uint64_t n) {
        if (n > remaining()) corrupt("an attribute claims more bytes than the file holds");
        in_.seekg(static_cast<std::streamoff>(n), std::ios::cur);
        pos_ += n;
    }
    // Peeks one byte: a NUL ends a header (or, in a multi-part file, the list of headers).
    bool atEnd() {
        if (remaining() == 0) corrupt("the header never ends");
        if (in_.peek() != 0) return false;
        in_.get();
        ++pos_;
        return true;
    }

    PartClaims part(std::size_t maxName) {
        PartClaims claims;
        while (!atEnd()) {
            const std::string attr = cstring(maxName, "attribute name");
            const std::string type = cstring(maxName, "attribute type");
            const std::int32_t bytes = value<std::int32_t>();
            if (bytes < 0) corrupt("attribute '" + attr + "' has a negative size");
            if (std::uint64_t(bytes) > remaining())
                corrupt("attribute '" + attr + "' claims " + std::to_string(bytes) + " bytes, the file has " +
                        std::to_string(remaining()) + " left");
            if (const auto fixed = fixedAttributeSize(type); fixed && bytes != *fixed)
                corrupt("attribute '" + attr + "' of type " + type + " states " + std::to_string(bytes) +
                        " bytes, the type has " + std::to_string(*fixed));
            if (attr == "dataWindow" && type == "box2i") {
                std::array<std::int32_t, 4> box{};
                read(box.data(), 16);
                claims.dataWindow = box;
            } else if (attr == "compression" && type == "compression") {
                claims.compression = value<std::uint8_t>();
            } else if (attr == "tiles" && type == "tiledesc") {
                claims.tileX = value<std::uint32_t>();
                claims.tileY = value<std::uint32_t>();
                value<std::uint8_t>(); // level mode: more levels only add chunks to the level-0 count
                claims.tiled = true;
            } else if (attr == "chunkCount" && type == "int") {
                claims.chunkCount = value<std::int32_t>();
                if (claims.chunkCount < 0) corrupt("negative chunkCount");
            } else if (type == "chlist") {
                // OpenEXR reads a channel list up to its terminating NUL, whatever size is stated.
                if (bytes > kMaxChannelListBytes)
                    corrupt("a channel list of " + std::to_string(bytes) + " bytes");
                const ChannelList list = readChannelList(bytes);
                if (attr == "channels") {
                    claims.channels = list.count;
                    claims.bytesPerPixel = list.bytesPerPixel;
                }
            } else if (type == "preview") {
                // Width and height, then 4 bytes per pixel, which OpenEXR allocates from the two numbers.
                if (bytes < 8)
                    corrupt("attribute '" + attr + "' is a preview of " + std::to_string(bytes) + " bytes");
                const std::uint64_t w = value<std::uint32_t>(), h = value<std::uint32_t>();
                if (double(w) * double(h) * 4 !=
                    double(bytes) - 8) // may pass 2^64 in integers; equal only below 2^31
                    corrupt("preview '" + attr + "' of " + std::to_string(w) + "x" + std::to_string(h) +
                            " pixels states " + std::to_string(bytes) + " bytes");
                skip(w * h * 4);
            } else {
                skip(std::uint64_t(bytes));
            }
        }
        return claims;
    }

    struct ChannelList {
        std::size_t count = 0;
        std::uint64_t bytesPerPixel = 0;
    };
    // Each channel: name, NUL, then 16 bytes (pixel type, linear, reserved, x and y sampling); a NUL ends the
    // list. Pixel types: 0 uint and 2 float (4 bytes), 1 half (2 bytes); OpenEXR refuses others.
    ChannelList readChannelList(std::int32_t bytes) {
        std::vector<char> list(static_cast<std::size_t>(bytes));
        read(list.data(), list.size());
        std::size_t pos = 0;
        ChannelList channels;
        while (pos < list.size() && list[pos] != '\0') {
            const void* end = std::memchr(list.data() + pos, '\0', list.size() - pos);
            if (!end) corrupt("unterminated channel name");
            pos = std::size_t(static_cast<const char*>(end) - list.data()) + 1;
            if (list.size() - pos < 16) corrupt("unterminated channel list");
            std::int32_t type = 0;
            std::memcpy(&type, list.data() + pos, 4);
            channels.bytesPerPixel += type == 1 ? 2 : 4;
            pos += 16;
            ++channels.count;
        }
        if (pos >= list.size()) corrupt("unterminated channel list");
        if (pos + 1 != list.size())
            corrupt("the channel list ends " + std::to_string(list.size() - pos - 1) +
                    " bytes before its stated size");
        return channels;
    }

private:
    std::string name_;
    std::uint64_t size_;
    std::uint64_t pos_ = 0;
    std::ifstream in_;
};

} // namespace

void checkExrHeaders(const std::filesystem::path& path, std::size_t memoryBudget) {
    std::error_code ec;
    const std::uintmax_t fileSize = std::filesystem::file_size(path, ec);
    if (ec || fileSize < 8) return; // not an EXR the walker can judge: the image library reports it
    HeaderWalker walker(path, fileSize);
    if (walker.value<std::uint32_t>() != kExrMagic) return;
    const std::uint32_t flags = walker.value<std::uint32_t>();
    const std::size_t maxName = (flags & kLongNamesFlag) ? 255 : 31;
    const bool multipart = (flags & kMultipartFlag) != 0;

    std::vector<PartClaims> parts;
    do {
        parts.push_back(walker.part(maxName));
    } while (multipart && !walker.atEnd());

    // What follows the headers is the offset tables: 8 bytes per chunk of every part.
    double tableBytes = 0;
    for (const PartClaims& p : parts) {
        if (!p.dataWindow) walker.corrupt("a part has no dataWindow");
        const auto& b = *p.dataWindow;
        const double w = double(b[2]) - b[0] + 1, h = double(b[3]) - b[1] + 1;
        if (!(w > 0 && h > 0))
            walker.corrupt("data window (" + std::to_string(b[0]) + "," + std::to_string(b[1]) + ")-(" +
                           std::to_string(b[2]) + "," + std::to_string(b[3]) + ") is empty or inverted");
        const double pixelBytes = w * h * double(std::max<std::size_t>(p.channels, 4)) * sizeof(float);
        checkMemoryBudget(pixelBytes > 1e18 ? std::size_t(-1) : std::size_t(pixelBytes), memoryBudget, path,
                          "EXR data window " + std::to_string(std::int64_t(w)) + "x" +
                              std::to_string(std::int64_t(h)));
        // OpenEXR decodes a chunk at a time into buffers it sizes from the header: per line buffer (or tile
        // buffer) the chunk's stored bytes, the decompressor's output (ZIP: 1 % more than the chunk) and its
        // scratch space (DWA: several planes), whatever the data window's height (a 1-pixel-high ZIP image
        // still gets buffers of 16 lines). A 693-byte strip claiming 589,825 pixels per line made it
        // allocate 1 GB with one line buffer per thread; volcl reads with one (OiioModule), so the working
        // set is bounded by four chunks beside the image (a 40000x1 ZIP float strip: 3.02 chunks measured).
        const bool tiledPart = p.tiled || (!multipart && (flags & kTiledFlag));
        const double chunkPixels =
            tiledPart ? double(p.tileX) * double(p.tileY) : w * linesPerChunk(p.compression);
        const double storedPixelBytes = double(std::max<std::uint64_t>(p.bytesPerPixel, 1));
        const double workingBytes = 4 * chunkPixels * storedPixelBytes;
        // The image as stored and as floats (OiioModule reads it as stored, then converts), and the buffers.
        const double readBytes = pixelBytes + w * h * storedPixelBytes + workingBytes;
        checkMemoryBudget(readBytes > 1e18 ? std::size_t(-1) : std::size_t(readBytes), memoryBudget, path,
                          "decoding the EXR data window " + std::to_string(std::int64_t(w)) + "x" +
                              std::to_string(std::int64_t(h)) + " (" +
                              (tiledPart
                                   ? "tiles of " + std::to_string(p.tileX) + "x" + std::to_string(p.tileY)
                                   : std::to_string(linesPerChunk(p.compression)) + " lines per chunk") +
                              ")");
        double chunks = 0;
        if (p.chunkCount >= 0) {
            chunks = double(p.chunkCount);
        } else if (p.tiled || (!multipart && (flags & kTiledFlag))) {
            if (p.tileX == 0 || p.tileY == 0) walker.corrupt("a tiled part without a valid tile size");
            chunks = std::ceil(w / p.tileX) * std::ceil(h / p.tileY);
        } else {
            chunks = std::ceil(h / linesPerChunk(p.compression));
        }
        tableBytes += chunks * 8;
    }
    if (tableBytes > double(walker.remaining()))
        walker.corrupt("its chunk offset tables need " + std::to_string(std::uint64_t(tableBytes)) +
                       " bytes, the file has " + std::to_string(walker.remaining()) + " left");
}

} // namespace volcl
