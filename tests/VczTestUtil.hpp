// Test helper for .vcz containers: a file written again by the current writer.
#pragma once

#include "wavelet/container/VczFormat.hpp"

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace volcl::test {

/// `raw` (a .vcz of any version, padded or not) written again by the current writer: the same header fields
/// and payload bytes, offsets implied, no padding.
inline std::vector<std::byte> rewrittenVcz(const std::vector<std::byte>& raw, const std::string& name) {
    const VczHeader h = readVczHeader(raw, name);
    const std::size_t oldStart = h.bricks[0][0].offset;
    VczHeader nh = h;
    const std::size_t newStart = vczPreambleSize(nh);
    for (auto& frame : nh.bricks)
        for (VczBrickEntry& e : frame)
            e.offset = e.offset - oldStart + newStart;
    for (VczFrame& fr : nh.frames)
        if (fr.auxSize) fr.auxOffset = fr.auxOffset - oldStart + newStart;
    std::vector<std::vector<std::uint8_t>> block(1);
    const auto* p = reinterpret_cast<const std::uint8_t*>(raw.data());
    block[0].assign(p + oldStart, p + raw.size());
    return writeVcz(nh, block);
}

} // namespace volcl::test
