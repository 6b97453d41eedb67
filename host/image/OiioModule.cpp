// OpenImageIO module: EXR (float/half, attributes) and 8-bit PNG writing, reading of any format OIIO knows.
#include "host/image/OiioModule.hpp"

#include "core/AtomicFile.hpp"
#include "core/Error.hpp"
#include "core/MemoryBudget.hpp"
#include "host/image/ExrHeaderCheck.hpp"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <span>
#include <vector>

#include <sys/mman.h>
#include <unistd.h>

namespace volcl {
namespace {

namespace OIIO = OIIO_NAMESPACE;

void write(const ImageBuffer& image, const std::filesystem::path& path, ImageFileFormat fileFormat,
           const ImageWriteOptions& options) {
    const std::string name = path.string();
    const bool png = fileFormat == ImageFileFormat::Png, exr = !png;
    AtomicFile out(path);
    auto writer = OIIO::ImageOutput::create(name);
    if (!writer) throw IoError(name + ": no image writer available (" + OIIO::geterror() + ")");

    const OIIO::TypeDesc format =
        png ? OIIO::TypeDesc::UINT8 : (options.halfFloat ? OIIO::TypeDesc::HALF : OIIO::TypeDesc::FLOAT);
    OIIO::ImageSpec spec(image.width, image.height, image.channelCount(), format);
    spec.channelnames = image.channels;
    spec.alpha_channel = -1;
    for (int c = 0; c < image.channelCount(); ++c)
        if (image.channels[std::size_t(c)] == "A") spec.alpha_channel = c;
    if (exr) spec.attribute("compression", "zip");
    // PNG pixels are display values with straight alpha already: stop OIIO from un-premultiplying them.
    if (png) spec.attribute("oiio:UnassociatedAlpha", 1);
    for (const auto& a : image.attributes) {
        if (const auto* s = std::get_if<std::string>(&a.value))
            spec.attribute(a.name, *s);
        else if (const auto* f = std::get_if<float>(&a.value))
            spec.attribute(a.name, *f);
        else if (const auto* i = std::get_if<int>(&a.value))
            spec.attribute(a.name, *i);
        else if (const auto* v = std::get_if<std::array<float, 2>>(&a.value))
            spec.attribute(a.name, OIIO::TypeDesc(OIIO::TypeDesc::FLOAT, OIIO::TypeDesc::VEC2), v->data());
    }

    // The encoder writes into memory and volcl writes the bytes: OpenImageIO's own file writes do not
    // report a full disk (a PNG became a 0-byte file with success), AtomicFile checks every byte.
    if (!writer->supports("ioproxy"))
        throw IoError(name + ": this OpenImageIO writer cannot write to memory (no ioproxy support)");
    OIIO::Filesystem::IOVecOutput encoded;
    if (!writer->set_ioproxy(&encoded) || !writer->open(name, spec))
        throw IoError(name + ": cannot open for writing (" + writer->geterror() + ")");
    bool ok = false;
    if (png) {
        // Explicit rounding so the 8-bit values do not depend on the library's conversion.
        std::vector<std::uint8_t> bytes(image.pixels.size());
        for (std::size_t i = 0; i < bytes.size(); ++i) {
            const float v = image.pixels[i];
            const float c = std::isnan(v) ? 0.0f : std::clamp(v, 0.0f, 1.0f);
            bytes[i] = static_cast<std::uint8_t>(std::lround(c * 255.0f));
        }
        ok = writer->write_image(OIIO::TypeDesc::UINT8, bytes.data());
    } else {
        ok = writer->write_image(OIIO::TypeDesc::FLOAT, image.pixels.data());
    }
    const std::string error = ok ? std::string() : writer->geterror();
    if (!writer->close() && ok) throw IoError(name + ": cannot finish writing (" + writer->geterror() + ")");
    if (!ok) throw IoError(name + ": cannot write pixels (" + error + ")");
    writer.reset();
    const std::vector<unsigned char>& bytes = encoded.buffer();
    if (bytes.empty()) throw IoError(name + ": the image writer produced no bytes");
    out.write(std::span<const std::byte>(reinterpret_cast<const std::byte*>(bytes.data()), bytes.size()));
    out.commit();
}

// libpng (inside OpenImageIO) prints its errors to stderr before OIIO returns them; OIIO's error text
// already holds the same words, and volcl's message must be one line. While an image is read, stderr goes
// to an anonymous memory file that is dropped afterwards.
class StderrSilencer {
public:
    StderrSilencer() {
        std::fflush(stderr);
        const int sink = ::memfd_create("volcl-image-stderr", MFD_CLOEXEC);
        if (sink < 0) return;
        saved_ = ::dup(2);
        if (saved_ >= 0 && ::dup2(sink, 2) < 0) {
            ::close(saved_);
            saved_ = -1;
        }
        ::close(sink);
    }
    ~StderrSilencer() {
        if (saved_ < 0) return;
        std::fflush(stderr);
        ::dup2(saved_, 2);
        ::close(saved_);
    }
    StderrSilencer(const StderrSilencer&) = delete;
    StderrSilencer& operator=(const StderrSilencer&) = delete;

private:
    int saved_ = -1;
};

ImageBuffer read(const std::filesystem::path& path, std::size_t memoryBudget) {
    const std::string name = path.string();
    // OpenEXR allocates from header claims while it opens a file: check them against the file first.
    checkExrHeaders(path, memoryBudget);
    // OpenEXR keeps two chunk buffers per worker thread (each a chunk's stored bytes, decompressed output and
    // scratch space); decoding on the calling thread keeps one, so its working set is what the check above
    // bounds, whatever the machine's core count. volcl's images are tables and strips: small.
    OIIO::attribute("exr_threads", -1);
    const StderrSilencer quiet;
    // Keep stored values as they are (PNG alpha is straight; OIIO would otherwise premultiply on read).
    OIIO::ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    // The reader is the one the extension names. ImageInput::open would, when that reader refuses the file,
    // try every format OIIO knows in turn (28 opens of a garbage .png, 4.6 ms instead of 0.1 ms) and report
    // the last one's complaint; a .png that is not a PNG is a corrupt file.
    std::string extension = path.extension().string();
    if (!extension.empty()) extension.erase(0, 1);
    std::transform(extension.begin(), extension.end(), extension.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    auto in = extension.empty() ? nullptr : OIIO::ImageInput::create(extension, false, &config);
    if (!in) throw IoError(name + ": no image reader for the file's extension (" + OIIO::geterror() + ")");
    OIIO::ImageSpec spec;
    if (!in->open(name, spec, config)) throw IoError(name + ": cannot read image (" + in->geterror() + ")");
    if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0)
        throw IoError(name + ": image has no pixels");
    if (spec.depth > 1) throw IoError(name + ": volume images are not supported as 2D images");
    // The pixels as stored, then as floats.
    const double pixels = double(spec.width) * double(spec.height);
    const double readBytes =
        pixels * (double(spec.pixel_bytes(true)) + double(spec.nchannels) * sizeof(float));
    checkMemoryBudget(readBytes > 1e18 ? std::size_t(-1) : static_cast<std::size_t>(readBytes), memoryBudget,
                      path, std::to_string(spec.width) + "x" + std::to_string(spec.height) + " image");

    std::vector<std::string> names;
    for (int c = 0; c < spec.nchannels; ++c)
        names.push_back(c < int(spec.channelnames.size()) ? spec.channelnames[std::size_t(c)]
                                                          : "channel" + std::to_string(c));
    // Read as stored, then convert: asked for another type, OIIO converts through a buffer of at least 256
    // scan lines whatever the image's height (156 MB for a 40000x1 float strip), which no budget check sees.
    // Float images (volcl's own tables) are stored as the buffer wants them: read straight into it.
    ImageBuffer img(spec.width, spec.height, names);
    const bool storedAsFloat = spec.channelformats.empty() && spec.format == OIIO::TypeDesc::FLOAT;
    std::vector<std::byte> stored(storedAsFloat ? 0
                                                : static_cast<std::size_t>(pixels) * spec.pixel_bytes(true));
    void* target = storedAsFloat ? static_cast<void*>(img.pixels.data()) : static_cast<void*>(stored.data());
    if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::UNKNOWN, target))
        throw IoError(name + ": corrupted or truncated image (" + in->geterror() + ")");
    if (storedAsFloat) {
        // Nothing to convert.
    } else if (spec.channelformats.empty()) {
        if (!OIIO::convert_pixel_values(spec.format, stored.data(), OIIO::TypeDesc::FLOAT, img.pixels.data(),
                                        static_cast<int>(img.pixels.size())))
            throw IoError(name + ": cannot convert its pixels to float (" + OIIO::geterror() + ")");
    } else {
        // Channels of different types (an EXR with half colour and float depth): channel by channel.
        std::size_t offset = 0;
        const std::size_t stride = spec.pixel_bytes(true), channels = std::size_t(spec.nchannels);
        for (std::size_t c = 0; c < channels; ++c) {
            const OIIO::TypeDesc type = spec.channelformat(int(c));
            for (std::size_t i = 0; i < static_cast<std::size_t>(pixels); ++i)
                if (!OIIO::convert_pixel_values(type, stored.data() + i * stride + offset,
                                                OIIO::TypeDesc::FLOAT, &img.pixels[i * channels + c], 1))
                    throw IoError(name + ": cannot convert its pixels to float (" + OIIO::geterror() + ")");
            offset += type.size();
        }
    }
    for (const auto& pv : spec.extra_attribs) {
        const OIIO::TypeDesc t = pv.type();
        const std::string attrName = pv.name().string();
        if (pv.nvalues() != 1) continue;
        if (t == OIIO::TypeDesc::STRING)
            img.attributes.push_back({attrName, std::string(pv.get_ustring().string())});
        else if (t == OIIO::TypeDesc::FLOAT)
            img.attributes.push_back({attrName, pv.get_float()});
        else if (t == OIIO::TypeDesc::INT)
            img.attributes.push_back({attrName, pv.get_int()});
        else if (t == OIIO::TypeDesc(OIIO::TypeDesc::FLOAT, OIIO::TypeDesc::VEC2)) {
            const auto* f = static_cast<const float*>(pv.data());
            img.attributes.push_back({attrName, std::array<float, 2>{f[0], f[1]}});
        }
    }
    in->close();
    return img;
}

const OiioModule kModule{write, read};

} // namespace
} // namespace volcl

// Declared as returning const void*, the type loadRuntimeModule calls it through (a call through another
// function type is undefined; clang's -fsanitize=function stops on it).
extern "C" __attribute__((visibility("default"))) const void* volcl_oiio_module() {
    return &volcl::kModule;
}
