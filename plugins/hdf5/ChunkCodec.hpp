// HDF5 chunks <-> volcl-compressed bytes: the filter's parameters (cd_values) and the stored chunk format.
#pragma once

#include "core/Volume.hpp"
#include "core/runtime/ClRuntime.hpp"

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace volcl::hdf5 {

/// How a chunk is compressed; the value is cd_values[0].
enum class ChunkRate : unsigned {
    Lossless = 0,
    MaxError = 1,
    Psnr = 2,
    Bpv = 3,
    RelError = 4,
    PwRelError = 5
};

/// Everything the filter needs to encode or decode one chunk. A user gives only rate and bound
/// (cd_values[0..2]); the set_local callback adds the element type and the chunk shape.
struct FilterParameters {
    ChunkRate rate = ChunkRate::Lossless;
    double bound = 0; ///< MaxError: largest absolute error in data units; Psnr: dB; Bpv: bits per voxel;
                      ///< RelError, PwRelError: R
    ScalarType type = ScalarType::UInt8;
    unsigned rank = 3;                  ///< 3 (z, y, x) or 4 (t, z, y, x)
    std::array<std::size_t, 4> chunk{}; ///< chunk dims, slowest first as HDF5 lists them (rank used)

    /// Voxels of one 3D frame of the chunk: Dims{x, y, z} with x the fastest (last HDF5) dimension.
    Dims frameDims() const noexcept;
    /// 3D frames in a chunk: 1 for rank 3, chunk[0] for rank 4.
    std::size_t frameCount() const noexcept;
    std::size_t chunkBytes() const noexcept;
};

/// Version of the full cd_values layout written by set_local (cd_values[3]).
inline constexpr unsigned kFilterParameterVersion = 1;
/// Largest number of cd_values the filter writes: rate, bound (2 words), version, type, rank, 4 dims.
inline constexpr std::size_t kMaxFilterValues = 10;

/// The user's part of cd_values: none or {0} is lossless; {1|2, low word, high word} carries the bound as a
/// little-endian double. Throws UsageError for an unknown rate, a missing bound, or a bound that is not a
/// finite positive number.
void parseUserValues(std::span<const unsigned> values, ChunkRate& rate, double& bound);
/// cd_values[0..2] for a rate and bound (the C and Python helpers write the same words).
std::array<unsigned, 3> userValues(ChunkRate rate, double bound);

/// The full cd_values list written by set_local.
std::vector<unsigned> packParameters(const FilterParameters& p);
/// Reads the full list back. Throws DataError when it is short, of another version, or inconsistent.
FilterParameters unpackParameters(std::span<const unsigned> values);

/// Compresses one chunk of p.chunkBytes() bytes (little-endian voxels of p.type). Lossy modes hold on the
/// real voxels of a padded edge chunk, whichever they are (PSNR over their own value range): each frame is
/// coded over the box outside which it repeats its last voxel, restored exactly on decode. Throws
/// UsageError / DataError from the codec (NaN in a lossy float chunk, for example).
std::vector<std::byte> encodeChunk(ComputeContext& cc, const FilterParameters& p,
                                   std::span<const std::byte> chunk);
/// Decompresses stored bytes into `chunk` (p.chunkBytes() bytes). Throws IoError/DataError when the stored
/// bytes are truncated, corrupted (checksums) or describe another chunk shape or type; `chunk` is then
/// left in an unspecified state.
void decodeChunk(ComputeContext& cc, const FilterParameters& p, std::span<const std::byte> stored,
                 std::span<std::byte> chunk);

} // namespace volcl::hdf5
