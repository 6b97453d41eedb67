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
};

/// Fills h.bricks from the frames (their payloads are moved out) and writes the file.
std::vector<std::byte> assembleVcz(VczHeader& h, std::vector<CodedFrame>& frames);

} // namespace volcl::codec
