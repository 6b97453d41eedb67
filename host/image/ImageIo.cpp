// Image files (EXR float/half with attributes, 8-bit PNG; OpenImageIO in a module) and sRGB display encoding.
#include "host/image/ImageIo.hpp"

#include "core/Error.hpp"
#include "core/runtime/RuntimeModule.hpp"
#include "host/image/OiioModule.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace volcl {
namespace {

std::string lowerExtension(const std::filesystem::path& p) {
    std::string ext = p.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    return ext;
}

constexpr float kHalfMax = 65504.0f;

// A failed load throws and is retried on the next call (a function-local static is initialised only once it
// succeeds).
const OiioModule& oiioModule() {
    static const auto* module = static_cast<const OiioModule*>(
        loadRuntimeModule(kOiioModuleFile, kOiioModuleEntry, "image I/O (OpenImageIO)"));
    return *module;
}

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

    oiioModule().write(image, path, png ? ImageFileFormat::Png : ImageFileFormat::Exr, options);
}

ImageBuffer readImage(const std::filesystem::path& path, std::size_t memoryBudget) {
    const std::string name = path.string();
    if (!std::filesystem::is_regular_file(path)) throw IoError(name + ": image file not found");
    return oiioModule().read(path, memoryBudget);
}

float linearToSrgb(float linear) noexcept {
    if (!(linear > 0.0f)) return 0.0f; // also maps NaN to black
    if (linear >= 1.0f) return 1.0f;
    if (linear <= 0.0031308f) return 12.92f * linear;
    return static_cast<float>(1.055 * std::pow(static_cast<double>(linear), 1.0 / 2.4) - 0.055);
}

ImageBuffer compositeOverSrgb(const ImageBuffer& src, const std::array<double, 4>& backgroundRgba) {
    const std::array<float, 4> background{float(backgroundRgba[0]), float(backgroundRgba[1]),
                                          float(backgroundRgba[2]), float(backgroundRgba[3])};
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
