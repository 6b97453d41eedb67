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

// Payload: u8 section count, u8 flags (bit 0: corrections, bit 1: some sections set-partitioned), with bit 1
// one byte per 8 sections marking them (bit s of byte s / 8 for section s; wavelet/entropy/SpeckModel.hpp),
// u32 size per section, u32 corrections size, data. Each dense-mode section is coded by whichever of the
// dense and set-partitioning coders gives fewer bytes; payloads without a set-partitioned section are the
// same bytes as before bit 1 existed. `q` holds the brick's coefficients in rows of `pitch` elements (0: dense, pitch d.x).
std::vector<std::uint8_t> buildPayload(const VczHeader& h, Dims d, std::span<const std::int32_t> q,
                                       const std::vector<Correction>& corr, std::size_t pitch = 0);

/// A payload's parts (spans into it).
struct ParsedPayload {
    std::vector<std::span<const std::uint8_t>> sections;
    std::span<const std::uint8_t> corrections;
    std::uint32_t setPartitioned = 0; ///< bit s: section s coded by set partitioning
};
/// Splits a payload of `expectedSections` sections; IoError naming `what` on any inconsistency.
ParsedPayload parsePayload(std::span<const std::uint8_t> p, std::size_t expectedSections,
                           const std::string& what);

} // namespace volcl::codec
