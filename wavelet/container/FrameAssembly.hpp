// The container stage's assembly: coded frames (brick payloads and ranges) into the brick index and the
// .vcz bytes.
#pragma once

#include "wavelet/container/VczFormat.hpp"

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace volcl::codec {

/// One frame's brick payloads and voxel ranges, in brick order.
struct CodedFrame {
    std::vector<std::vector<std::uint8_t>> payloads;
    std::vector<std::pair<double, double>> ranges;
    std::vector<std::uint8_t> aux; ///< the frame's auxiliary block (motion data of P/B frames)
};

/// Fills h.bricks and the frames' auxiliary block entries from the frames (their payloads are moved out)
/// and writes the file; a frame's auxiliary block follows its bricks.
std::vector<std::byte> assembleVcz(VczHeader& h, std::vector<CodedFrame>& frames);

} // namespace volcl::codec
