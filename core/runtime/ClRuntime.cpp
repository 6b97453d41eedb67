// OpenCL runtime implementation: discovery, device selection, program cache and launches.
#include "core/runtime/ClRuntime.hpp"

#include "core/ZeroedBytes.hpp"
#include "core/runtime/HostMemoryPool.hpp"
#include "core/runtime/KernelSources.hpp"
#include "core/runtime/ProgramBinaryCache.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <mutex>
#include <sstream>

#ifdef __linux__
#include <sched.h>
#include <unistd.h>
#endif

namespace volcl {

namespace {

// Asks PoCL's CPU driver to pin its worker thread i to CPU i (POCL_AFFINITY=1), before PoCL starts them; a
// value the user set wins. Why: unpinned, the workers of a 2-core machine where another process keeps one
// core busy settle on the same core as each other for the life of the process (2 + 1 is as balanced as 3
// threads on 2 cores get, and the scheduler keeps it), so a kernel gets one core in some processes and
// one and a half in others: the codec's transform stage took its whole CPU time as wall time (BrainWeb
// 9/7 inverse: wall = CPU = 6.6-9.8 ms in 5 of 5 processes), pinned 0.63-0.87 of it (bench/inverse_speed.cpp).
// Skipped unless the process may run on CPUs 0 .. n-1, all of them online (not under taskset or a cgroup
// cpuset that excludes some): PoCL pins by thread index.
void pinCpuWorkers() {
#ifdef __linux__
    static std::once_flag once;
    std::call_once(once, [] {
        cpu_set_t set;
        CPU_ZERO(&set);
        const long online = sysconf(_SC_NPROCESSORS_ONLN);
        if (online < 2 || online > CPU_SETSIZE || sched_getaffinity(0, sizeof set, &set) != 0) return;
        for (long i = 0; i < online; ++i)
            if (!CPU_ISSET(i, &set)) return;
        setenv("POCL_AFFINITY", "1", 0);
    });
#endif
}

} // namespace

namespace {

// A buffer's destructor callback gives its block back to the pool.
void CL_CALLBACK returnHostMemory(cl_mem, void* lease) {
    std::unique_ptr<HostBlock> block(static_cast<HostBlock*>(lease));
}

std::string lower(std::string_view s) {
    std::string out(s);
    std::transform(out.begin(), out.end(), out.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    return out;
}

template <class T> T deviceInfo(const cl::Device& d, cl_device_info what) {
    T value{};
    clCheck(d.getInfo(what, &value), "clGetDeviceInfo");
    return value;
}

std::string trimmed(std::string s) {
    while (!s.empty() && (s.back() == '\0' || std::isspace(static_cast<unsigned char>(s.back()))))
        s.pop_back();
    return s;
}

} // namespace

bool DeviceInfo::hasExtension(std::string_view ext) const {
    std::istringstream in(extensions);
    std::string word;
    while (in >> word)
        if (word == ext) return true;
    return false;
}

std::vector<DeviceInfo> listDevices() {
    pinCpuWorkers(); // before the ICD loads PoCL
    std::vector<cl::Platform> platforms;
    cl_int err = cl::Platform::get(&platforms);
    // No ICD at all reports CL_PLATFORM_NOT_FOUND_KHR: that is "no devices", not an error.
    if (err == -1001 || platforms.empty()) return {};
    clCheck(err, "clGetPlatformIDs");
    std::vector<DeviceInfo> out;
    for (const cl::Platform& p : platforms) {
        std::vector<cl::Device> devices;
        if (p.getDevices(CL_DEVICE_TYPE_ALL, &devices) != CL_SUCCESS) continue;
        std::string platformName;
        p.getInfo(CL_PLATFORM_NAME, &platformName);
        for (const cl::Device& d : devices) {
            DeviceInfo info;
            info.index = out.size();
            info.platform = trimmed(platformName);
            info.name = trimmed(deviceInfo<std::string>(d, CL_DEVICE_NAME));
            info.vendor = trimmed(deviceInfo<std::string>(d, CL_DEVICE_VENDOR));
            info.version = trimmed(deviceInfo<std::string>(d, CL_DEVICE_VERSION));
            info.driver = trimmed(deviceInfo<std::string>(d, CL_DRIVER_VERSION));
            auto type = deviceInfo<cl_device_type>(d, CL_DEVICE_TYPE);
            // A device that reports several types (Oclgrind reports CPU, GPU and accelerator) is taken as a
            // GPU: it gets the device profile's generic entry and its own buffers, not the CPU's in-place ones.
            info.isGpu = (type & CL_DEVICE_TYPE_GPU) != 0;
            info.isCpu = (type & CL_DEVICE_TYPE_CPU) != 0 && !info.isGpu;
            info.computeUnits = deviceInfo<cl_uint>(d, CL_DEVICE_MAX_COMPUTE_UNITS);
            info.globalMemBytes = deviceInfo<cl_ulong>(d, CL_DEVICE_GLOBAL_MEM_SIZE);
            info.maxAllocBytes = deviceInfo<cl_ulong>(d, CL_DEVICE_MAX_MEM_ALLOC_SIZE);
            info.localMemBytes = deviceInfo<cl_ulong>(d, CL_DEVICE_LOCAL_MEM_SIZE);
            info.maxWorkGroupSize = deviceInfo<std::size_t>(d, CL_DEVICE_MAX_WORK_GROUP_SIZE);
            info.extensions = trimmed(deviceInfo<std::string>(d, CL_DEVICE_EXTENSIONS));
            info.fp64 = info.hasExtension("cl_khr_fp64");
            info.device = d;
            out.push_back(std::move(info));
        }
    }
    return out;
}

KernelDefines& KernelDefines::setText(std::string name, std::string value) {
    values_[std::move(name)] = std::move(value);
    return *this;
}

KernelDefines& KernelDefines::set(std::string name, double value) {
    // Hex float literals would be exact, but OpenCL C accepts them only as double; use round-trip decimal.
    if (!std::isfinite(value)) throw UsageError("kernel define " + name + " must be finite");
    char buf[64];
    auto [end, ec] = std::to_chars(buf, buf + sizeof buf, static_cast<float>(value));
    (void)ec;
    std::string text(buf, end);
    if (text.find_first_of(".eEn") == std::string::npos) text += ".0";
    values_[std::move(name)] = "(" + text + "f)";
    return *this;
}

KernelDefines& KernelDefines::set(std::string name) {
    values_[std::move(name)] = "";
    return *this;
}

KernelDefines& KernelDefines::erase(const std::string& name) {
    values_.erase(name);
    return *this;
}

std::string KernelDefines::toOptions() const {
    std::string out;
    for (const auto& [name, value] : values_) {
        if (!out.empty()) out += ' ';
        out += "-D" + name;
        if (!value.empty()) out += "=" + value;
    }
    return out;
}

ComputeContext::ComputeContext(std::string_view selector)
    : ComputeContext(selector, std::span<const cl_context_properties>{}) {}

ComputeContext::ComputeContext(std::string_view selector, std::shared_ptr<HostMemoryPool> hostMemory)
    : ComputeContext(selector, std::span<const cl_context_properties>{}, std::move(hostMemory)) {}

ComputeContext::ComputeContext(std::string_view selector,
                               std::span<const cl_context_properties> extraProperties,
                               std::shared_ptr<HostMemoryPool> hostMemory)
    : hostMemory_(hostMemory ? std::move(hostMemory) : std::make_shared<HostMemoryPool>()) {
    std::string sel(selector);
    if (sel.empty())
        if (const char* env = std::getenv("VOLCL_DEVICE")) sel = env;
    std::vector<DeviceInfo> devices = listDevices();
    if (devices.empty()) throw Error("no OpenCL device found (is an ICD such as pocl-opencl-icd installed?)");
    const DeviceInfo* chosen = nullptr;
    if (sel.empty()) {
        chosen = &devices.front();
    } else {
        std::size_t index = 0;
        auto [ptr, ec] = std::from_chars(sel.data(), sel.data() + sel.size(), index);
        if (ec == std::errc() && ptr == sel.data() + sel.size()) {
            if (index >= devices.size())
                throw UsageError("device index " + sel + " out of range (" + std::to_string(devices.size()) +
                                 " devices; see volcl devices)");
            chosen = &devices[index];
        } else {
            std::string needle = lower(sel);
            for (const DeviceInfo& d : devices)
                if (lower(d.name).find(needle) != std::string::npos ||
                    lower(d.platform).find(needle) != std::string::npos) {
                    chosen = &d;
                    break;
                }
            if (!chosen) throw UsageError("no OpenCL device matches '" + sel + "' (see volcl devices)");
        }
    }
    device_ = *chosen;
    profile_ = &deviceProfileFor(device_);
    cl_int err = CL_SUCCESS;
    std::vector<cl_context_properties> props;
    if (!extraProperties.empty()) {
        props.push_back(CL_CONTEXT_PLATFORM);
        props.push_back(
            reinterpret_cast<cl_context_properties>(device_.device.getInfo<CL_DEVICE_PLATFORM>()));
        props.insert(props.end(), extraProperties.begin(), extraProperties.end());
        props.push_back(0);
    }
    context_ = cl::Context(device_.device, props.empty() ? nullptr : props.data(), nullptr, nullptr, &err);
    clCheck(err, "clCreateContext");
    queue_ = cl::CommandQueue(context_, device_.device, CL_QUEUE_PROFILING_ENABLE, &err);
    clCheck(err, "clCreateCommandQueue");
    sources_ = std::make_unique<KernelSourceLibrary>(KernelSourceLibrary::fromEnvironment());
}

ComputeContext::~ComputeContext() {
    // Destructors never throw: a failed finish at teardown is not reportable anyway.
    if (queue_()) queue_.finish();
}

cl::Program ComputeContext::program(std::string_view file, const KernelDefines& defines,
                                    std::string_view extraOptions) {
    std::string source = sources_->resolve(file);
    std::string options = defines.toOptions();
    if (!extraOptions.empty())
        options.append(" ").append(extraOptions); // (" " + string) trips GCC 12's -Wrestrict
    auto key = std::make_tuple(fnv1a64(source), options);
    if (auto it = programs_.find(key); it != programs_.end()) return it->second;

    // Program binaries cached on disk, keyed on the device, driver, options and source: PoCL preprocesses the
    // whole source with clang on every clBuildProgram from source just to find its own cache entry, which was
    // ~30 % of a one-shot `volcl decode`.
    ProgramBinaryCache disk(device_, options, source);
    // "-w": the OpenCL compiler's warnings (PoCL prints "N warnings generated." straight to stderr) are
    // not for users; a failed build still reports its log in the ClError below.
    const std::string buildOptions = options.empty() ? std::string("-w") : options + " -w";
    if (std::optional<std::vector<unsigned char>> binary = disk.load()) {
        cl_int err = CL_SUCCESS;
        cl_int binaryStatus = CL_SUCCESS;
        const unsigned char* data = binary->data();
        const std::size_t size = binary->size();
        cl_device_id id = device_.device();
        cl_program raw = clCreateProgramWithBinary(context_(), 1, &id, &size, &data, &binaryStatus, &err);
        if (err == CL_SUCCESS && binaryStatus == CL_SUCCESS) {
            cl::Program prog(raw); // takes ownership
            if (prog.build(std::vector<cl::Device>{device_.device}, buildOptions.c_str()) == CL_SUCCESS) {
                ++programsFromDisk_;
                programs_.emplace(key, prog);
                return prog;
            }
        } else if (raw) {
            clReleaseProgram(raw);
        }
        // An unusable entry (another driver build, damage) is rebuilt from source and replaced below.
    }

    cl_int err = CL_SUCCESS;
    cl::Program prog(context_, source, false, &err);
    clCheck(err, "clCreateProgramWithSource");
    err = prog.build(std::vector<cl::Device>{device_.device}, buildOptions.c_str());
    if (err != CL_SUCCESS) {
        std::string log;
        prog.getBuildInfo(device_.device, CL_PROGRAM_BUILD_LOG, &log);
        throw ClError("clBuildProgram(" + std::string(file) + (options.empty() ? "" : " " + options) + ")",
                      err, trimmed(log));
    }
    disk.store(prog);
    programs_.emplace(key, prog);
    return prog;
}

cl::Kernel ComputeContext::kernel(std::string_view file, std::string_view name, const KernelDefines& defines,
                                  std::string_view extraOptions) {
    cl::Program prog = program(file, defines, extraOptions);
    cl_int err = CL_SUCCESS;
    cl::Kernel k(prog, std::string(name).c_str(), &err);
    if (err != CL_SUCCESS)
        throw ClError("clCreateKernel(" + std::string(name) + " in " + std::string(file) + ")", err);
    return k;
}

cl::Buffer ComputeContext::createBuffer(cl_mem_flags flags, std::size_t bytes) {
    if (bytes > device_.maxAllocBytes)
        throw DataError("buffer of " + std::to_string(bytes) +
                        " bytes exceeds the device's maximum allocation (" +
                        std::to_string(device_.maxAllocBytes) + " bytes)");
    cl_int err = CL_SUCCESS;
    if (profile_->hostBuffersInPlace && (flags & CL_MEM_ALLOC_HOST_PTR) && bytes >= kHugePageBytes) {
        // Host-allocated buffers on CPU devices use pooled memory of our own (see HostMemoryPool), handed
        // back when the runtime releases the buffer.
        HostBlock block;
        try {
            block = HostBlock(hostMemory_, bytes);
        } catch (const std::bad_alloc&) {
        }
        if (block.data())
            return bufferOver(std::move(block), (flags & ~cl_mem_flags(CL_MEM_ALLOC_HOST_PTR)), bytes);
    }
    cl::Buffer b(context_, flags, bytes, nullptr, &err);
    clCheck(err, "clCreateBuffer");
    return b;
}

cl::Buffer ComputeContext::bufferOver(HostBlock block, cl_mem_flags flags, std::size_t bytes) {
    if (bytes > block.size()) throw Error("internal: buffer larger than its host block");
    if (bytes > device_.maxAllocBytes)
        throw DataError("buffer of " + std::to_string(bytes) +
                        " bytes exceeds the device's maximum allocation (" +
                        std::to_string(device_.maxAllocBytes) + " bytes)");
    cl_int err = CL_SUCCESS;
    if (!profile_->hostBuffersInPlace) {
        // Other devices get their own memory with the block's contents; the block goes back now.
        cl::Buffer b(context_, flags | CL_MEM_COPY_HOST_PTR, bytes, block.data(), &err);
        clCheck(err, "clCreateBuffer");
        return b;
    }
    cl::Buffer b(context_, flags | CL_MEM_USE_HOST_PTR, bytes, block.data(), &err);
    clCheck(err, "clCreateBuffer");
    auto lease = std::make_unique<HostBlock>(std::move(block));
    err = clSetMemObjectDestructorCallback(b(), returnHostMemory, lease.get());
    if (err != CL_SUCCESS) {
        b = cl::Buffer(); // released before its memory goes back (with the lease, below)
        clCheck(err, "clSetMemObjectDestructorCallback");
    }
    lease.release(); // owned by the callback now
    return b;
}

cl::Event ComputeContext::launch(cl::Kernel& k, cl::NDRange global, cl::NDRange local) {
    cl::Event ev;
    clCheck(queue_.enqueueNDRangeKernel(k, cl::NullRange, global, local, nullptr, &ev),
            "clEnqueueNDRangeKernel");
    return ev;
}

cl::Event ComputeContext::launch1d(cl::Kernel& k, std::size_t n, std::size_t local) {
    return launch(k, cl::NDRange(roundUp(std::max<std::size_t>(n, 1), local)), cl::NDRange(local));
}

cl::Event ComputeContext::launch2d(cl::Kernel& k, std::size_t nx, std::size_t ny, std::size_t lx,
                                   std::size_t ly) {
    return launch(
        k, cl::NDRange(roundUp(std::max<std::size_t>(nx, 1), lx), roundUp(std::max<std::size_t>(ny, 1), ly)),
        cl::NDRange(lx, ly));
}

cl::Event ComputeContext::launch3d(cl::Kernel& k, std::size_t nx, std::size_t ny, std::size_t nz,
                                   std::size_t lx, std::size_t ly, std::size_t lz) {
    return launch(k,
                  cl::NDRange(roundUp(std::max<std::size_t>(nx, 1), lx),
                              roundUp(std::max<std::size_t>(ny, 1), ly),
                              roundUp(std::max<std::size_t>(nz, 1), lz)),
                  cl::NDRange(lx, ly, lz));
}

void ComputeContext::finish() {
    clCheck(queue_.finish(), "clFinish");
}

double eventMilliseconds(const cl::Event& e) {
    clCheck(e.wait(), "clWaitForEvents");
    cl_ulong start = 0, end = 0;
    clCheck(e.getProfilingInfo(CL_PROFILING_COMMAND_START, &start), "clGetEventProfilingInfo");
    clCheck(e.getProfilingInfo(CL_PROFILING_COMMAND_END, &end), "clGetEventProfilingInfo");
    return static_cast<double>(end - start) * 1e-6;
}

} // namespace volcl
