// OpenCL runtime: device discovery and choice, context + in-order queue, program cache, typed buffers, launches.
#pragma once

#include "core/Error.hpp"
#include "core/runtime/DeviceProfile.hpp"
#include "core/runtime/HostMemoryPool.hpp"

#include <CL/opencl.hpp>

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <string_view>
#include <tuple>
#include <type_traits>
#include <vector>

namespace volcl {

class KernelSourceLibrary;

/// Throws ClError(call, err) when err != CL_SUCCESS.
inline void clCheck(cl_int err, const char* call) {
    if (err != CL_SUCCESS) throw ClError(call, err);
}

/// What `volcl devices` prints about one device; `index` counts devices over all platforms in order.
struct DeviceInfo {
    std::size_t index = 0;
    std::string platform, name, vendor, version, driver;
    bool isCpu = false, isGpu = false;
    unsigned computeUnits = 0;
    std::uint64_t globalMemBytes = 0, maxAllocBytes = 0, localMemBytes = 0;
    std::size_t maxWorkGroupSize = 0;
    bool fp64 = false;
    std::string extensions;
    bool hasExtension(std::string_view ext) const;
    cl::Device device;
};

/// All OpenCL devices on all platforms. Empty when no ICD is installed.
std::vector<DeviceInfo> listDevices();

/// Preprocessor defines for kernel specialisation, rendered in sorted order so equal sets hash equally.
/// Example: `KernelDefines d; d.set("USE_SHADING", 1).set("TABLE_SIZE", 256);`
class KernelDefines {
public:
    template <class T>
    requires std::is_integral_v<T> KernelDefines& set(std::string name, T value) {
        return setText(std::move(name), std::to_string(value));
    }
    KernelDefines& set(std::string name, double value); ///< emitted as a float literal; must be finite
    KernelDefines& set(std::string name);               ///< defined, no value
    KernelDefines& erase(const std::string& name);      ///< no longer defined (absent: unchanged)
    std::string toOptions() const;                      ///< "-DA=1 -DB=2"
    bool operator==(const KernelDefines&) const = default;

private:
    KernelDefines& setText(std::string name, std::string value);
    std::map<std::string, std::string> values_;
};

/// A typed device buffer owning `count` elements of T. Move-only via cl::Buffer's reference counting.
template <class T> class DeviceBuffer {
public:
    DeviceBuffer() = default;
    DeviceBuffer(cl::Buffer buffer, std::size_t count) : buffer_(std::move(buffer)), count_(count) {}
    std::size_t size() const noexcept { return count_; }
    std::size_t bytes() const noexcept { return count_ * sizeof(T); }
    const cl::Buffer& get() const noexcept { return buffer_; }
    cl::Buffer& get() noexcept { return buffer_; }

private:
    cl::Buffer buffer_;
    std::size_t count_ = 0;
};

/// A device, its context and one in-order profiling queue, plus a program cache keyed on
/// (device, source hash, build options). Not thread-safe for concurrent launches; one per thread.
/// Example:
/// ```
/// volcl::ComputeContext cc;                       // VOLCL_DEVICE or the first device
/// auto k = cc.kernel("common/copy.cl", "copy_float", {});
/// auto a = cc.upload<float>(hostData);
/// auto b = cc.allocate<float>(hostData.size());
/// volcl::setArgs(k, a, b, cl_uint(hostData.size()));
/// cc.launch1d(k, hostData.size(), 64);
/// std::vector<float> out = cc.download(b);
/// ```
class ComputeContext {
public:
    /// `selector`: empty (use $VOLCL_DEVICE, else the first device), a device index ("1"), or a
    /// case-insensitive substring of the device or platform name. Throws Error when nothing matches.
    explicit ComputeContext(std::string_view selector = {});
    /// As above, with extra context properties (key, value pairs, no terminator) after CL_CONTEXT_PLATFORM,
    /// e.g. CL_GL_CONTEXT_KHR and CL_GLX_DISPLAY_KHR for a context that shares objects with OpenGL.
    ComputeContext(std::string_view selector, std::span<const cl_context_properties> extraProperties,
                   std::shared_ptr<HostMemoryPool> hostMemory = {});
    /// As the first, drawing host buffers from `hostMemory`: memory filled before the context existed
    /// (see adoptHost) comes from the same pool and goes back to it.
    ComputeContext(std::string_view selector, std::shared_ptr<HostMemoryPool> hostMemory);
    ~ComputeContext();
    ComputeContext(const ComputeContext&) = delete;
    ComputeContext& operator=(const ComputeContext&) = delete;

    const DeviceInfo& device() const noexcept { return device_; }
    /// This device's tuning (work-group sizes, CPU/GPU choices), chosen when the context was made.
    const DeviceProfile& profile() const noexcept { return *profile_; }
    cl::Context& context() noexcept { return context_; }
    cl::CommandQueue& queue() noexcept { return queue_; }
    const KernelSourceLibrary& sources() const noexcept { return *sources_; }

    /// Builds (or fetches from the cache) the program of one kernel file with defines and extra options.
    /// Build failures throw ClError whose buildLog() holds the compiler output.
    cl::Program program(std::string_view file, const KernelDefines& defines = {},
                        std::string_view extraOptions = {});
    cl::Kernel kernel(std::string_view file, std::string_view name, const KernelDefines& defines = {},
                      std::string_view extraOptions = {});
    std::size_t cachedProgramCount() const noexcept { return programs_.size(); }
    /// Programs this context created from the on-disk binary cache (see ProgramBinaryCache).
    std::size_t programsFromDiskCache() const noexcept { return programsFromDisk_; }

    template <class T> DeviceBuffer<T> allocate(std::size_t count, cl_mem_flags flags = CL_MEM_READ_WRITE) {
        return DeviceBuffer<T>(createBuffer(flags, std::max<std::size_t>(count, 1) * sizeof(T)), count);
    }
    /// A buffer over caller-owned host memory (CL_MEM_USE_HOST_PTR): on CPU devices kernels work on it in
    /// place. `host` must outlive the buffer; see the OpenCL rules on mapping before the host reads results.
    template <class T> DeviceBuffer<T> wrapHost(std::span<T> host, cl_mem_flags flags = CL_MEM_READ_WRITE) {
        cl_int err = CL_SUCCESS;
        cl::Buffer b(context_, flags | CL_MEM_USE_HOST_PTR, std::max<std::size_t>(host.size_bytes(), 1),
                     host.data(), &err);
        clCheck(err, "clCreateBuffer(CL_MEM_USE_HOST_PTR)");
        return DeviceBuffer<T>(std::move(b), host.size());
    }
    /// A buffer of `count` elements over a block of this context's pool, written before the buffer existed:
    /// on CPU devices kernels work in the block, which goes back to the pool when the buffer is released;
    /// other devices get a copy and the block goes back at once.
    template <class T>
    DeviceBuffer<T> adoptHost(HostBlock block, std::size_t count, cl_mem_flags flags = CL_MEM_READ_WRITE) {
        return DeviceBuffer<T>(
            bufferOver(std::move(block), flags, std::max<std::size_t>(count, 1) * sizeof(T)), count);
    }
    /// The pool host buffers are drawn from.
    const std::shared_ptr<HostMemoryPool>& hostMemory() const noexcept { return hostMemory_; }
    template <class T>
    DeviceBuffer<T> upload(std::span<const T> host, cl_mem_flags flags = CL_MEM_READ_WRITE) {
        DeviceBuffer<T> b = allocate<T>(host.size(), flags);
        write(b, host);
        return b;
    }
    template <class T>
    DeviceBuffer<T> upload(const std::vector<T>& host, cl_mem_flags flags = CL_MEM_READ_WRITE) {
        return upload(std::span<const T>(host), flags);
    }
    template <class T> void write(DeviceBuffer<T>& b, std::span<const T> host, std::size_t offset = 0) {
        if (host.empty()) return;
        if (offset + host.size() > b.size()) throw Error("internal: buffer write out of range");
        clCheck(
            queue_.enqueueWriteBuffer(b.get(), CL_TRUE, offset * sizeof(T), host.size_bytes(), host.data()),
            "clEnqueueWriteBuffer");
    }
    template <class T> void read(const DeviceBuffer<T>& b, std::span<T> host, std::size_t offset = 0) {
        if (host.empty()) return;
        if (offset + host.size() > b.size()) throw Error("internal: buffer read out of range");
        clCheck(
            queue_.enqueueReadBuffer(b.get(), CL_TRUE, offset * sizeof(T), host.size_bytes(), host.data()),
            "clEnqueueReadBuffer");
    }
    template <class T> std::vector<T> download(const DeviceBuffer<T>& b) {
        std::vector<T> out(b.size());
        read(b, std::span<T>(out));
        return out;
    }
    template <class T> void fill(DeviceBuffer<T>& b, const T& value) {
        if (b.size() == 0) return;
        clCheck(queue_.enqueueFillBuffer(b.get(), value, 0, b.bytes()), "clEnqueueFillBuffer");
    }

    /// Launches with an explicit local size; the global size is rounded up to a multiple of it, so kernels
    /// must bounds-check against the true size they receive as an argument. Returns the profiling event.
    cl::Event launch(cl::Kernel& k, cl::NDRange global, cl::NDRange local);
    /// Without a local size they take the profile's launch defaults.
    cl::Event launch1d(cl::Kernel& k, std::size_t n) { return launch1d(k, n, profile_->launch.local1d); }
    cl::Event launch1d(cl::Kernel& k, std::size_t n, std::size_t local);
    cl::Event launch2d(cl::Kernel& k, std::size_t nx, std::size_t ny) {
        return launch2d(k, nx, ny, profile_->launch.local2d);
    }
    cl::Event launch2d(cl::Kernel& k, std::size_t nx, std::size_t ny, std::size_t lx, std::size_t ly);
    cl::Event launch2d(cl::Kernel& k, std::size_t nx, std::size_t ny, LocalSize local) {
        return launch2d(k, nx, ny, local.x, local.y);
    }
    cl::Event launch3d(cl::Kernel& k, std::size_t nx, std::size_t ny, std::size_t nz) {
        return launch3d(k, nx, ny, nz, profile_->launch.local3d);
    }
    cl::Event launch3d(cl::Kernel& k, std::size_t nx, std::size_t ny, std::size_t nz, std::size_t lx,
                       std::size_t ly, std::size_t lz);
    cl::Event launch3d(cl::Kernel& k, std::size_t nx, std::size_t ny, std::size_t nz, LocalSize local) {
        return launch3d(k, nx, ny, nz, local.x, local.y, local.z);
    }
    void finish();

private:
    cl::Buffer createBuffer(cl_mem_flags flags, std::size_t bytes);
    cl::Buffer bufferOver(HostBlock block, cl_mem_flags flags, std::size_t bytes);

    DeviceInfo device_;
    const DeviceProfile* profile_ = nullptr; // an entry of the static profile table
    cl::Context context_;
    cl::CommandQueue queue_;
    std::unique_ptr<KernelSourceLibrary> sources_;
    std::map<std::tuple<std::uint64_t, std::string>, cl::Program> programs_; // (source hash, options)
    std::size_t programsFromDisk_ = 0;
    std::shared_ptr<HostMemoryPool> hostMemory_; // shared with buffers that outlive the context
};

/// Kernel time between CL_PROFILING_COMMAND_START and END, in milliseconds (waits for the event).
double eventMilliseconds(const cl::Event& e);

/// Rounds n up to a multiple of m (m > 0).
constexpr std::size_t roundUp(std::size_t n, std::size_t m) {
    return (n + m - 1) / m * m;
}

namespace detail {
template <class T> void setArg(cl::Kernel& k, cl_uint i, const DeviceBuffer<T>& b) {
    clCheck(k.setArg(i, b.get()), "clSetKernelArg");
}
template <class T> void setArg(cl::Kernel& k, cl_uint i, DeviceBuffer<T>& b) {
    clCheck(k.setArg(i, b.get()), "clSetKernelArg");
}
template <class T> void setArg(cl::Kernel& k, cl_uint i, const T& v) {
    clCheck(k.setArg(i, v), "clSetKernelArg");
}
} // namespace detail

/// Sets all kernel arguments in order; DeviceBuffer and plain values (cl_uint, float, structs) are accepted.
template <class... Args> void setArgs(cl::Kernel& k, const Args&... args) {
    cl_uint i = 0;
    (detail::setArg(k, i++, args), ...);
}

} // namespace volcl
