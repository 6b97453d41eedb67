// Frame upload through a pixel-unpack buffer, display-encoding shader, offscreen framebuffer and read-back.
#include "apps/viewer/GlPresenter.hpp"

#include "core/Error.hpp"
#include "core/runtime/ClRuntime.hpp"

#include <epoxy/gl.h>

#include <algorithm>
#include <cstring>
#include <sstream>
#include <vector>

namespace volcl::viewer {
namespace {

// One triangle covering the viewport, generated from gl_VertexID: no vertex buffer to manage.
// The texture's row 0 holds the image's top row, so v runs downwards.
constexpr const char* kVertexShader = R"(#version 330 core
out vec2 uv;
void main() {
    vec2 p = vec2(float((gl_VertexID & 1) << 2) - 1.0, float((gl_VertexID & 2) << 1) - 1.0);
    uv = vec2(0.5 * (p.x + 1.0), 1.0 - 0.5 * (p.y + 1.0));
    gl_Position = vec4(p, 0.0, 1.0);
}
)";

// compositeOverSrgb() (host/image/ImageIo.cpp) in GLSL: associated colour over the associated background,
// back to straight colour, then the sRGB curve with the same clamps.
constexpr const char* kFragmentShader = R"(#version 330 core
in vec2 uv;
out vec4 colour;
uniform sampler2D frame;
uniform vec4 background;
float srgb(float c) {
    if (!(c > 0.0)) return 0.0;
    if (c >= 1.0) return 1.0;
    if (c <= 0.0031308) return 12.92 * c;
    return 1.055 * pow(c, 1.0 / 2.4) - 0.055;
}
void main() {
    vec4 p = texture(frame, uv);
    float a = clamp(p.a, 0.0, 1.0);
    float ba = clamp(background.a, 0.0, 1.0);
    float outA = 1.0 - (1.0 - a) * (1.0 - ba);
    vec3 assoc = p.rgb + (1.0 - a) * background.rgb * ba;
    vec3 straight = outA > 0.0 ? assoc / outA : vec3(0.0);
    colour = vec4(srgb(straight.r), srgb(straight.g), srgb(straight.b), outA);
}
)";

} // namespace

unsigned compileShader(unsigned kind, const char* source, std::string_view what) {
    const GLuint s = glCreateShader(kind);
    glShaderSource(s, 1, &source, nullptr);
    glCompileShader(s);
    GLint ok = GL_FALSE;
    glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
    if (ok != GL_TRUE) {
        char log[2048] = {};
        glGetShaderInfoLog(s, sizeof log, nullptr, log);
        glDeleteShader(s);
        throw Error("OpenGL: " + std::string(what) + " shader does not compile: " + log);
    }
    return s;
}

unsigned linkProgram(const char* vertexSource, const char* fragmentSource, std::string_view what) {
    const GLuint vs = compileShader(GL_VERTEX_SHADER, vertexSource, what);
    GLuint fs = 0;
    try {
        fs = compileShader(GL_FRAGMENT_SHADER, fragmentSource, what);
    } catch (...) {
        glDeleteShader(vs);
        throw;
    }
    const GLuint program = glCreateProgram();
    glAttachShader(program, vs);
    glAttachShader(program, fs);
    glLinkProgram(program);
    glDeleteShader(vs);
    glDeleteShader(fs);
    GLint ok = GL_FALSE;
    glGetProgramiv(program, GL_LINK_STATUS, &ok);
    if (ok != GL_TRUE) {
        char log[2048] = {};
        glGetProgramInfoLog(program, sizeof log, nullptr, log);
        glDeleteProgram(program);
        throw Error("OpenGL: " + std::string(what) + " program does not link: " + log);
    }
    return program;
}

std::string_view frameTransportName(FrameTransport t) noexcept {
    return t == FrameTransport::Pbo ? "pixel buffer object" : "cl_khr_gl_sharing";
}

TransportRequest parseTransportRequest(std::string_view text) {
    if (text == "auto") return TransportRequest::Auto;
    if (text == "pbo") return TransportRequest::Pbo;
    if (text == "share") return TransportRequest::Share;
    throw UsageError("--transport '" + std::string(text) + "' is unknown (auto, pbo, share)");
}

FrameTransport availableTransport(const DeviceInfo& device) {
    return device.hasExtension("cl_khr_gl_sharing") ? FrameTransport::ClGlSharing : FrameTransport::Pbo;
}

FrameTransport chooseTransport(TransportRequest request, const DeviceInfo& device) {
    const FrameTransport available = availableTransport(device);
    switch (request) {
    case TransportRequest::Pbo:
        return FrameTransport::Pbo;
    case TransportRequest::Auto:
        return available;
    case TransportRequest::Share:
        break;
    }
    if (available != FrameTransport::ClGlSharing)
        throw Error("view: --transport share: OpenCL device '" + device.name +
                    "' does not list cl_khr_gl_sharing (use --transport pbo or auto)");
    return FrameTransport::ClGlSharing;
}

void glCheck(const char* what) {
    const GLenum e = glGetError();
    if (e == GL_NO_ERROR) return;
    while (glGetError() != GL_NO_ERROR) {
    }
    std::ostringstream os;
    os << "OpenGL error 0x" << std::hex << e << " in " << what;
    throw Error(os.str());
}

FramePresenter::FramePresenter() {
    if (epoxy_gl_version() < 33)
        throw Error("OpenGL: the viewer needs OpenGL 3.3, the context offers " +
                    std::to_string(epoxy_gl_version() / 10) + "." + std::to_string(epoxy_gl_version() % 10));
    program_ = linkProgram(kVertexShader, kFragmentShader, "viewer");
    locFrame_ = glGetUniformLocation(program_, "frame");
    locBackground_ = glGetUniformLocation(program_, "background");
    glGenVertexArrays(1, &vao_); // core profile draws need a bound vertex array, even an empty one
    glGenTextures(1, &texture_);
    glGenBuffers(1, &pbo_);
    glCheck("viewer setup");
}

FramePresenter::~FramePresenter() {
    glDeleteBuffers(1, &pbo_);
    glDeleteTextures(1, &texture_);
    glDeleteVertexArrays(1, &vao_);
    glDeleteProgram(program_);
}

void FramePresenter::upload(const ImageBuffer& frame) {
    if (frame.width <= 0 || frame.height <= 0) throw Error("viewer: empty frame");
    int idx[4] = {-1, -1, -1, -1};
    const char* want[4] = {"R", "G", "B", "A"};
    for (int c = 0; c < frame.channelCount(); ++c)
        for (int k = 0; k < 4; ++k)
            if (frame.channels[std::size_t(c)] == want[k] && idx[k] < 0) idx[k] = c;
    for (int k = 0; k < 4; ++k)
        if (idx[k] < 0) throw Error(std::string("viewer: frame has no channel ") + want[k]);

    const std::size_t pixels = std::size_t(frame.width) * std::size_t(frame.height);
    const std::size_t bytes = pixels * 4 * sizeof(float);
    ensureTexture(frame.width, frame.height);
    glBindBuffer(GL_PIXEL_UNPACK_BUFFER, pbo_);
    // Orphan the buffer so the driver never waits for the previous frame's transfer.
    glBufferData(GL_PIXEL_UNPACK_BUFFER, GLsizeiptr(bytes), nullptr, GL_STREAM_DRAW);
    void* mapped = glMapBufferRange(GL_PIXEL_UNPACK_BUFFER, 0, GLsizeiptr(bytes),
                                    GL_MAP_WRITE_BIT | GL_MAP_INVALIDATE_BUFFER_BIT);
    if (!mapped) {
        glBindBuffer(GL_PIXEL_UNPACK_BUFFER, 0);
        glCheck("glMapBufferRange");
        throw Error("OpenGL: cannot map the pixel-unpack buffer");
    }
    float* dst = static_cast<float*>(mapped);
    const int nc = frame.channelCount();
    if (nc == 4 && idx[0] == 0 && idx[1] == 1 && idx[2] == 2 && idx[3] == 3) {
        std::memcpy(dst, frame.pixels.data(), bytes);
    } else {
        const float* src = frame.pixels.data();
        for (std::size_t i = 0; i < pixels; ++i, src += nc, dst += 4)
            for (int k = 0; k < 4; ++k)
                dst[k] = src[idx[k]];
    }
    glUnmapBuffer(GL_PIXEL_UNPACK_BUFFER);
    glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, frame.width, frame.height, GL_RGBA, GL_FLOAT, nullptr);
    glBindBuffer(GL_PIXEL_UNPACK_BUFFER, 0);
    glCheck("frame upload");
}

void FramePresenter::ensureTexture(int width, int height) {
    glBindTexture(GL_TEXTURE_2D, texture_);
    // Allocate before binding an unpack buffer: with one bound, the null pointer would read from it.
    glBindBuffer(GL_PIXEL_UNPACK_BUFFER, 0);
    if (width == texWidth_ && height == texHeight_) return;
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, width, height, 0, GL_RGBA, GL_FLOAT, nullptr);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, 0);
    texWidth_ = width;
    texHeight_ = height;
}

void FramePresenter::uploadFromBuffer(unsigned unpackBuffer, int width, int height) {
    if (width <= 0 || height <= 0) throw Error("viewer: empty frame");
    ensureTexture(width, height);
    glBindBuffer(GL_PIXEL_UNPACK_BUFFER, unpackBuffer);
    glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, width, height, GL_RGBA, GL_FLOAT, nullptr);
    glBindBuffer(GL_PIXEL_UNPACK_BUFFER, 0);
    glCheck("shared frame upload");
}

void FramePresenter::draw(int width, int height, std::array<double, 4> background) {
    if (texWidth_ == 0) throw Error("viewer: draw before the first frame upload");
    glViewport(0, 0, width, height);
    glDisable(GL_BLEND);
    glDisable(GL_DEPTH_TEST);
    glUseProgram(program_);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, texture_);
    // Same size: every fragment lands on a texel centre, NEAREST returns it unchanged. Smaller (adaptive
    // quality): bilinear magnification.
    const GLint filter = (width == texWidth_ && height == texHeight_) ? GL_NEAREST : GL_LINEAR;
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, filter);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, filter);
    glUniform1i(locFrame_, 0);
    glUniform4f(locBackground_, float(background[0]), float(background[1]), float(background[2]),
                float(background[3]));
    glBindVertexArray(vao_);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glBindVertexArray(0);
    glUseProgram(0);
    glCheck("frame draw");
}

OffscreenFramebuffer::OffscreenFramebuffer(int width, int height) {
    glGenFramebuffers(1, &fbo_);
    glGenRenderbuffers(1, &colour_);
    try {
        resize(width, height);
    } catch (...) {
        glDeleteRenderbuffers(1, &colour_);
        glDeleteFramebuffers(1, &fbo_);
        throw;
    }
}

OffscreenFramebuffer::~OffscreenFramebuffer() {
    glDeleteRenderbuffers(1, &colour_);
    glDeleteFramebuffers(1, &fbo_);
}

void OffscreenFramebuffer::resize(int width, int height) {
    if (width <= 0 || height <= 0) throw UsageError("viewer: framebuffer size must be positive");
    glBindRenderbuffer(GL_RENDERBUFFER, colour_);
    glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, width, height);
    glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, colour_);
    const GLenum status = glCheckFramebufferStatus(GL_FRAMEBUFFER);
    if (status != GL_FRAMEBUFFER_COMPLETE) {
        std::ostringstream os;
        os << "OpenGL: offscreen framebuffer " << width << "x" << height << " incomplete (0x" << std::hex
           << status << ")";
        throw Error(os.str());
    }
    width_ = width;
    height_ = height;
    glCheck("offscreen framebuffer");
}

void OffscreenFramebuffer::bind() const {
    glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
}

ImageBuffer readFramebuffer(int width, int height) {
    std::vector<unsigned char> rgba(std::size_t(width) * std::size_t(height) * 4);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glReadPixels(0, 0, width, height, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());
    glCheck("glReadPixels");
    ImageBuffer out(width, height, {"R", "G", "B", "A"});
    // GL rows run bottom-up; images top-down.
    for (int y = 0; y < height; ++y) {
        const unsigned char* row = rgba.data() + std::size_t(height - 1 - y) * std::size_t(width) * 4;
        for (int x = 0; x < width; ++x)
            for (int c = 0; c < 4; ++c)
                out.at(x, y, c) = float(row[std::size_t(x) * 4 + c]) / 255.0f;
    }
    return out;
}

} // namespace volcl::viewer
