// Fuzz target for .vcz files through the public reader: header and index parsing, then decoding whole,
// a region, a coarser level and single bricks (both entropy coders, every transform, per the seeds).
#include "fuzz/FuzzSupport.hpp"
#include "host/Error.hpp"
#include "host/runtime/ClRuntime.hpp"
#include "wavelet/Codec.hpp"
#include "wavelet/VczFormat.hpp"

#include <algorithm>
#include <memory>

namespace {

volcl::ComputeContext& computeContext() {
    static const std::unique_ptr<volcl::ComputeContext> cc = std::make_unique<volcl::ComputeContext>();
    return *cc;
}

} // namespace

// Creates the OpenCL context before fuzzing (the first decode still builds its kernels).
extern "C" int LLVMFuzzerInitialize(int*, char***) {
    (void)computeContext();
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace volcl;
    const auto* first = reinterpret_cast<const std::byte*>(data);
    std::vector<std::byte> bytes(first, first + size);
    try {
        // The harness's own budget: a forged size must be refused here, not exhaust the fuzzing machine.
        (void)readVczHeader(bytes, "fuzz.vcz", fuzz::kFuzzMemoryBudget);
        const VczReader reader(std::move(bytes), "fuzz.vcz");
        const VczHeader& h = reader.header();
        ComputeContext& cc = computeContext();
        DecodeOptions whole;
        whole.threads = 1;
        (void)reader.decode(cc, whole);
        if (h.dims.x > 1 && h.dims.y > 1 && h.dims.z > 1) {
            DecodeOptions region = whole;
            region.region = Region{{h.dims.x / 2, 0, h.dims.z / 2}, {h.dims.x, h.dims.y / 2 + 1, h.dims.z}};
            (void)reader.decode(cc, region);
        }
        if (h.levels > 0) {
            DecodeOptions coarse = whole;
            coarse.level = 1;
            (void)reader.decode(cc, coarse);
        }
        const std::size_t bricks = h.brickCount();
        for (std::size_t b = 0; b < std::min<std::size_t>(bricks, 2); ++b)
            (void)reader.decodeBrick(cc, h.frames.size() - 1, bricks - 1 - b, 0);
    } catch (const Error&) {
        // Refused as corrupt (IoError), unsupported (DataError) or out of range (UsageError): expected.
    }
    return 0;
}
