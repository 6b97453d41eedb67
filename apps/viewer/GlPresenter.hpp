// OpenGL presentation of rendered frames: PBO upload into a float texture, display encoding in a shader,
// full-viewport draw, offscreen framebuffers and read-back. Needs a current OpenGL 3.3 core context.
#pragma once

#include "host/image/ImageIo.hpp"

#include <array>
#include <string>
#include <string_view>

namespace volcl {
struct DeviceInfo;
}

namespace volcl::viewer {

/// How a frame travels from OpenCL to OpenGL.
enum class FrameTransport {
    Pbo,        ///< host image -> mapped pixel-unpack buffer -> texture (works with every device)
    ClGlSharing ///< cl_khr_gl_sharing: the device copies the frame into a shared GL buffer -> texture
};
std::string_view frameTransportName(FrameTransport t) noexcept;

/// What `--transport` asks for.
enum class TransportRequest { Auto, Pbo, Share };
/// "auto", "pbo" or "share"; throws UsageError otherwise.
TransportRequest parseTransportRequest(std::string_view text);

/// The transport a device allows. PoCL lacks cl_khr_gl_sharing and aborts if its GL entry points are
/// called, so the extension is checked before anything else touches CL-GL interop.
FrameTransport availableTransport(const DeviceInfo& device);

/// Auto: sharing when the device lists cl_khr_gl_sharing, else the PBO. Pbo: always the PBO. Share: sharing,
/// or volcl::Error (exit 1) naming the device when it lacks the extension.
FrameTransport chooseTransport(TransportRequest request, const DeviceInfo& device);

/// Throws volcl::Error naming `what` if OpenGL has recorded an error.
void glCheck(const char* what);

/// Uploads linear associated RGBA frames and draws them over the viewport, composited over the scene
/// background and sRGB-encoded exactly as compositeOverSrgb() does for `volcl render` PNGs. Example:
/// ```
/// volcl::viewer::FramePresenter p;           // a GL 3.3 core context is current
/// p.upload(renderer.render());
/// p.draw(width, height, scene.background);
/// volcl::ImageBuffer shot = volcl::viewer::readFramebuffer(width, height);
/// ```
class FramePresenter {
public:
    FramePresenter();
    ~FramePresenter();
    FramePresenter(const FramePresenter&) = delete;
    FramePresenter& operator=(const FramePresenter&) = delete;

    /// Copies the R, G, B, A channels (other channels such as Z are skipped) into the pixel-unpack buffer
    /// and from there into the frame texture, reallocating both when the frame size changes.
    void upload(const ImageBuffer& frame);
    /// Uploads a frame that already sits in the GL buffer `unpackBuffer` as width x height RGBA floats (the
    /// cl_khr_gl_sharing path: OpenCL wrote it, no host copy).
    void uploadFromBuffer(unsigned unpackBuffer, int width, int height);
    /// Draws the frame texture over a viewport of `width` x `height` pixels of the bound framebuffer.
    /// A frame of the viewport's size is sampled texel for texel; a smaller one is magnified bilinearly.
    void draw(int width, int height, std::array<double, 4> background);

private:
    void ensureTexture(int width, int height);
    unsigned program_ = 0, vao_ = 0, texture_ = 0, pbo_ = 0;
    int locBackground_ = -1, locFrame_ = -1;
    int texWidth_ = 0, texHeight_ = 0;
};

/// An RGBA8 framebuffer object to render into without a window.
class OffscreenFramebuffer {
public:
    OffscreenFramebuffer(int width, int height);
    ~OffscreenFramebuffer();
    OffscreenFramebuffer(const OffscreenFramebuffer&) = delete;
    OffscreenFramebuffer& operator=(const OffscreenFramebuffer&) = delete;
    void resize(int width, int height);
    void bind() const;
    int width() const noexcept { return width_; }
    int height() const noexcept { return height_; }

private:
    unsigned fbo_ = 0, colour_ = 0;
    int width_ = 0, height_ = 0;
};

/// Compiles one GLSL shader stage (kind: GL_VERTEX_SHADER, ...); throws Error with the info log, naming
/// `what` ("viewer", "overlay").
unsigned compileShader(unsigned kind, const char* source, std::string_view what);
/// Compiles and links a vertex + fragment shader program; throws Error with the logs, naming `what`.
unsigned linkProgram(const char* vertexSource, const char* fragmentSource, std::string_view what);

/// Reads the bound framebuffer's colour as 8-bit RGBA into R, G, B, A channels holding k/255, row 0 at the
/// top (writeImage() stores those exactly as the 8-bit values read).
ImageBuffer readFramebuffer(int width, int height);

} // namespace volcl::viewer
