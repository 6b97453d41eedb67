// Streaming lossless encoder: a volume produced one brick row at a time is coded into a .vcz without ever
// holding more than one row of bricks, so the memory used does not grow with the volume.
#pragma once

#include "core/Volume.hpp"
#include "core/runtime/ClRuntime.hpp"
#include "wavelet/Codec.hpp"

#include <array>
#include <cstddef>
#include <functional>
#include <ostream>
#include <string>

namespace volcl {

/// A volume known by its grid and a function that fills any box of it: `fill(lo, out)` writes the voxels
/// [lo, lo + out.dims()) into `out` (already sized and typed). Readers of raw files and generators both fit.
struct VolumeSource {
    Dims dims;
    ScalarType type = ScalarType::UInt8;
    std::array<double, 3> spacing{1.0, 1.0, 1.0};
    std::array<double, 3> origin{0.0, 0.0, 0.0};
    Direction3 direction = kIdentityDirection; ///< stored as encodeVolume stores a volume's
    bool anatomical = false;
    std::function<void(Dims lo, Volume& out)> fill;
};

/// What a streaming encode did.
struct StreamEncodeReport {
    std::size_t bytes = 0;    ///< file size
    std::size_t rows = 0;     ///< brick rows coded
    std::size_t rowBytes = 0; ///< decoded size of the largest row held at once
};

/// Codes `source` losslessly (integer voxels, reversible lifting) one brick row (brick.y x brick.z voxels
/// across the whole x extent) at a time and writes the .vcz to `out`, which must be able to seek back to its
/// start: payloads are written as they are coded, the header and index (whose size is known in advance)
/// last, over the room left for them.
/// With `lodStatistics` the per-brick, per-level statistics are measured row by row too. The file equals,
/// byte for byte, encodeVolume followed by addLodStatistics on the whole volume (tests compare them).
/// Throws UsageError for options the stream cannot code (lossy rates, float voxels: their rate control
/// and value range need the whole volume), IoError naming `name` when writing fails.
StreamEncodeReport encodeStreaming(ComputeContext& cc, const VolumeSource& source,
                                   const CodecOptions& options, bool lodStatistics, std::ostream& out,
                                   const std::string& name);

} // namespace volcl
