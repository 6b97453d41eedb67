// Image files through OpenImageIO: float RGBA(+extra channels) buffers, EXR attributes, PNG display encoding.
#pragma once

#include <array>
#include <filesystem>
#include <string>
#include <variant>
#include <vector>

namespace volcl {

struct ImageAttribute {
    std::string name;
    std::variant<std::string, float, int, std::array<float, 2>> value; ///< v2f for EXR "volcl:domain"
};

/// Interleaved float pixels, row 0 at the top. Example:
/// ```
/// volcl::ImageBuffer img(256, 256, {"R", "G", "B", "A"});
/// img.at(3, 4, 0) = 0.5f;
/// img.attributes.push_back({"volcl:method", std::string("exact")});
/// volcl::writeImage(img, "table.exr");
/// ```
struct ImageBuffer {
    ImageBuffer() = default;
    ImageBuffer(int width, int height, std::vector<std::string> channelNames);
    int width = 0, height = 0;
    std::vector<std::string> channels;
    std::vector<float> pixels;
    std::vector<ImageAttribute> attributes;
    int channelCount() const noexcept { return static_cast<int>(channels.size()); }
    float& at(int x, int y, int c) {
        return pixels[(static_cast<std::size_t>(y) * width + x) * channels.size() + c];
    }
    float at(int x, int y, int c) const {
        return pixels[(static_cast<std::size_t>(y) * width + x) * channels.size() + c];
    }
    const ImageAttribute* findAttribute(std::string_view name) const;
};

struct ImageWriteOptions {
    bool halfFloat = false; ///< EXR: store HALF instead of FLOAT
};

/// Writes EXR (float or half, all channels and attributes) or PNG (8-bit, values clamped to [0,1], no
/// transform: encode first). Atomic: temporary file + rename. Throws IoError naming the file.
void writeImage(const ImageBuffer& image, const std::filesystem::path& path,
                const ImageWriteOptions& options = {});
/// Reads any image OpenImageIO can read as float, with its attributes. Throws IoError naming the file.
/// `memoryBudget`: largest pixel buffer (float bytes) the file may claim, 0 = defaultMemoryBudget();
/// a larger claim (a forged EXR data window) is an IoError naming the file, before allocation.
ImageBuffer readImage(const std::filesystem::path& path, std::size_t memoryBudget = 0);

/// Display encoding of linear associated RGBA: composite over `background` (straight RGBA), then sRGB
/// encode. Result has channels R,G,B,A with A = 1 - (1 - a)(1 - background alpha). `background` is the
/// colour type of the whole API (Scene::background, light colours): straight RGBA in doubles; the
/// compositing runs in float, as the viewer's shader does.
ImageBuffer compositeOverSrgb(const ImageBuffer& linearAssociatedRgba,
                              const std::array<double, 4>& background);
float linearToSrgb(float linear) noexcept;

} // namespace volcl
