// Fuzz target for the host side of .vcz decoding, without OpenCL: header and index parsing, each frame's
// motion block, and every brick's payload framing, entropy decoding (both coders) and corrections, at full
// resolution and at the coarsest level, or its voxel coding (palette or raw). About 13 times the executions per CPU second of fuzz_vcz, which runs
// the same stages and then the inverse-transform kernels.
#include "core/Error.hpp"
#include "fuzz/FuzzSupport.hpp"
#include "wavelet/FrameDecoder.hpp"
#include "wavelet/container/VczFormat.hpp"
#include "wavelet/payload/VoxelBrick.hpp"

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace volcl;
    const std::span<const std::byte> file(reinterpret_cast<const std::byte*>(data), size);
    try {
        const VczHeader h = readVczHeader(file, "fuzz.vcz", fuzz::kFuzzMemoryBudget);
        std::vector<std::int32_t> coefficients;
        for (std::size_t f = 0; f < h.frames.size(); ++f) {
            (void)vczFrameAux(file, h, f, "fuzz.vcz");
            for (std::size_t b = 0; b < h.brickCount(); ++b) {
                const Dims d = h.brickDims(b);
                if (codec::voxelCodedBrick(file, h, f, b)) {
                    (void)codec::decodeVoxelBrick(vczBrickPayload(file, h, f, b, "fuzz.vcz"), h.type, d,
                                                  "fuzz.vcz");
                    continue;
                }
                coefficients.assign(d.count(), 0);
                (void)codec::entropyDecodeBrick(file, h, f, b, 0, coefficients.data(), d.x, "fuzz.vcz");
                if (h.levels > 0)
                    (void)codec::entropyDecodeBrick(file, h, f, b, h.levels, coefficients.data(), d.x,
                                                    "fuzz.vcz");
            }
        }
    } catch (const Error&) {
        // Refused as corrupt (IoError) or unsupported (DataError): expected.
    }
    return 0;
}
