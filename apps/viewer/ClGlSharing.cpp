// cl_khr_gl_sharing: context properties from the current EGL/GLX context and a GL buffer OpenCL writes.
#include "apps/viewer/ClGlSharing.hpp"

#include "apps/viewer/GlPresenter.hpp"
#include "core/Error.hpp"
#include "core/runtime/ClRuntime.hpp"

#include <CL/cl_gl.h>
#include <epoxy/egl.h>
#include <epoxy/gl.h>
// GLX last: Xlib's macros (None, Bool, Status) must not reach the headers above.
#include <epoxy/glx.h>

namespace volcl::viewer {

std::vector<cl_context_properties> glSharingContextProperties() {
    // EGL first: the headless path; a GLFW window on X11 has a GLX context and no current EGL one.
    if (epoxy_has_egl()) {
        const EGLContext ctx = eglGetCurrentContext();
        if (ctx != EGL_NO_CONTEXT)
            return {CL_GL_CONTEXT_KHR, reinterpret_cast<cl_context_properties>(ctx), CL_EGL_DISPLAY_KHR,
                    reinterpret_cast<cl_context_properties>(eglGetCurrentDisplay())};
    }
    if (GLXContext ctx = glXGetCurrentContext())
        return {CL_GL_CONTEXT_KHR, reinterpret_cast<cl_context_properties>(ctx), CL_GLX_DISPLAY_KHR,
                reinterpret_cast<cl_context_properties>(glXGetCurrentDisplay())};
    throw Error("cl_khr_gl_sharing: no current EGL or GLX context to share with");
}

namespace {

ClGlEntryPoints lookUpEntryPoints(const ComputeContext& cc) {
    // Never look up the entry points on a device without the extension (PoCL aborts in them).
    if (!cc.device().hasExtension("cl_khr_gl_sharing"))
        throw Error("OpenCL device '" + cc.device().name + "' does not list cl_khr_gl_sharing");
    const cl_platform_id platform = cc.device().device.getInfo<CL_DEVICE_PLATFORM>();
    ClGlEntryPoints fn;
    fn.createFromGlBuffer = reinterpret_cast<ClGlEntryPoints::CreateFromGlBuffer>(
        clGetExtensionFunctionAddressForPlatform(platform, "clCreateFromGLBuffer"));
    fn.acquire = reinterpret_cast<ClGlEntryPoints::EnqueueGlObjects>(
        clGetExtensionFunctionAddressForPlatform(platform, "clEnqueueAcquireGLObjects"));
    fn.release = reinterpret_cast<ClGlEntryPoints::EnqueueGlObjects>(
        clGetExtensionFunctionAddressForPlatform(platform, "clEnqueueReleaseGLObjects"));
    // ICD platforms may keep these in the loader's dispatch table rather than answer the lookup; the
    // loader's exports dispatch to the same driver functions.
    if (!fn.createFromGlBuffer) fn.createFromGlBuffer = &::clCreateFromGLBuffer;
    if (!fn.acquire) fn.acquire = &::clEnqueueAcquireGLObjects;
    if (!fn.release) fn.release = &::clEnqueueReleaseGLObjects;
    return fn;
}

} // namespace

SharedFrameBuffer::SharedFrameBuffer(ComputeContext& cc) : SharedFrameBuffer(cc, lookUpEntryPoints(cc)) {}

SharedFrameBuffer::SharedFrameBuffer(ComputeContext& cc, const ClGlEntryPoints& entryPoints)
    : cc_(cc), fn_(entryPoints) {
    if (!fn_.createFromGlBuffer || !fn_.acquire || !fn_.release)
        throw Error("cl_khr_gl_sharing: missing entry points");
    glGenBuffers(1, &glBuffer_);
    glCheck("shared buffer");
}

SharedFrameBuffer::~SharedFrameBuffer() {
    shared_ = cl::Buffer(); // the CL object goes before the GL buffer it wraps
    glDeleteBuffers(1, &glBuffer_);
}

void SharedFrameBuffer::present(const cl::Buffer& frame, int width, int height, FramePresenter& presenter) {
    if (width <= 0 || height <= 0) throw Error("viewer: empty frame");
    const std::size_t bytes = std::size_t(width) * std::size_t(height) * 4 * sizeof(float);
    if (!frame() || frame.getInfo<CL_MEM_SIZE>() < bytes)
        throw Error("viewer: the rendered frame buffer is smaller than " + std::to_string(width) + "x" +
                    std::to_string(height) + " float4");
    if (bytes != bytes_) {
        shared_ = cl::Buffer();
        glBindBuffer(GL_PIXEL_UNPACK_BUFFER, glBuffer_);
        glBufferData(GL_PIXEL_UNPACK_BUFFER, GLsizeiptr(bytes), nullptr, GL_STREAM_DRAW);
        glBindBuffer(GL_PIXEL_UNPACK_BUFFER, 0);
        glCheck("shared buffer storage");
        cl_int err = CL_SUCCESS;
        cl_mem mem = fn_.createFromGlBuffer(cc_.context()(), CL_MEM_WRITE_ONLY, glBuffer_, &err);
        clCheck(err, "clCreateFromGLBuffer");
        shared_ = cl::Buffer(mem); // takes the reference clCreateFromGLBuffer returned
        bytes_ = bytes;
    }
    // GL must be done with the buffer (last frame's texture upload) before OpenCL writes it.
    glFinish();
    cl_command_queue q = cc_.queue()();
    cl_mem mem = shared_();
    clCheck(fn_.acquire(q, 1, &mem, 0, nullptr, nullptr), "clEnqueueAcquireGLObjects");
    clCheck(cc_.queue().enqueueCopyBuffer(frame, shared_, 0, 0, bytes), "clEnqueueCopyBuffer");
    clCheck(fn_.release(q, 1, &mem, 0, nullptr, nullptr), "clEnqueueReleaseGLObjects");
    clCheck(cc_.queue().finish(), "clFinish");
    presenter.uploadFromBuffer(glBuffer_, width, height);
}

} // namespace volcl::viewer
