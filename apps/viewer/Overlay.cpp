// Text overlay: host rasterisation with the embedded 6x13 font, GL texture and a blended quad.
#include "apps/viewer/Overlay.hpp"

#include "apps/viewer/GlPresenter.hpp"
#include "core/Error.hpp"

#include <epoxy/gl.h>

#include <algorithm>

namespace volcl::viewer {
namespace {

constexpr unsigned char kFont[][kGlyphHeight] = {
#include "apps/viewer/OverlayFont.inc"
};
static_assert(sizeof(kFont) / sizeof(kFont[0]) == 95, "printable ASCII 32..126");

// The quad is placed in pixels from the top-left corner; the mask is read texel for texel.
constexpr const char* kVertexShader = R"(#version 330 core
uniform vec2 origin;
uniform vec2 size;
uniform vec2 viewport;
out vec2 texel;
void main() {
    vec2 corner = vec2(float(gl_VertexID & 1), float((gl_VertexID >> 1) & 1));
    texel = corner * size;
    vec2 pixel = origin + texel;
    gl_Position = vec4(2.0 * pixel.x / viewport.x - 1.0, 1.0 - 2.0 * pixel.y / viewport.y, 0.0, 1.0);
}
)";

constexpr const char* kFragmentShader = R"(#version 330 core
in vec2 texel;
out vec4 colour;
uniform sampler2D mask;
void main() {
    float c = texelFetch(mask, ivec2(texel), 0).r;
    colour = mix(vec4(0.0, 0.0, 0.0, 0.6), vec4(1.0, 1.0, 1.0, 1.0), c);
}
)";

} // namespace

TextMask rasteriseText(const std::vector<std::string>& lines) {
    std::size_t longest = 0;
    for (const auto& l : lines)
        longest = std::max(longest, l.size());
    TextMask m;
    if (longest == 0) return m;
    m.width = int(longest) * kGlyphWidth + 2 * kTextMargin;
    m.height = int(lines.size()) * kGlyphHeight + 2 * kTextMargin;
    m.coverage.assign(std::size_t(m.width) * std::size_t(m.height), 0);
    for (std::size_t row = 0; row < lines.size(); ++row)
        for (std::size_t col = 0; col < lines[row].size(); ++col) {
            const unsigned char ch = static_cast<unsigned char>(lines[row][col]);
            const unsigned char* glyph = kFont[(ch >= 32 && ch <= 126 ? ch : '?') - 32];
            const int x0 = kTextMargin + int(col) * kGlyphWidth, y0 = kTextMargin + int(row) * kGlyphHeight;
            for (int y = 0; y < kGlyphHeight; ++y)
                for (int x = 0; x < kGlyphWidth; ++x)
                    if (glyph[y] & (0x80 >> x))
                        m.coverage[std::size_t(y0 + y) * std::size_t(m.width) + std::size_t(x0 + x)] = 255;
        }
    return m;
}

std::vector<std::string> wrapList(const std::string& prefix, const std::string& text, std::size_t maxChars) {
    std::vector<std::string> out;
    std::string line = prefix;
    std::size_t start = 0;
    bool first = true;
    while (start <= text.size()) {
        std::size_t end = text.find(", ", start);
        if (end == std::string::npos) end = text.size();
        const std::string item = text.substr(start, end - start);
        const std::string sep = first ? "" : ", ";
        if (!first && line.size() + sep.size() + item.size() > maxChars) {
            out.push_back(line + ",");
            line = std::string(prefix.size(), ' ') + item;
        } else {
            line += sep + item;
        }
        first = false;
        start = end + 2;
    }
    out.push_back(line);
    return out;
}

TextOverlay::TextOverlay() {
    program_ = linkProgram(kVertexShader, kFragmentShader, "overlay");
    locOrigin_ = glGetUniformLocation(program_, "origin");
    locSize_ = glGetUniformLocation(program_, "size");
    locViewport_ = glGetUniformLocation(program_, "viewport");
    locMask_ = glGetUniformLocation(program_, "mask");
    glGenVertexArrays(1, &vao_);
    glGenTextures(1, &texture_);
    glCheck("overlay setup");
}

TextOverlay::~TextOverlay() {
    glDeleteTextures(1, &texture_);
    glDeleteVertexArrays(1, &vao_);
    glDeleteProgram(program_);
}

void TextOverlay::setText(const std::vector<std::string>& lines) {
    if (lines == lines_) return;
    lines_ = lines;
    mask_ = rasteriseText(lines);
    if (mask_.width == 0) return;
    glBindTexture(GL_TEXTURE_2D, texture_);
    glBindBuffer(GL_PIXEL_UNPACK_BUFFER, 0);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_R8, mask_.width, mask_.height, 0, GL_RED, GL_UNSIGNED_BYTE,
                 mask_.coverage.data());
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, 0);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    glCheck("overlay text upload");
}

void TextOverlay::draw(int viewportWidth, int viewportHeight) {
    if (mask_.width == 0 || viewportWidth <= 0 || viewportHeight <= 0) return;
    glViewport(0, 0, viewportWidth, viewportHeight);
    glEnable(GL_BLEND);
    glBlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
    glUseProgram(program_);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, texture_);
    glUniform1i(locMask_, 0);
    glUniform2f(locOrigin_, 0.0f, 0.0f);
    glUniform2f(locSize_, float(mask_.width), float(mask_.height));
    glUniform2f(locViewport_, float(viewportWidth), float(viewportHeight));
    glBindVertexArray(vao_);
    glDrawArrays(GL_TRIANGLE_STRIP, 0, 4);
    glBindVertexArray(0);
    glUseProgram(0);
    glDisable(GL_BLEND);
    glCheck("overlay draw");
}

} // namespace volcl::viewer
