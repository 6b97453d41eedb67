// EGL context creation for the headless viewer: device, Mesa surfaceless or default platform.
#include "apps/viewer/HeadlessGl.hpp"

#include "core/Error.hpp"

#include <epoxy/egl.h>
#include <epoxy/gl.h>

#include <dlfcn.h>
#include <link.h>

#include <cstdlib>
#include <cstring>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

namespace volcl::viewer {
namespace {

std::string eglErrorText() {
    std::ostringstream os;
    os << "EGL error 0x" << std::hex << eglGetError();
    return os.str();
}

bool hasToken(const char* list, std::string_view token) {
    if (!list) return false;
    std::string_view s(list);
    std::size_t pos = 0;
    while (pos < s.size()) {
        const std::size_t end = std::min(s.find(' ', pos), s.size());
        if (s.substr(pos, end - pos) == token) return true;
        pos = end + 1;
    }
    return false;
}

struct Attempt {
    EGLDisplay display = EGL_NO_DISPLAY;
    EGLContext context = EGL_NO_CONTEXT;
    EGLSurface surface = EGL_NO_SURFACE;
};

// Creates and makes current a 3.3 core context on an initialised display; `needSurface` asks for a pbuffer.
// Returns an empty string on success, else the reason.
std::string makeContext(Attempt& a, bool needSurface) {
    EGLint major = 0, minor = 0;
    if (!eglInitialize(a.display, &major, &minor)) return "eglInitialize failed (" + eglErrorText() + ")";
    if (!eglBindAPI(EGL_OPENGL_API)) return "no desktop OpenGL API (" + eglErrorText() + ")";
    const char* ext = eglQueryString(a.display, EGL_EXTENSIONS);
    EGLConfig config = nullptr;
    const bool configless =
        hasToken(ext, "EGL_KHR_no_config_context") || hasToken(ext, "EGL_MESA_configless_context");
    if (needSurface || !configless) {
        const EGLint want[] = {EGL_SURFACE_TYPE,
                               needSurface ? EGL_PBUFFER_BIT : 0,
                               EGL_RENDERABLE_TYPE,
                               EGL_OPENGL_BIT,
                               EGL_RED_SIZE,
                               8,
                               EGL_GREEN_SIZE,
                               8,
                               EGL_BLUE_SIZE,
                               8,
                               EGL_NONE};
        EGLint count = 0;
        if (!eglChooseConfig(a.display, want, &config, 1, &count) || count < 1)
            return "no OpenGL-renderable EGL config";
    }
    if (!needSurface && !hasToken(ext, "EGL_KHR_surfaceless_context"))
        return "display lacks EGL_KHR_surfaceless_context";
    const EGLint attribs[] = {EGL_CONTEXT_MAJOR_VERSION,
                              3,
                              EGL_CONTEXT_MINOR_VERSION,
                              3,
                              EGL_CONTEXT_OPENGL_PROFILE_MASK,
                              EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                              EGL_NONE};
    a.context = eglCreateContext(a.display, config ? config : EGL_NO_CONFIG_KHR, EGL_NO_CONTEXT, attribs);
    if (a.context == EGL_NO_CONTEXT) return "no OpenGL 3.3 core context (" + eglErrorText() + ")";
    if (needSurface) {
        const EGLint size[] = {EGL_WIDTH, 1, EGL_HEIGHT, 1, EGL_NONE};
        a.surface = eglCreatePbufferSurface(a.display, config, size);
        if (a.surface == EGL_NO_SURFACE) return "no pbuffer surface (" + eglErrorText() + ")";
    }
    if (!eglMakeCurrent(a.display, a.surface, a.surface, a.context))
        return "eglMakeCurrent failed (" + eglErrorText() + ")";
    return {};
}

void release(Attempt& a) {
    if (a.display == EGL_NO_DISPLAY) return;
    eglMakeCurrent(a.display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    if (a.surface != EGL_NO_SURFACE) eglDestroySurface(a.display, a.surface);
    if (a.context != EGL_NO_CONTEXT) eglDestroyContext(a.display, a.context);
    eglTerminate(a.display);
    a = {};
}

// Keeps every Mesa DRI driver now mapped (<libdir>/dri/*_dri.so, e.g. llvmpipe's swrast_dri.so) loaded until
// the process exits. eglTerminate unloads the driver while its process-lifetime allocations are still held by
// the driver's own globals: LeakSanitizer then reports them as leaks from an unknown module, which no
// suppression can name. Pinned, they stay reachable (and attributable to the driver), and a second context
// does not map the driver again. RTLD_NOLOAD only raises the flags of an object already loaded.
// (The names are collected first: dlopen must not run inside dl_iterate_phdr, which holds the loader's lock.)
void pinGlDrivers() {
    std::vector<std::string> drivers;
    dl_iterate_phdr(
        [](dl_phdr_info* info, std::size_t, void* out) {
            if (info->dlpi_name && std::strstr(info->dlpi_name, "/dri/"))
                static_cast<std::vector<std::string>*>(out)->emplace_back(info->dlpi_name);
            return 0;
        },
        &drivers);
    for (const std::string& driver : drivers)
        dlopen(driver.c_str(), RTLD_NOW | RTLD_NOLOAD | RTLD_NODELETE);
}

const char* platformName(EglPlatform p) {
    switch (p) {
    case EglPlatform::Device:
        return "device";
    case EglPlatform::Surfaceless:
        return "surfaceless";
    case EglPlatform::Default:
        return "default";
    }
    return "?";
}

} // namespace

HeadlessGlContext::HeadlessGlContext() {
    const char* clientExt = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    std::vector<EglPlatform> order{EglPlatform::Device, EglPlatform::Surfaceless, EglPlatform::Default};
    if (const char* forced = std::getenv("VOLCL_EGL_PLATFORM"); forced && *forced) {
        const std::string_view f(forced);
        if (f == "device")
            order = {EglPlatform::Device};
        else if (f == "surfaceless")
            order = {EglPlatform::Surfaceless};
        else if (f == "default")
            order = {EglPlatform::Default};
        else
            throw UsageError("VOLCL_EGL_PLATFORM must be device, surfaceless or default, not '" +
                             std::string(f) + "'");
    }
    std::string failures;
    for (EglPlatform p : order) {
        Attempt a;
        std::string why;
        if (p == EglPlatform::Device) {
            if (!hasToken(clientExt, "EGL_EXT_platform_device") ||
                !hasToken(clientExt, "EGL_EXT_device_enumeration")) {
                why = "EGL_EXT_platform_device not offered";
            } else {
                EGLDeviceEXT devices[8];
                EGLint count = 0;
                if (!eglQueryDevicesEXT(8, devices, &count) || count < 1)
                    why = "no EGL device";
                else
                    a.display = eglGetPlatformDisplayEXT(EGL_PLATFORM_DEVICE_EXT, devices[0], nullptr);
            }
        } else if (p == EglPlatform::Surfaceless) {
            if (!hasToken(clientExt, "EGL_MESA_platform_surfaceless"))
                why = "EGL_MESA_platform_surfaceless not offered";
            else
                a.display =
                    eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
        } else {
            a.display = eglGetDisplay(EGL_DEFAULT_DISPLAY);
        }
        if (why.empty() && a.display == EGL_NO_DISPLAY) why = "no display (" + eglErrorText() + ")";
        if (why.empty()) why = makeContext(a, p == EglPlatform::Default);
        if (why.empty() && epoxy_gl_version() < 33) why = "context offers OpenGL below 3.3";
        if (why.empty()) {
            display_ = a.display;
            context_ = a.context;
            surface_ = a.surface;
            platform_ = p;
            pinGlDrivers();
            return;
        }
        release(a);
        failures += std::string(failures.empty() ? "" : "; ") + platformName(p) + ": " + why;
    }
    throw Error("no headless OpenGL 3.3 context through EGL (" + failures +
                "); install libegl-mesa0 and libgl1-mesa-dri (scripts/setup.sh)");
}

HeadlessGlContext::~HeadlessGlContext() {
    Attempt a{display_, context_, surface_};
    release(a);
}

std::string HeadlessGlContext::description() const {
    const auto str = [](GLenum name) {
        const GLubyte* s = glGetString(name);
        return s ? std::string(reinterpret_cast<const char*>(s)) : std::string("?");
    };
    return std::string("EGL ") + platformName(platform_) + ": OpenGL " + str(GL_VERSION) + ", " +
           str(GL_RENDERER);
}

} // namespace volcl::viewer
