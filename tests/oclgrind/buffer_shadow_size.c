// Oclgrind 21.10 false positives: a buffer's uninitialised-value record sized by its last host write or by an earlier buffer.
// Oclgrind --uninitialized keeps one record ("shadow") per buffer number. Each clEnqueueWriteBuffer replaces the
// buffer's record with a new one the size of that write, so after writes at several offsets only the last
// write's size, from offset 0, counts as initialised. A record is not dropped when its buffer is released: a new
// buffer that gets the same number (the next one created) keeps the old record's size, and what kernels store
// past it reads as uninitialised. Four modes, each storing 16 float4 in `mid` and copying them to `out`:
//   split  the host writes mid's second half (offset 128), then its first half (offset 0), as the brick renderer
//          writes decoded bricks at their pool offsets and then the page table at 0: the second half reports;
//   whole  one write of all of mid: no report;
//   reuse  a 16-byte buffer is used by a kernel and released, then mid (16 halves x 4, made by vstore_half4_rte
//          and read by vload_half4, as kb_table_to_half and kb_table_from_half) is created: all but the first
//          two entries report;
//   fresh  the same without the earlier buffer: no report.
// Usage: buffer_shadow_size split|whole|reuse|fresh  (prints "equal" when out holds the input values)
#define CL_TARGET_OPENCL_VERSION 120
#include <CL/cl.h>
#include <stdio.h>
#include <string.h>

static const char* source = "__kernel void to_half(__global const float4* in, __global half* out) {\n"
                            "    const uint i = get_global_id(0);\n"
                            "    vstore_half4_rte(in[i], i, out);\n"
                            "}\n"
                            "__kernel void from_half(__global const half* in, __global float4* out) {\n"
                            "    const uint i = get_global_id(0);\n"
                            "    out[i] = vload_half4(i, in);\n"
                            "}\n"
                            "__kernel void copy(__global const float4* in, __global float4* out) {\n"
                            "    const uint i = get_global_id(0);\n"
                            "    out[i] = in[i];\n"
                            "}\n";

enum { N = 16 };

int main(int argc, char** argv) {
    const char* mode = argc > 1 ? argv[1] : "split";
    const int viaHalf = strcmp(mode, "reuse") == 0 || strcmp(mode, "fresh") == 0;
    cl_platform_id platform;
    cl_device_id device;
    if (clGetPlatformIDs(1, &platform, NULL) != CL_SUCCESS ||
        clGetDeviceIDs(platform, CL_DEVICE_TYPE_ALL, 1, &device, NULL) != CL_SUCCESS)
        return 2;
    cl_context context = clCreateContext(NULL, 1, &device, NULL, NULL, NULL);
    cl_command_queue queue = clCreateCommandQueue(context, device, 0, NULL);
    cl_program program = clCreateProgramWithSource(context, 1, &source, NULL, NULL);
    if (clBuildProgram(program, 1, &device, "", NULL, NULL) != CL_SUCCESS) return 2;
    cl_kernel toHalf = clCreateKernel(program, "to_half", NULL);
    cl_kernel fromHalf = clCreateKernel(program, "from_half", NULL);
    cl_kernel copy = clCreateKernel(program, "copy", NULL);
    float host[4 * N]; // values exact in half precision
    for (int i = 0; i < 4 * N; ++i)
        host[i] = 0.25f * (float)i;
    cl_mem in = clCreateBuffer(context, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof host, host, NULL);
    const size_t n = N, one = 1;
    if (strcmp(mode, "reuse") == 0) {
        cl_mem earlier = clCreateBuffer(context, CL_MEM_READ_WRITE, 16, NULL, NULL);
        clSetKernelArg(toHalf, 0, sizeof in, &in);
        clSetKernelArg(toHalf, 1, sizeof earlier, &earlier);
        if (clEnqueueNDRangeKernel(queue, toHalf, 1, NULL, &one, NULL, 0, NULL, NULL) != CL_SUCCESS) return 2;
        clReleaseMemObject(earlier);
        clFinish(queue);
    }
    const size_t midBytes = viaHalf ? 8 * N : sizeof host;
    cl_mem mid = clCreateBuffer(context, CL_MEM_READ_WRITE, midBytes, NULL, NULL);
    cl_mem out = clCreateBuffer(context, CL_MEM_WRITE_ONLY, sizeof host, NULL, NULL);
    cl_int err = CL_SUCCESS;
    if (viaHalf) {
        clSetKernelArg(toHalf, 0, sizeof in, &in);
        clSetKernelArg(toHalf, 1, sizeof mid, &mid);
        err = clEnqueueNDRangeKernel(queue, toHalf, 1, NULL, &n, NULL, 0, NULL, NULL);
    } else if (strcmp(mode, "split") == 0) {
        const size_t h = midBytes / 2;
        err = clEnqueueWriteBuffer(queue, mid, CL_TRUE, h, h, (const char*)host + h, 0, NULL, NULL);
        err |= clEnqueueWriteBuffer(queue, mid, CL_TRUE, 0, h, host, 0, NULL, NULL);
    } else {
        err = clEnqueueWriteBuffer(queue, mid, CL_TRUE, 0, midBytes, host, 0, NULL, NULL);
    }
    cl_kernel reader = viaHalf ? fromHalf : copy;
    clSetKernelArg(reader, 0, sizeof mid, &mid);
    clSetKernelArg(reader, 1, sizeof out, &out);
    float result[4 * N];
    if (err != CL_SUCCESS ||
        clEnqueueNDRangeKernel(queue, reader, 1, NULL, &n, NULL, 0, NULL, NULL) != CL_SUCCESS ||
        clEnqueueReadBuffer(queue, out, CL_TRUE, 0, sizeof result, result, 0, NULL, NULL) != CL_SUCCESS)
        return 2;
    printf("%s\n", memcmp(result, host, sizeof host) == 0 ? "equal" : "differ");
    clReleaseMemObject(in);
    clReleaseMemObject(mid);
    clReleaseMemObject(out);
    clReleaseKernel(toHalf);
    clReleaseKernel(fromHalf);
    clReleaseKernel(copy);
    clReleaseProgram(program);
    clReleaseCommandQueue(queue);
    clReleaseContext(context);
    return 0;
}
