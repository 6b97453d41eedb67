// The payload stage: one brick's coded sections and optional corrections framed as its payload, and the
// validated parse of that frame.
#pragma once

#include "wavelet/container/VczFormat.hpp"
#include "wavelet/quantise/Corrections.hpp"

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace volcl::codec {

// Payload: u8 section count, u8 flags (bit 0: corrections), u32 size per section, u32 corrections size, data.
// `q` holds the brick's coefficients in rows of `pitch` elements (0: dense, pitch d.x).
std::vector<std::uint8_t> buildPayload(const VczHeader& h, Dims d, std::span<const std::int32_t> q,
                                       const std::vector<Correction>& corr, std::size_t pitch = 0);

/// A payload's parts (spans into it).
struct ParsedPayload {
    std::vector<std::span<const std::uint8_t>> sections;
    std::span<const std::uint8_t> corrections;
};
/// Splits a payload of `expectedSections` sections; IoError naming `what` on any inconsistency.
ParsedPayload parsePayload(std::span<const std::uint8_t> p, std::size_t expectedSections,
                           const std::string& what);

} // namespace volcl::codec
