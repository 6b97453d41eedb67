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

/// What coding one brick's voxels measured, kept so that a second choice on the same voxels (the lossless
/// file a lossy target is compared with) decides exactly as a fresh one would without coding them again.
struct VoxelBrickTrial {
    Dims origin, dims;                       ///< the brick measured (a different box starts afresh)
    bool checked = false, nonFinite = false; ///< voxels read; a float brick holds NaN or Inf
    std::vector<std::uint8_t> prefix;        ///< the payload's head (kind, palette)
    std::optional<std::vector<std::uint8_t>> cheap, thorough; ///< the zstd frames at the two levels
};
using VoxelBrickTrials = std::vector<VoxelBrickTrial>;

/// The voxels of the box (origin `o`, dims `d`) of `v` as a voxel-coded payload: u8 0 (a wavelet payload's
/// section count is never 0), u8 kind, the kind's data. Nullopt when it would not be smaller than `limit`
/// bytes (a cheap zstd pass decides before the thorough one runs), or when `finiteOnly` and the box holds a
/// NaN or Inf (a lossy file's coarse levels hold a smooth fill there, which an exact brick does not have).
/// With `memo`, what it holds of this box is reused and what is coded is kept there.
std::optional<std::vector<std::uint8_t>> encodeVoxelBrick(const Volume& v, Dims o, Dims d, std::size_t limit,
                                                          bool finiteOnly = false,
                                                          VoxelBrickTrial* memo = nullptr);

/// True when a payload of a file with VczHeader::voxelBricks holds voxels rather than sections.
bool isVoxelBrick(std::span<const std::uint8_t> payload) noexcept;

/// The voxels of a voxel-coded payload of a brick of dims `d`, dense (x fastest), as int32 (integer
/// values, float32 as bit patterns). IoError naming `what` on any inconsistency.
std::vector<std::int32_t> decodeVoxelBrick(std::span<const std::uint8_t> payload, ScalarType type, Dims d,
                                           const std::string& what);

/// The encoder's chooser: every brick of `frame` whose voxel coding is smaller than its wavelet payload in
/// `payloads` (index order) is replaced by it; a brick coded exactly satisfies every bound. Returns the
/// number of bricks replaced (the header then needs voxelBricks). With `memo` (one entry per brick, sized
/// here), the trials of an earlier call on the same voxels are reused and this call's are kept.
std::size_t codeSmallerBricksAsVoxels(const Volume& frame, const VczHeader& h,
                                      std::vector<std::vector<std::uint8_t>>& payloads, unsigned threads,
                                      VoxelBrickTrials* memo = nullptr);

} // namespace volcl::codec
