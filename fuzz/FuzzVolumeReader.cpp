// Fuzz target for one volume reader, chosen at build time by VOLCL_FUZZ_EXTENSION (".nrrd", ".mhd", ...).
// Formats whose header names a separate data file (VOLCL_FUZZ_SPLIT) take the input as header, a NUL byte,
// then the bytes of "data.raw" beside it; the seeds' headers name that file.
#include "fuzz/FuzzSupport.hpp"
#include "host/Error.hpp"
#include "host/io/VolumeIo.hpp"

#include <algorithm>

#ifndef VOLCL_FUZZ_SPLIT
#define VOLCL_FUZZ_SPLIT 0
#endif

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
