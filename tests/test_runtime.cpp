// OpenCL runtime: discovery, selection, program cache, defines, build-log errors, buffers, launches.
#include "TestUtil.hpp"
#include "core/runtime/ClRuntime.hpp"
#include "core/runtime/KernelSources.hpp"
#include "core/runtime/ProgramBinaryCache.hpp"
#include "core/runtime/Timing.hpp"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <numeric>
#include <optional>

#ifdef __linux__
#include <sched.h>
#include <unistd.h>
#endif

using namespace volcl;

TEST(Runtime, ListsAtLeastOneDevice) {
    auto devices = listDevices();
    ASSERT_FALSE(devices.empty()) << "PoCL (pocl-opencl-icd) must provide a CPU device";
    for (std::size_t i = 0; i < devices.size(); ++i) {
        EXPECT_EQ(devices[i].index, i);
        EXPECT_FALSE(devices[i].name.empty());
        EXPECT_GT(devices[i].computeUnits, 0u);
        EXPECT_GT(devices[i].maxAllocBytes, 0u);
    }
}

TEST(Runtime, AsksPoclToPinItsWorkersWhenEveryCpuIsAvailable) {
#ifdef __linux__
    listDevices();
    cpu_set_t set;
    CPU_ZERO(&set);
    ASSERT_EQ(sched_getaffinity(0, sizeof set, &set), 0);
    const long online = sysconf(_SC_NPROCESSORS_ONLN);
    bool everyCpu = online > 1;
    for (long i = 0; i < online && everyCpu; ++i)
        everyCpu = CPU_ISSET(i, &set);
    // Set before PoCL started its threads (by us, or by the user, whose value is kept).
    if (everyCpu) EXPECT_NE(std::getenv("POCL_AFFINITY"), nullptr);
#else
    GTEST_SKIP() << "PoCL worker pinning is Linux-only";
#endif
}

TEST(Runtime, SelectsDeviceByIndexAndName) {
    auto devices = listDevices();
    ASSERT_FALSE(devices.empty());
    ComputeContext byIndex("0");
    EXPECT_EQ(byIndex.device().name, devices[0].name);
    std::string part = devices[0].platform.substr(0, 3);
    ComputeContext byName(part);
    EXPECT_FALSE(byName.device().name.empty());
    EXPECT_THROW(ComputeContext("99"), UsageError);
    EXPECT_THROW(ComputeContext("no-such-device-xyz"), UsageError);
}

TEST(Runtime, CopyKernelRoundTripsDataWithOddSizes) {
    ComputeContext& cc = test::computeContext();
    for (std::size_t n : {1u, 63u, 64u, 65u, 1000u}) {
        std::vector<float> host(n);
        std::iota(host.begin(), host.end(), -3.5f);
        auto src = cc.upload(host);
        auto dst = cc.allocate<float>(n);
        cl::Kernel k = cc.kernel("common/copy.cl", "copy_float");
        setArgs(k, src, dst, cl_uint(n));
        cc.launch1d(k, n, 64);
        EXPECT_EQ(cc.download(dst), host) << "n = " << n;
    }
}

TEST(Runtime, ProgramCacheKeysOnSourceAndOptions) {
    ComputeContext cc;
    cc.kernel("common/copy.cl", "copy_float");
    cc.kernel("common/copy.cl", "copy_float16");
    EXPECT_EQ(cc.cachedProgramCount(), 1u) << "same file, same options: one program";
    cc.kernel("common/copy.cl", "copy_float", KernelDefines().set("UNUSED_FLAG", 1));
    EXPECT_EQ(cc.cachedProgramCount(), 2u) << "different defines: a second program";
    cc.kernel("common/copy.cl", "copy_float", KernelDefines().set("UNUSED_FLAG", 1));
    EXPECT_EQ(cc.cachedProgramCount(), 2u);
}

namespace {

// Sets an environment variable for the life of a test and restores it afterwards.
class ScopedEnv {
public:
    ScopedEnv(const char* name, const std::string& value) : name_(name) {
        if (const char* old = std::getenv(name)) old_ = old;
        setenv(name, value.c_str(), 1);
    }
    ~ScopedEnv() {
        if (old_)
            setenv(name_, old_->c_str(), 1);
        else
            unsetenv(name_);
    }

private:
    const char* name_;
    std::optional<std::string> old_;
};

// Runs copy_float through a fresh context and checks the result (a program from the disk cache must work).
std::size_t copyThroughFreshContext() {
    ComputeContext cc;
    std::vector<float> host(100);
    std::iota(host.begin(), host.end(), 0.25f);
    auto src = cc.upload(host);
    auto dst = cc.allocate<float>(host.size());
    cl::Kernel k = cc.kernel("common/copy.cl", "copy_float");
    setArgs(k, src, dst, cl_uint(host.size()));
    cc.launch1d(k, host.size(), 64);
    EXPECT_EQ(cc.download(dst), host);
    return cc.programsFromDiskCache();
}

} // namespace

TEST(Runtime, ProgramBinariesAreCachedOnDiskAndDamagedEntriesRebuilt) {
    const auto dir = test::tempDir("runtime_binary_cache");
    ScopedEnv env("VOLCL_CACHE_DIR", dir.string());
    EXPECT_EQ(copyThroughFreshContext(), 0u) << "first build: from source";
    const ComputeContext probe;
    const ProgramBinaryCache entry(probe.device(), "", probe.sources().resolve("common/copy.cl"));
    ASSERT_TRUE(entry.file());
    ASSERT_TRUE(std::filesystem::exists(*entry.file())) << entry.file()->string();
    ASSERT_TRUE(entry.load());
    EXPECT_EQ(copyThroughFreshContext(), 1u) << "second context: from the disk cache";
    // Other options or source are other entries.
    EXPECT_FALSE(
        ProgramBinaryCache(probe.device(), "-DX=1", probe.sources().resolve("common/copy.cl")).load());
    EXPECT_FALSE(
        ProgramBinaryCache(probe.device(), "", probe.sources().resolve("common/copy.cl") + " ").load());

    // A flipped byte anywhere (key, checksum or binary) or a truncation makes the entry unusable: the
    // program is rebuilt from source and the entry replaced.
    const std::uintmax_t size = std::filesystem::file_size(*entry.file());
    for (std::uintmax_t at : {std::uintmax_t(3), std::uintmax_t(20), size / 2, size - 1}) {
        {
            std::fstream f(*entry.file(), std::ios::in | std::ios::out | std::ios::binary);
            f.seekg(std::streamoff(at));
            const char c = char(f.get());
            f.seekp(std::streamoff(at));
            f.put(char(c ^ 0x41));
        }
        EXPECT_FALSE(entry.load()) << "byte " << at;
        EXPECT_EQ(copyThroughFreshContext(), 0u) << "byte " << at;
        EXPECT_TRUE(entry.load()) << "rewritten after byte " << at;
    }
    std::filesystem::resize_file(*entry.file(), size - 7);
    EXPECT_FALSE(entry.load());
    EXPECT_EQ(copyThroughFreshContext(), 0u);
    EXPECT_EQ(copyThroughFreshContext(), 1u);
}

TEST(Runtime, ProgramBinaryCacheCanBeOffOrUnwritable) {
    {
        ScopedEnv env("VOLCL_CACHE_DIR", "off");
        EXPECT_FALSE(ProgramBinaryCache::directory());
        EXPECT_EQ(copyThroughFreshContext(), 0u);
        EXPECT_EQ(copyThroughFreshContext(), 0u);
    }
    // A cache "directory" that is a file: nothing can be stored, kernels still build and run.
    const auto dir = test::tempDir("runtime_binary_cache_file");
    std::ofstream(dir / "not-a-dir") << "x";
    ScopedEnv env("VOLCL_CACHE_DIR", (dir / "not-a-dir").string());
    EXPECT_EQ(copyThroughFreshContext(), 0u);
    EXPECT_EQ(copyThroughFreshContext(), 0u);
}

TEST(Runtime, DefinesSpecialiseKernels) {
    auto dir = test::tempDir("runtime_defines");
    std::ofstream(dir / "scale.cl") << "#include \"helper.h\"\n"
                                       "__kernel void scale(__global float* a) { a[get_global_id(0)] = "
                                       "HELPER(a[get_global_id(0)]) * FACTOR; }\n";
    std::ofstream(dir / "helper.h") << "#define HELPER(x) ((x) + OFFSET)\n";
    setenv("VOLCL_KERNEL_DIR", dir.c_str(), 1);
    ComputeContext cc;
    unsetenv("VOLCL_KERNEL_DIR");
    std::vector<float> v{1.0f, 2.0f, 3.0f, 4.0f};
    auto buf = cc.upload(v);
    cl::Kernel k = cc.kernel("scale.cl", "scale", KernelDefines().set("FACTOR", 2.5).set("OFFSET", 1));
    setArgs(k, buf);
    cc.launch(k, cl::NDRange(4), cl::NDRange(4));
    EXPECT_EQ(cc.download(buf), (std::vector<float>{5.0f, 7.5f, 10.0f, 12.5f}));
}

TEST(Runtime, BrokenKernelReportsBuildLog) {
    auto dir = test::tempDir("runtime_broken");
    std::ofstream(dir / "broken.cl")
        << "__kernel void broken(__global float* a) { a[0] = undefined_symbol_xyz; }\n";
    setenv("VOLCL_KERNEL_DIR", dir.c_str(), 1);
    ComputeContext cc;
    unsetenv("VOLCL_KERNEL_DIR");
    try {
        cc.kernel("broken.cl", "broken");
        FAIL() << "a broken kernel must not build";
    } catch (const ClError& e) {
        EXPECT_EQ(e.code(), CL_BUILD_PROGRAM_FAILURE);
        EXPECT_NE(e.buildLog().find("undefined_symbol_xyz"), std::string::npos) << e.buildLog();
        EXPECT_NE(std::string(e.what()).find("broken.cl"), std::string::npos) << e.what();
    }
}

TEST(Runtime, MissingKernelFileAndNameAreClearErrors) {
    ComputeContext& cc = test::computeContext();
    EXPECT_THROW(cc.kernel("no_such_file.cl", "x"), Error);
    try {
        cc.kernel("common/copy.cl", "no_such_kernel");
        FAIL();
    } catch (const ClError& e) {
        EXPECT_NE(std::string(e.what()).find("no_such_kernel"), std::string::npos);
    }
}

TEST(Runtime, IncludesExpandOnceWithLineMarkers) {
    KernelSourceLibrary lib;
    std::string src = lib.resolve("phantoms/phantoms.cl");
    EXPECT_NE(src.find("typedef struct VolclEllipsoid"), std::string::npos);
    EXPECT_EQ(src.find("#include \""), std::string::npos) << "quoted includes are expanded";
    EXPECT_NE(src.find("#line 1 \"volcl_shared.h\""), std::string::npos);
}

TEST(Runtime, KernelDefinesAreSortedAndRefuseNonFinite) {
    KernelDefines a, b;
    a.set("B", 2).set("A", 1);
    b.set("A", 1).set("B", 2);
    EXPECT_EQ(a.toOptions(), b.toOptions());
    EXPECT_EQ(a.toOptions(), "-DA=1 -DB=2");
    EXPECT_THROW(KernelDefines().set("X", std::nan("")), UsageError);
    EXPECT_THROW(KernelDefines().set("X", INFINITY), UsageError);
}

TEST(Runtime, EventTimingIsPositiveAndBandwidthMeasurable) {
    ComputeContext& cc = test::computeContext();
    double gbs = copyKernelBandwidthGBs(cc, 1 << 20, 3);
    EXPECT_GT(gbs, 0.0);
    EXPECT_TRUE(std::isfinite(gbs));
}

// Host-allocated buffers of 2 MiB and more come from a pool on CPU devices: memory handed back by a released
// buffer is handed out again. Reused memory must carry what the new owner writes (no stale data visible to a
// kernel), and buffers may outlive their context (the pool lives on with them).
TEST(Runtime, PooledHostBuffersAreReusedAndOutliveTheirContext) {
    ComputeContext& cc = test::computeContext();
    for (std::size_t n :
         {std::size_t(600'000), std::size_t(524'288), std::size_t(600'000), std::size_t(3'000'001)})
        for (int round = 0; round < 3; ++round) {
            std::vector<float> host(n);
            std::iota(host.begin(), host.end(), float(round) - 7.0f);
            auto src = cc.allocate<float>(n, CL_MEM_READ_WRITE | CL_MEM_ALLOC_HOST_PTR);
            auto dst = cc.allocate<float>(n, CL_MEM_READ_WRITE | CL_MEM_ALLOC_HOST_PTR);
            cc.write(src, std::span<const float>(host));
            cl::Kernel k = cc.kernel("common/copy.cl", "copy_float");
            setArgs(k, src, dst, cl_uint(n));
            cc.launch1d(k, n, 64);
            ASSERT_EQ(cc.download(dst), host) << "n = " << n << ", round " << round;
        }
    DeviceBuffer<float> survivor;
    {
        ComputeContext local;
        survivor = local.allocate<float>(1 << 20, CL_MEM_READ_WRITE | CL_MEM_ALLOC_HOST_PTR);
    }
    EXPECT_EQ(survivor.size(), std::size_t(1) << 20);
}

TEST(Runtime, OversizedBufferIsRefused) {
    ComputeContext& cc = test::computeContext();
    EXPECT_THROW(cc.allocate<float>(cc.device().maxAllocBytes), DataError);
}

TEST(Runtime, DeviceProfileIsChosenByDeviceKind) {
    // The CPU entry and the generic one differ only in the CPU/GPU choices; the context keeps its device's.
    DeviceInfo cpu, gpu;
    cpu.isCpu = true;
    gpu.isGpu = true;
    const DeviceProfile &onCpu = deviceProfileFor(cpu), &onGpu = deviceProfileFor(gpu);
    EXPECT_EQ(onCpu.entry, "cpu");
    EXPECT_EQ(onGpu.entry, "any");
    EXPECT_EQ(&onGpu, &genericDeviceProfile());
    EXPECT_TRUE(onCpu.hostBuffersInPlace && onCpu.lifting.brickResident);
    EXPECT_FALSE(onGpu.hostBuffersInPlace || onGpu.lifting.brickResident);
    EXPECT_EQ(onCpu.mesh.tileThreads, 1u);
    EXPECT_EQ(onGpu.mesh.tileThreads, 16u);
    EXPECT_EQ(onCpu.launch.local1d, onGpu.launch.local1d);
    EXPECT_EQ(onCpu.rayMarch.macrocellEdge, onGpu.rayMarch.macrocellEdge);
    ComputeContext& cc = test::computeContext();
    EXPECT_EQ(&cc.profile(), &deviceProfileFor(cc.device()));
}

TEST(Timing, MedianOfOddAndEvenCounts) {
    EXPECT_EQ(median({3, 1, 2}), 2.0);
    EXPECT_EQ(median({4, 1, 3, 2}), 2.5);
    EXPECT_EQ(median({}), 0.0);
}
