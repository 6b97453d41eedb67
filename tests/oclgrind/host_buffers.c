// Oclgrind 21.10 false positives: buffers filled by clEnqueueFillBuffer or made with CL_MEM_USE_HOST_PTR.
// The kernel stores one byte of a 64-byte buffer the host initialised, four ways: CL_MEM_USE_HOST_PTR (how
// ComputeContext::wrapHost hands volumes to kernels, e.g. the voxels lift_bricks reads in load_voxels),
// clEnqueueFillBuffer (ComputeContext::fill), CL_MEM_COPY_HOST_PTR and clEnqueueWriteBuffer. Oclgrind
// --uninitialized reports the stored value as uninitialised for the first two, not for the last two.
// Usage: host_buffers use|fill|copy|write  (prints the kernel's result, 4)
#define CL_TARGET_OPENCL_VERSION 120
#include <CL/cl.h>
#include <stdio.h>
#include <string.h>

static const char* source = "__kernel void k(__global const uchar* in, __global int* out) {\n"
                            "    out[0] = in[3];\n"
                            "}\n";

int main(int argc, char** argv) {
    const char* mode = argc > 1 ? argv[1] : "use";
    cl_platform_id platform;
    cl_device_id device;
    if (clGetPlatformIDs(1, &platform, NULL) != CL_SUCCESS ||
        clGetDeviceIDs(platform, CL_DEVICE_TYPE_ALL, 1, &device, NULL) != CL_SUCCESS)
        return 2;
    cl_context context = clCreateContext(NULL, 1, &device, NULL, NULL, NULL);
    cl_command_queue queue = clCreateCommandQueue(context, device, 0, NULL);
    cl_program program = clCreateProgramWithSource(context, 1, &source, NULL, NULL);
    if (clBuildProgram(program, 1, &device, "", NULL, NULL) != CL_SUCCESS) return 2;
    cl_kernel kernel = clCreateKernel(program, "k", NULL);
    static unsigned char host[64] = {4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4,
                                     4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4,
                                     4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4};
    cl_mem in = NULL;
    if (strcmp(mode, "use") == 0 || strcmp(mode, "copy") == 0) {
        const cl_mem_flags flags = mode[0] == 'u' ? CL_MEM_USE_HOST_PTR : CL_MEM_COPY_HOST_PTR;
        in = clCreateBuffer(context, CL_MEM_READ_ONLY | flags, sizeof host, host, NULL);
    } else {
        in = clCreateBuffer(context, CL_MEM_READ_ONLY, sizeof host, NULL, NULL);
        const cl_int err =
            strcmp(mode, "fill") == 0
                ? clEnqueueFillBuffer(queue, in, host, 16, 0, sizeof host, 0, NULL, NULL)
                : clEnqueueWriteBuffer(queue, in, CL_TRUE, 0, sizeof host, host, 0, NULL, NULL);
        if (err != CL_SUCCESS) return 2;
    }
    cl_mem out = clCreateBuffer(context, CL_MEM_WRITE_ONLY, sizeof(int), NULL, NULL);
    clSetKernelArg(kernel, 0, sizeof in, &in);
    clSetKernelArg(kernel, 1, sizeof out, &out);
    const size_t one = 1;
    int result = 0;
    if (clEnqueueNDRangeKernel(queue, kernel, 1, NULL, &one, NULL, 0, NULL, NULL) != CL_SUCCESS ||
        clEnqueueReadBuffer(queue, out, CL_TRUE, 0, sizeof result, &result, 0, NULL, NULL) != CL_SUCCESS)
        return 2;
    printf("%d\n", result);
    clReleaseMemObject(in);
    clReleaseMemObject(out);
    clReleaseKernel(kernel);
    clReleaseProgram(program);
    clReleaseCommandQueue(queue);
    clReleaseContext(context);
    return 0;
}
