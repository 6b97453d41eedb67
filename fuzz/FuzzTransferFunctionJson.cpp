// Fuzz target for transfer-function JSON (canonical and ParaView): parse, validate, pack, round-trip.
#include "core/Error.hpp"
#include "host/tf/TransferFunction.hpp"

#include <cstddef>
#include <cstdint>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace volcl;
    try {
        const TransferFunction tf =
            TransferFunction::fromJson(std::string_view(reinterpret_cast<const char*>(data), size));
        (void)tf.packKnots();
        (void)TransferFunction::fromJson(tf.toJson()); // what it writes, it reads back
    } catch (const Error&) {
    }
    return 0;
}
