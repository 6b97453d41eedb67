// The decoder's stages for one frame: payloads parsed and entropy decoded (dequantised on the way) on host
// threads, inverse transformed on the device down to a level, and placed into the output region with the
// corrections applied.
#pragma once

#include "core/Volume.hpp"
#include "core/runtime/ClRuntime.hpp"
#include "wavelet/CodecTypes.hpp"
#include "wavelet/DecodeAhead.hpp"
#include "wavelet/container/VczFormat.hpp"
#include "wavelet/quantise/Corrections.hpp"

#include <cstddef>
#include <span>
#include <string>
#include <vector>

namespace volcl::codec {

/// The host stage of decoding brick `b` of frame `frame`: its checksum, payload framing and entropy decoding
/// of the sections down to `level` into `dst` (rows of `pitch` >= brick x elements; float lifting comes out
/// dequantised, as float bit patterns). Returns the brick's exactly stored voxels at level 0 (else none).
/// IoError naming `name` and the brick for corrupted payloads. The frame and brick must exist.
std::vector<Correction> entropyDecodeBrick(std::span<const std::byte> file, const VczHeader& h,
                                           std::size_t frame, std::size_t b, int level, std::int32_t* dst,
                                           std::size_t pitch, const std::string& name);

/// The listed bricks of frame `frame` that go through the inverse transform: all but those of lossless integer
/// data whose index entry says every voxel holds one value (filled, not decoded) and voxel-coded ones
/// (decoded on the host).
std::vector<std::size_t> varyingBricks(std::span<const std::byte> file, const VczHeader& h, std::size_t frame,
                                       const std::vector<std::size_t>& which);

/// True when brick `b` of frame `frame` is voxel-coded (wavelet/payload/VoxelBrick.hpp): a file with
/// VczHeader::voxelBricks whose payload starts with a section count of 0. Reads that byte only.
bool voxelCodedBrick(std::span<const std::byte> file, const VczHeader& h, std::size_t frame, std::size_t b);

/// Decodes the listed bricks of frame `frame` at `level` into `out` (zeroed, of `outDims`), which holds the
/// level-`level` samples [a, e); `placeOnDevice` lets the inverse kernel write whole bricks' voxels itself.
/// The frame must exist. IoError naming `name` and the brick for corrupted payloads. With
/// `deferredCorrections` the exactly stored voxels are handed back per brick instead of applied (a P/B
/// frame's residual, decoded into Float32, gets them after its prediction is added). `ahead` hands over
/// the bricks it decoded when it matches (see DecodeAhead).
void decodeFrameBricks(ComputeContext& cc, std::span<const std::byte> file, const VczHeader& h,
                       std::size_t frame, const std::vector<std::size_t>& which, int level, unsigned threads,
                       const std::string& name, CodecProfile* prof, Dims a, Dims e, Volume& out, Dims outDims,
                       bool placeOnDevice,
                       std::vector<std::vector<Correction>>* deferredCorrections = nullptr,
                       DecodeAhead* ahead = nullptr);

} // namespace volcl::codec
