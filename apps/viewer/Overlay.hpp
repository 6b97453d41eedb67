// In-window text overlay: a 6x13 bitmap font rasterised on the host and drawn as a blended texture.
#pragma once

#include <string>
#include <vector>

namespace volcl::viewer {

/// Coverage mask of some lines of text (0 or 255 per pixel, row 0 at the top), with a margin of
/// `kTextMargin` pixels around the text. Characters outside printable ASCII are drawn as '?'.
struct TextMask {
    int width = 0, height = 0;
    std::vector<unsigned char> coverage;
};
inline constexpr int kGlyphWidth = 6, kGlyphHeight = 13, kTextMargin = 4;
TextMask rasteriseText(const std::vector<std::string>& lines);

/// Splits `text` at ", " so that no line is longer than `maxChars` (a single longer item stays whole).
std::vector<std::string> wrapList(const std::string& prefix, const std::string& text, std::size_t maxChars);

/// Draws text in the top-left corner of the bound framebuffer: white glyphs on a translucent black panel,
/// alpha-blended over what is there. Needs a current OpenGL 3.3 core context. Example:
/// ```
/// volcl::viewer::TextOverlay overlay;
/// overlay.setText({"frame 98 ms (10.2 fps)", "render 128x128 step 1"});
/// overlay.draw(viewportWidth, viewportHeight);
/// ```
class TextOverlay {
public:
    TextOverlay();
    ~TextOverlay();
    TextOverlay(const TextOverlay&) = delete;
    TextOverlay& operator=(const TextOverlay&) = delete;
    /// Rasterises and uploads the text; unchanged text is not uploaded again.
    void setText(const std::vector<std::string>& lines);
    void draw(int viewportWidth, int viewportHeight);
    int width() const noexcept { return mask_.width; }
    int height() const noexcept { return mask_.height; }

private:
    unsigned program_ = 0, vao_ = 0, texture_ = 0;
    int locOrigin_ = -1, locViewport_ = -1, locSize_ = -1, locMask_ = -1;
    std::vector<std::string> lines_;
    TextMask mask_;
};

} // namespace volcl::viewer
