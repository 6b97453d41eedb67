// Public enums of the codec API and the .vcz header.
#pragma once

#include <cstdint>

namespace volcl {

/// How coefficient sections are entropy coded. Stored in .vcz files: never renumber.
enum class EntropyMode : std::uint8_t {
    Fast = 0,  ///< sign-folded coefficients split into byte planes, then zstd
    Dense = 1, ///< rANS: magnitude classes from per-section tables chosen by neighbour/parent context,
               ///< adaptive signs and row flags, raw mantissa bits
};

} // namespace volcl
