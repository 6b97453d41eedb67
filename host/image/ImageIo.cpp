// Image files through OpenImageIO (EXR float/half with attributes, 8-bit PNG) and sRGB display encoding.
#include "host/image/ImageIo.hpp"

#include "host/Error.hpp"
#include "host/io/AtomicFile.hpp"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace volcl {
namespace {

namespace OIIO = OIIO_NAMESPACE;

std::string lowerExtension(const std::filesystem::path& p) {
    std::string ext = p.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    return ext;
}

constexpr float kHalfMax = 65504.0f;

} // namespace

ImageBuffer::ImageBuffer(int w, int h, std::vector<std::string> channelNames)
    : width(w), height(h), channels(std::move(channelNames)) {
    if (w <= 0 || h <= 0)
        throw UsageError("image size " + std::to_string(w) + "x" + std::to_string(h) + " is empty");
    if (channels.empty()) throw UsageError("image needs at least one channel");
    pixels.assign(static_cast<std::size_t>(w) * static_cast<std::size_t>(h) * channels.size(), 0.0f);
}

const ImageAttribute* ImageBuffer::findAttribute(std::string_view name) const {
    for (const auto& a : attributes)
        if (a.name == name) return &a;
    return nullptr;
}

void writeImage(const ImageBuffer& image, const std::filesystem::path& path,
                const ImageWriteOptions& options) {
    const std::string name = path.string();
    if (image.width <= 0 || image.height <= 0 || image.channels.empty())
        throw UsageError(name + ": cannot write an empty image");
    if (image.pixels.size() != static_cast<std::size_t>(image.width) * image.height * image.channels.size())
        throw UsageError(name + ": pixel buffer size does not match " + std::to_string(image.width) + "x" +
                         std::to_string(image.height) + "x" + std::to_string(image.channels.size()));
    const std::string ext = lowerExtension(path);
    const bool exr = ext == ".exr";
    const bool png = ext == ".png";
    if (!exr && !png) throw UsageError(name + ": unsupported image format '" + ext + "' (use .exr or .png)");
    if (png && image.channelCount() > 4)
        throw UsageError(name + ": PNG holds at most 4 channels, this image has " +
                         std::to_string(image.channelCount()));
    if (exr && options.halfFloat)
        for (float v : image.pixels)
            if (std::isfinite(v) && std::abs(v) > kHalfMax)
                throw DataError(name + ": value " + std::to_string(v) +
                                " does not fit in half float (max 65504); write float EXR instead");

    AtomicFile out(path);
    // The temporary has a different name, so choose the writer from the target's extension.
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

    if (!writer->open(out.tempPath().string(), spec))
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
    out.commit();
}

ImageBuffer readImage(const std::filesystem::path& path) {
    const std::string name = path.string();
    if (!std::filesystem::is_regular_file(path)) throw IoError(name + ": image file not found");
    // Keep stored values as they are (PNG alpha is straight; OIIO would otherwise premultiply on read).
    OIIO::ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    auto in = OIIO::ImageInput::open(name, &config);
    if (!in) throw IoError(name + ": cannot read image (" + OIIO::geterror() + ")");
    const OIIO::ImageSpec& spec = in->spec();
    if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0)
        throw IoError(name + ": image has no pixels");
    if (spec.depth > 1) throw IoError(name + ": volume images are not supported as 2D images");

    std::vector<std::string> names;
    for (int c = 0; c < spec.nchannels; ++c)
        names.push_back(c < int(spec.channelnames.size()) ? spec.channelnames[std::size_t(c)]
                                                          : "channel" + std::to_string(c));
    ImageBuffer img(spec.width, spec.height, names);
    if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, img.pixels.data()))
        throw IoError(name + ": corrupted or truncated image (" + in->geterror() + ")");
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

float linearToSrgb(float linear) noexcept {
    if (!(linear > 0.0f)) return 0.0f; // also maps NaN to black
    if (linear >= 1.0f) return 1.0f;
    if (linear <= 0.0031308f) return 12.92f * linear;
    return static_cast<float>(1.055 * std::pow(static_cast<double>(linear), 1.0 / 2.4) - 0.055);
}

ImageBuffer compositeOverSrgb(const ImageBuffer& src, std::array<float, 4> background) {
    int idx[4] = {-1, -1, -1, -1};
    const char* want[4] = {"R", "G", "B", "A"};
    for (int c = 0; c < src.channelCount(); ++c)
        for (int k = 0; k < 4; ++k)
            if (src.channels[std::size_t(c)] == want[k] && idx[k] < 0) idx[k] = c;
    for (int k = 0; k < 4; ++k)
        if (idx[k] < 0) throw UsageError(std::string("compositeOverSrgb: image has no channel ") + want[k]);

    ImageBuffer out(src.width, src.height, {"R", "G", "B", "A"});
    out.attributes = src.attributes;
    const float ba = std::clamp(background[3], 0.0f, 1.0f);
    for (int y = 0; y < src.height; ++y)
        for (int x = 0; x < src.width; ++x) {
            const float a = std::clamp(src.at(x, y, idx[3]), 0.0f, 1.0f);
            const float outA = 1.0f - (1.0f - a) * (1.0f - ba);
            for (int c = 0; c < 3; ++c) {
                // Associated colour over the associated background, then back to straight colour for display.
                const float assoc = src.at(x, y, idx[c]) + (1.0f - a) * background[std::size_t(c)] * ba;
                const float straight = outA > 0.0f ? assoc / outA : 0.0f;
                out.at(x, y, c) = linearToSrgb(straight);
            }
            out.at(x, y, 3) = outA;
        }
    return out;
}

} // namespace volcl
