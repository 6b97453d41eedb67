// The device profile table: one entry per kind of device (and vendor/name where a value was tuned for one).
#include "core/runtime/DeviceProfile.hpp"

#include "core/runtime/ClRuntime.hpp"

#include <array>

namespace volcl {
namespace {

// What every device ran before the profile, and what devices of no particular kind (GPUs, accelerators)
// still run. The CPU entry below changes only the CPU/GPU choices.
constexpr DeviceProfile kGeneric{
    .entry = "any",
    .launch = {.local1d = 64, .local2d = {16, 1}, .local3d = {16, 1, 1}},
    .hostBuffersInPlace = false, // other devices get their own memory with a host block's contents
    .copyLocal = 16,
    .phantom = {16, 1, 1},
    .lifting =
        {
            // One fixed local size: PoCL specialises a kernel per local size, so varying it costs a build
            // each time.
            .x = {1, 8, 1},
            .yz = {16, 1, 1},
            .copy = {16, 1, 1},
            // One work-item per brick keeps the brick in one core's cache; on GPUs that is far too little
            // parallelism.
            .brickResident = false,
            // lift_bricks declares reqd_work_group_size(1, 1, 1).
            .brickLocal = 1,
            // A few work-items per core, each pulling bricks from the counter (see lift_bricks).
            .brickItemsPerComputeUnit = 4,
        },
    .motion = {.search = 64, .reduce = 64, .costs = 16, .rows = {16, 1, 1}, .voxels = {32, 8, 2}},
    .preintegration =
        {
            // Work-group width along the back index: PoCL pays a fixed cost per work-group, so groups are
            // made wide, but never wider than the table row (rounded up to a multiple of 16).
            .rowMax = 64,
            .rowMultiple = 16,
            .exactRow = 16,
        },
    .rayMarch =
        {
            // Tiles of nearby rays share cache lines in y as well as x: 8x8 rays, or 4x4 packets of 4x2 rays.
            .tile = {8, 8},
            .packet = {4, 4},
            .pathTrace = {8, 8},
            .macrocellEdge = 8, // 8^3 cells keep the grid small and tight
            // A 96x96 probe costs 1/28 of a 512^2 frame; 5 rounds of off + 3 edges keep the choice below two
            // full frames. Coarser cells cost fewer cell visits per ray and skip less.
            .skipProbePixels = 96 * 96,
            .skipProbeRounds = 5,
            .skipEdgeFactors = {2, 4, 0},
            // BrainWeb's 32^3 level-0 bricks decode in about 7 ms each (docs/multires.md): 16 cost about a
            // tenth of that scene's 512^2 kernel, so the first frame of a view never waits long.
            .refineBricksPerFrame = 16,
            // Decode and kernel share the CPU device's cores: a refining frame takes at most about twice a
            // still frame's kernel time.
            .refineKernelShare = 1.0,
        },
    .preview =
        {
            // A scanline's cost varies with what it crosses: small groups let PoCL's threads share the work.
            .scanlines = 4,
            .warp = {16, 4},
            .drc = {8, 8},
        },
    .mesh =
        {
            // 4 x 2, 4 x 4 and 8 x 2 pixels per work-item measured the same as 2 x 2 on the blunt fin.
            .cellRaysX = 2,
            .cellRaysY = 2,
            .cells = {8, 8},
            .kbuffer = 64,
            .binChunks = 64,
            .binLocal = 1,
            .tileThreads = 16, // one work-item per tile row on GPUs
            .radixBlocks = 128,
            .radixLocal = 1,
        },
};

constexpr DeviceProfile cpuProfile() {
    DeviceProfile p = kGeneric;
    p.entry = "cpu";
    p.hostBuffersInPlace = true; // kernels work in pooled host memory (see ComputeContext::adoptHost)
    p.lifting.brickResident = true;
    p.mesh.tileThreads = 1; // CPUs run one work-item per tile
    return p;
}

enum class DeviceKind { Any, Cpu, Gpu };

/// Where an entry applies: a kind of device and, for values tuned on one, substrings of its vendor and
/// name (empty: any), as CLBlast's database keys its tuning.
struct ProfileEntry {
    DeviceKind kind;
    std::string_view vendor, name;
    DeviceProfile profile;
};

// First match wins; the last entry matches every device.
constexpr std::array kProfiles{
    ProfileEntry{DeviceKind::Cpu, {}, {}, cpuProfile()},
    ProfileEntry{DeviceKind::Any, {}, {}, kGeneric},
};

bool matches(const ProfileEntry& e, const DeviceInfo& d) {
    const bool kind = e.kind == DeviceKind::Any || (e.kind == DeviceKind::Cpu && d.isCpu) ||
                      (e.kind == DeviceKind::Gpu && d.isGpu);
    return kind && d.vendor.find(e.vendor) != std::string::npos && d.name.find(e.name) != std::string::npos;
}

} // namespace

const DeviceProfile& deviceProfileFor(const DeviceInfo& device) {
    for (const ProfileEntry& e : kProfiles)
        if (matches(e, device)) return e.profile;
    return kProfiles.back().profile;
}

const DeviceProfile& genericDeviceProfile() {
    return kProfiles.back().profile;
}

} // namespace volcl
