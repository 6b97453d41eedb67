// The fast entropy coder: sign-folded coefficients split into byte planes, zero blocks skipped, then zstd.
#pragma once

#include "wavelet/entropy/EntropyCoder.hpp"

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace volcl::entropy {

// Calls fn(row, len, box) for each row of the section's subbands (x fastest, in coding order).
template <class T, class Fn>
void forEachSectionRow(T* c, const std::vector<SubbandBox>& sec, Dims brick, Fn fn) {
    for (const SubbandBox& b : sec)
        for (std::size_t z = b.z0; z < b.z1; ++z)
            for (std::size_t y = b.y0; y < b.y1; ++y)
                fn(c + (z * brick.y + y) * brick.x + b.x0, b.x1 - b.x0, b);
}

/// Appends the fast-coded section with subbands `sec` of `c` (rows of brick.x elements) to `out`.
void encodeFast(std::span<const std::int32_t> c, const std::vector<SubbandBox>& sec, Dims brick,
                std::vector<std::uint8_t>& out);
/// Decodes a fast-coded section into `c`; with `dq` straight to dequantised values (float bit patterns).
void decodeFast(std::span<const std::uint8_t> in, std::span<std::int32_t> c,
                const std::vector<SubbandBox>& sec, Dims brick, const char* what, const Dequantiser* dq);

} // namespace volcl::entropy
