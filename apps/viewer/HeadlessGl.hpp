// Offscreen OpenGL 3.3 core contexts through EGL, without a window system (CI, --headless).
#pragma once

#include <string>

namespace volcl::viewer {

/// Which EGL platform a headless context came from.
enum class EglPlatform { Device, Surfaceless, Default };

/// An OpenGL 3.3 core context made current on this thread with no surface (render into a framebuffer
/// object). Tries, in order: the first EGL device (a GPU when there is one), Mesa's surfaceless platform
/// (llvmpipe on CPU-only machines), then the default display with a 1x1 pbuffer. `VOLCL_EGL_PLATFORM`
/// (device | surfaceless | default) forces one. Throws volcl::Error listing why each attempt failed.
/// Example:
/// ```
/// volcl::viewer::HeadlessGlContext gl;
/// std::cerr << gl.description() << '\n';   // "EGL surfaceless: OpenGL 4.5 (Core Profile) Mesa ..., llvmpipe
/// ..." volcl::viewer::FramePresenter presenter;
/// ```
class HeadlessGlContext {
public:
    HeadlessGlContext();
    ~HeadlessGlContext();
    HeadlessGlContext(const HeadlessGlContext&) = delete;
    HeadlessGlContext& operator=(const HeadlessGlContext&) = delete;
    EglPlatform platform() const noexcept { return platform_; }
    /// Platform, GL version and renderer strings.
    std::string description() const;

private:
    void* display_ = nullptr;
    void* context_ = nullptr;
    void* surface_ = nullptr;
    EglPlatform platform_ = EglPlatform::Surfaceless;
};

} // namespace volcl::viewer
