// The .vcz container: header, frame table (I/P/B), brick index with per-brick checksums and statistics.
#pragma once

#include "core/Volume.hpp"
#include "wavelet/CodecTypes.hpp"

#include <array>
#include <cstddef>
#include <cstdint>
#include <map>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace volcl {

// The NIfTI metadata keys of a .vcz (kVczNiftiMetadataKey, kVczNiftiValuesKey) are in
// host/io/NiftiMetadata.hpp with the code that reads them.

/// What the bricks hold. Stored in .vcz files: never renumber.
enum class TransformKind : std::uint8_t {
    RawBits = 0,        ///< no transform: the voxels' bit patterns (lossless float32)
    IntegerLifting = 1, ///< reversible integer lifting of integer voxels (lossless)
    FloatLifting = 2,   ///< float lifting + dead-zone quantisation (lossy)
};

/// Frame types of a time series: I (coded alone), P (motion-compensated from reference0 plus a coded
/// residual), B (compensated from reference0 and reference1, an earlier and a later I/P frame, plus a
/// residual). P and B frames are read from version 4 files and later.
enum class FrameType : std::uint8_t { I = 0, P = 1, B = 2 };

struct VczFrame {
    FrameType type = FrameType::I;
    std::int32_t reference0 = -1, reference1 = -1; ///< frames a P/B frame predicts from (-1: none)
    double time = 0;
    /// Auxiliary per-frame block (motion vectors for P/B frames): offset, size, XXH3-64 checksum.
    std::uint64_t auxOffset = 0, auxSize = 0, auxChecksum = 0;
};

/// Index entry of one brick of one frame.
struct VczBrickEntry {
    /// Payload position in the file and its XXH3-64 (versions 5 and 6 keep its low 32 bits).
    std::uint64_t offset = 0, size = 0, checksum = 0;
    double min = 0, max = 0; ///< voxel range of the brick (TF-independent stats)
};

/// Everything before the brick payloads.
struct VczHeader {
    Dims dims;
    ScalarType type = ScalarType::UInt8;
    std::array<double, 3> spacing{1, 1, 1}, origin{0, 0, 0};
    TransformKind transform = TransformKind::IntegerLifting;
    Wavelet wavelet = Wavelet::Cdf53;
    int levels = 0;
    Dims brick{64, 64, 64};
    EntropyMode entropy = EntropyMode::Dense;
    RateMode rate = RateMode::Lossless;
    double rateTarget = 0;           ///< E, PSNR in dB or bits/voxel, as asked
    double reconstructionBias = 0.5; ///< dequantised magnitude = (|q| + bias) * step
    std::vector<double> steps;       ///< per subband: index 0 the low band, then 7 per level (1..L)
    double valueMin = 0, valueMax = 0;
    std::vector<VczFrame> frames;
    std::map<std::string, std::string> metadata;
    std::vector<std::vector<VczBrickEntry>> bricks; ///< [frame][brick]
    /// Format version of the file this header was read from (0: built in memory). Versions 5 and 6 store
    /// 32-bit payload checksums; the others 64-bit ones.
    std::uint32_t version = 0;
    /// Some bricks may be coded as voxels (a payload whose first byte, the section count, is 0: palette or
    /// raw voxels, lossless; wavelet/payload/VoxelBrick.hpp). Written as version 7, read from version 7 only.
    bool voxelBricks = false;
    /// The voxels are float64 (version 8): the bricks (and `type`, Float32) hold their float32 layer, which
    /// renderers and coarse levels read; each frame's auxiliary block holds the float64 layer that gives the
    /// voxels back (wavelet/Float64Layer.hpp). Voxel-coded bricks may occur, as in version 7.
    bool float64 = false;
    /// The type of the voxels VczReader::decode gives: Float64 for a float64 file, else `type`.
    ScalarType voxelType() const noexcept { return float64 ? ScalarType::Float64 : type; }

    /// Bricks per axis and in total.
    Dims brickGrid() const noexcept;
    std::size_t brickCount() const noexcept { return brickGrid().count(); }
    /// Origin (voxel index) and size of brick `i` (x fastest over the brick grid).
    Dims brickOrigin(std::size_t i) const noexcept;
    Dims brickDims(std::size_t i) const noexcept;
    /// Quantisation step of subband (level, orient); level 0 is the low band.
    double step(int level, int orient) const;
};

/// Magic bytes at the start of every .vcz file.
inline constexpr std::array<unsigned char, 8> kVczMagic{0x89, 'V', 'C', 'Z', '\r', '\n', 0x1a, '\n'};
/// Version of single volumes written before version 6. 3: fast-mode sections may skip zero blocks (flag 0x80
/// beside the plane count); version 2 files, whose sections never set it, are read too.
inline constexpr std::uint32_t kVczVersion = 3;
/// Version of files holding P or B frames written before version 5: the frame table's references and
/// auxiliary blocks (motion data) in the fixed-width layout of version 3.
inline constexpr std::uint32_t kVczVersionPredicted = 4;
/// Version of series written before version 6: a compact frame table and brick index (varints, offsets
/// implied by the payload order, 32-bit payload checksums, metadata zstd-compressed) whose size grows by a
/// few bytes per brick instead of 40. Files of one frame were never written as version 5.
inline constexpr std::uint32_t kVczVersionSeries = 5;
/// Version written for every file, one frame or many: the layout of version 5 with the header's sizes as
/// varints and the quantisation steps implied by one delta (docs/codec.md, "Version 6"). A single volume's
/// header and index are then proportional to what it holds: hydrogen at 40 dB, 8 bricks, 1.3 KB less.
/// Versions 2-5 are still read.
inline constexpr std::uint32_t kVczVersionCompact = 6;
/// Version 6's layout in a file where some bricks are coded as voxels (VczHeader::voxelBricks): written only
/// then, so every other file stays version 6, byte for byte.
inline constexpr std::uint32_t kVczVersionVoxelBricks = 7;
/// Version 7's layout in a file of float64 voxels (VczHeader::float64): every frame an I frame whose auxiliary
/// block is the float64 layer. Written only then.
inline constexpr std::uint32_t kVczVersionFloat64 = 8;

/// Serialises the header and index (brick offsets must be final) followed by the payloads, which must
/// lie in `payloads` in index order starting right after the index, each frame's auxiliary block right after
/// its bricks (offsets are implied by the order).
/// `preambleSize` (0: as small as it can be) pads the preamble to that size, for a writer that reserved it
/// with vczPreambleBound before the payloads were known (offsets then start there).
std::vector<std::byte> writeVcz(const VczHeader& header, std::span<const std::vector<std::uint8_t>> payloads,
                                std::size_t preambleSize = 0);
/// Size in bytes of the header + index block for this header (payload offsets start there).
std::size_t vczPreambleSize(const VczHeader& header);
/// At least the preamble size of this header, with its quantisation steps, whatever its payload and motion
/// block sizes (below 32 GB), brick ranges and metadata values of the same sizes turn out to be: what a writer
/// reserves before coding (rate trials, streaming), then fills with writeVcz(..., preambleSize). `sizesKnown`:
/// the header's index entries hold their final payload sizes and its metadata is final (a rate trial of a
/// single volume): only the brick ranges are bounded, by the voxel type's.
std::size_t vczPreambleBound(const VczHeader& header, bool sizesKnown = false);

/// What a reader of the header will hold, and so what its size claims are checked against the memory budget
/// for: `Frame`, a whole decoded frame (with one brick's coefficients while decoding); `Bricks`, one brick at a
/// time (its coefficients) and the index, as the brick renderer and `info` hold: a file whose decoded frame is
/// larger than memory opens, and VczReader::decode checks the frame or region it is asked for instead.
enum class VczHeaderUse { Frame, Bricks };

/// Parses and validates magic, version, header checksum, index checksum, that every brick lies inside
/// the file and that nothing follows the last one, and that the header's fields are a combination an
/// encoder writes. What `use` holds (a frame, or a brick and the index) larger than `memoryBudget` bytes
/// (0 = defaultMemoryBudget()) is refused as a forged size. Throws IoError naming `name` on any
/// inconsistency; never reads out of bounds.
VczHeader readVczHeader(std::span<const std::byte> file, const std::string& name,
                        std::size_t memoryBudget = 0, VczHeaderUse use = VczHeaderUse::Frame);

/// Throws IoError naming `name` when decoding `dims` voxels of the header's type, with one brick's coefficients
/// and corrections beside them, exceeds `memoryBudget` (0 = the default); `what` names the voxels.
void checkVczDecodeBudget(const VczHeader& header, Dims dims, std::size_t memoryBudget,
                          const std::string& name, const std::string& what);

/// Payload of one brick after checking its checksum (IoError naming the brick on mismatch).
std::span<const std::uint8_t> vczBrickPayload(std::span<const std::byte> file, const VczHeader& header,
                                              std::size_t frame, std::size_t brick, const std::string& name);

/// The auxiliary block of a frame (motion data of P/B frames; empty for I frames) after checking its
/// checksum (IoError naming the frame on mismatch).
std::span<const std::uint8_t> vczFrameAux(std::span<const std::byte> file, const VczHeader& header,
                                          std::size_t frame, const std::string& name);

/// XXH3-64 of a byte range.
std::uint64_t vczChecksum(std::span<const std::uint8_t> bytes) noexcept;

} // namespace volcl
