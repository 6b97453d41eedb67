// cl_khr_gl_sharing transport: a GL pixel buffer the OpenCL device writes through clCreateFromGLBuffer.
#pragma once

#include <CL/opencl.hpp>

#include <vector>

namespace volcl {
class ComputeContext;
}

namespace volcl::viewer {

class FramePresenter;

/// Context properties that tie a new OpenCL context to the OpenGL context current on this thread:
/// CL_GL_CONTEXT_KHR with CL_EGL_DISPLAY_KHR (headless EGL) or CL_GLX_DISPLAY_KHR (GLFW window on X11).
/// Pass them to ComputeContext(selector, properties). Throws volcl::Error when no GL context is current.
std::vector<cl_context_properties> glSharingContextProperties();

/// The cl_khr_gl_sharing entry points the viewer calls.
struct ClGlEntryPoints {
    using CreateFromGlBuffer = cl_mem(CL_API_CALL*)(cl_context, cl_mem_flags, cl_GLuint, cl_int*);
    using EnqueueGlObjects = cl_int(CL_API_CALL*)(cl_command_queue, cl_uint, const cl_mem*, cl_uint,
                                                  const cl_event*, cl_event*);
    CreateFromGlBuffer createFromGlBuffer = nullptr;
    EnqueueGlObjects acquire = nullptr, release = nullptr;
};

/// One GL buffer shared with OpenCL. Only for a ComputeContext whose device lists cl_khr_gl_sharing and
/// which was created with glSharingContextProperties(): PoCL aborts when its GL entry points are called,
/// so the constructor checks the extension first and throws volcl::Error without it. Example:
/// ```
/// volcl::ComputeContext cc(selector, volcl::viewer::glSharingContextProperties());
/// volcl::viewer::SharedFrameBuffer shared(cc);
/// renderer.render();
/// shared.present(renderer.outputBuffer(), width, height, presenter); // device copy, then texture upload
/// ```
class SharedFrameBuffer {
public:
    explicit SharedFrameBuffer(ComputeContext& cc);
    /// With given entry points (no extension check, no lookup): lets tests run the whole frame path on a
    /// device without the extension by emulating the sharing with copies.
    SharedFrameBuffer(ComputeContext& cc, const ClGlEntryPoints& entryPoints);
    ~SharedFrameBuffer();
    SharedFrameBuffer(const SharedFrameBuffer&) = delete;
    SharedFrameBuffer& operator=(const SharedFrameBuffer&) = delete;

    /// Copies `frame` (width x height float4 on the device) into the shared buffer between
    /// clEnqueueAcquireGLObjects and clEnqueueReleaseGLObjects (glFinish before, clFinish after: the
    /// extension's portable synchronisation), then uploads it into the presenter's texture.
    void present(const cl::Buffer& frame, int width, int height, FramePresenter& presenter);

private:
    ComputeContext& cc_;
    ClGlEntryPoints fn_;
    unsigned glBuffer_ = 0;
    cl::Buffer shared_;
    std::size_t bytes_ = 0;
};

} // namespace volcl::viewer
