// Fuzz target for RGBA-strip transfer functions read from an image (PNG or EXR, per VOLCL_FUZZ_EXTENSION).
#include "core/Error.hpp"
#include "fuzz/FuzzSupport.hpp"
#include "host/tf/TransferFunction.hpp"

#include <string>

// Loads the image module once before fuzzing, so its start-up cost is not charged to the first input.
extern "C" int LLVMFuzzerInitialize(int*, char***) {
    const std::uint8_t junk[] = {'x'};
    try {
        (void)volcl::TransferFunction::fromFile(
            volcl::fuzz::writeScratchFile(std::string("warmup") + VOLCL_FUZZ_EXTENSION, junk), {0.0, 1.0});
    } catch (const volcl::Error&) {
    }
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace volcl;
    const auto path = fuzz::writeScratchFile(std::string("strip") + VOLCL_FUZZ_EXTENSION, {data, size});
    try {
        const TransferFunction tf = TransferFunction::fromFile(path, {0.0, 1.0});
        (void)tf.packKnots();
    } catch (const Error&) {
    }
    return 0;
}
