// Bricks coded as their voxels, losslessly (a palette of the brick's values and zstd over the indices, or
// zstd over the raw voxels' byte planes), and the encoder's per-brick choice between that and the
// wavelet payload by size.
#pragma once

#include "core/Volume.hpp"
#include "wavelet/container/VczFormat.hpp"

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace volcl::codec {

/// Kinds of voxel-coded bricks (stored in .vcz files: never renumber).
enum class VoxelBrickKind : std::uint8_t {
    Palette = 1, ///< varint K, K values, one zstd frame of indices (u8 when K <= 256, else u16)
    Raw = 2,     ///< one zstd frame of the voxels' byte planes (low bytes first)
};

/// The voxels of the box (origin `o`, dims `d`) of `v` as a voxel-coded payload: u8 0 (a wavelet payload's
/// section count is never 0), u8 kind, the kind's data. Nullopt when it would not be smaller than `limit`
/// bytes (a cheap zstd pass decides before the thorough one runs), or when `finiteOnly` and the box holds a
/// NaN or Inf (a lossy file's coarse levels hold a smooth fill there, which an exact brick does not have).
std::optional<std::vector<std::uint8_t>> encodeVoxelBrick(const Volume& v, Dims o, Dims d, std::size_t limit,
                                                          bool finiteOnly = false);

/// True when a payload of a file with VczHeader::voxelBricks holds voxels rather than sections.
bool isVoxelBrick(std::span<const std::uint8_t> payload) noexcept;

/// The voxels of a voxel-coded payload of a brick of dims `d`, dense (x fastest), as int32 (integer
/// values, float32 as bit patterns). IoError naming `what` on any inconsistency.
std::vector<std::int32_t> decodeVoxelBrick(std::span<const std::uint8_t> payload, ScalarType type, Dims d,
                                           const std::string& what);

/// The encoder's chooser: every brick of `frame` whose voxel coding is smaller than its wavelet payload in
/// `payloads` (index order) is replaced by it; a brick coded exactly satisfies every bound. Returns the
/// number of bricks replaced (the header then needs voxelBricks).
std::size_t codeSmallerBricksAsVoxels(const Volume& frame, const VczHeader& h,
                                      std::vector<std::vector<std::uint8_t>>& payloads, unsigned threads);

} // namespace volcl::codec
