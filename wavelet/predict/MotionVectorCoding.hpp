// Compact motion-field serialisation: modes, median-predicted vector differences and intra values, zstd-coded.
#pragma once

#include "wavelet/predict/MotionField.hpp"

#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

namespace volcl {

/// The predictor of block b's vector: the component-wise median of its left (x - 1), upper (y - 1) and
/// front (z - 1) neighbours' vectors; a neighbour outside the grid counts as the zero vector.
MotionVector medianPredictor(const std::vector<MotionVector>& vectors, Dims blocks, std::size_t b) noexcept;

/// The field as it round-trips: vectors a block's mode does not use are set to zero and intra values
/// of non-intra blocks to 0 (they are not stored).
MotionField canonicalMotionField(const MotionField& field);

/// Bytes of a motion field: a one-byte layout tag, the section length (varint), then one zstd frame of planes:
/// modes, the differences (vector - median predictor, zigzag, one byte per component) of the vectors
/// in use, and the intra blocks' float32 values split into byte planes. Mostly-zero fields cost a few
/// bytes. Throws DataError for a field whose vectors exceed +-63 half voxels.
std::vector<std::uint8_t> encodeMotionField(const MotionField& field);

/// Inverse of encodeMotionField for a field on `grid`; truncated or corrupted bytes throw IoError
/// naming `what`. Returns canonicalMotionField of what was encoded.
MotionField decodeMotionField(std::span<const std::uint8_t> bytes, BlockGrid grid, std::string_view what);

} // namespace volcl
