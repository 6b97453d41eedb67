// Fuzz target for ParaView collections (.pvd) read as a time series: the input is the .pvd, a NUL byte, then
// the bytes of "frame.nrrd" beside it, which the seeds' data sets name (one file may be named many times).
#include "core/Error.hpp"
#include "fuzz/FuzzSupport.hpp"
#include "host/io/Series.hpp"

#include <algorithm>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace volcl;
    const auto* nul = std::find(data, data + size, std::uint8_t{0});
    std::span<const std::uint8_t> frame;
    if (nul != data + size) frame = std::span<const std::uint8_t>(nul + 1, data + size);
    fuzz::writeScratchFile("frame.nrrd", frame);
    const auto path = fuzz::writeScratchFile("input.pvd", {data, static_cast<std::size_t>(nul - data)});
    ReadOptions options;
    options.memoryBudget = fuzz::kFuzzMemoryBudget;
    try {
        const std::vector<std::string> inputs{path.string()};
        const SeriesInput in = readSeriesInputs(inputs, options);
        double sum = 0;
        for (const Volume& v : in.series.frames)
            for (std::size_t i = 0; i < v.voxelCount(); i += 1 + v.voxelCount() / 4096)
                sum += v.valueAt(i);
        for (std::size_t f = 0; f < in.sources.size(); ++f)
            sum += static_cast<double>(in.sources[f].describe(f).size());
        (void)sum;
    } catch (const Error&) {
    }
    return 0;
}
