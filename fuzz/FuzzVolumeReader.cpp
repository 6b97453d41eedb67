// Fuzz target for one volume reader, chosen at build time by VOLCL_FUZZ_EXTENSION (".nrrd", ".mhd", ...).
// Formats whose header names a separate data file (VOLCL_FUZZ_SPLIT) take the input as header, a NUL byte,
// then the bytes of "data.raw" beside it; the seeds' headers name that file.
#include "core/Error.hpp"
#include "fuzz/FuzzSupport.hpp"
#include "host/io/VolumeIo.hpp"

#include <algorithm>
#include <cstdlib>
#include <string>
#include <string_view>

#ifndef VOLCL_FUZZ_SPLIT
#define VOLCL_FUZZ_SPLIT 0
#endif

// .vdb grids are decoded by readers that the OpenVDB reader service forks; they inherit the sanitizer's
// options. A forged grid size makes a reader's allocation fail at its address-space cap: with the default
// options the sanitizer then aborts it with a symbolized report (an llvm-symbolizer run, a quarter of the
// machine's time), while the product build throws std::bad_alloc there and replies "not enough memory".
// Readers started after this behave like the product build; the target itself keeps its options.
extern "C" int LLVMFuzzerInitialize(int*, char***) {
    if (std::string_view(VOLCL_FUZZ_EXTENSION) == ".vdb") {
        const char* current = std::getenv("ASAN_OPTIONS");
        const std::string options =
            std::string(current ? current : "") + ":allocator_may_return_null=1:symbolize=0";
        ::setenv("ASAN_OPTIONS", options.c_str(), 1);
    }
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace volcl;
    std::span<const std::uint8_t> header(data, size), payload;
    if (VOLCL_FUZZ_SPLIT) {
        const auto* nul = std::find(data, data + size, std::uint8_t{0});
        header = std::span<const std::uint8_t>(data, static_cast<std::size_t>(nul - data));
        if (nul != data + size) payload = std::span<const std::uint8_t>(nul + 1, data + size);
        fuzz::writeScratchFile("data.raw", payload);
    }
    const auto path = fuzz::writeScratchFile(std::string("input") + VOLCL_FUZZ_EXTENSION, header);
    ReadOptions options;
    options.memoryBudget = fuzz::kFuzzMemoryBudget;
    try {
        const TimeSeries series = readVolumeFile(path, options);
        // Touch every voxel: a reader that returned a short buffer shows up here under ASan.
        double sum = 0;
        for (const Volume& v : series.frames)
            for (std::size_t i = 0; i < v.voxelCount(); i += 1 + v.voxelCount() / 4096)
                sum += v.valueAt(i);
        (void)sum;
    } catch (const Error&) {
        // A refused input is the expected outcome; anything else (a crash, another exception) is a finding.
    }
    return 0;
}
