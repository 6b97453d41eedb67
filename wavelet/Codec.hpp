// Wavelet volume codec: encode/decode in memory, region and level decoding, brick access for renderers.
#pragma once

#include "core/Volume.hpp"
#include "core/runtime/ClRuntime.hpp"
#include "wavelet/CodecTypes.hpp"
#include "wavelet/DecodeAhead.hpp"
#include "wavelet/Metrics.hpp"
#include "wavelet/container/VczFormat.hpp"
#include "wavelet/predict/MotionSearch.hpp"
#include "wavelet/transform/LiftingTransform.hpp" // callers use BrickBatch and the references with it

#include <cstddef>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace volcl {

class MappedFile; // core/MappedFile.hpp: internal, held by pointer

/// Encoder settings. Example (lossy, every voxel within 0.5 of the input):
/// ```
/// volcl::CodecOptions o;
/// o.rate = volcl::RateMode::MaxError;
/// o.target = 0.5;
/// std::vector<std::byte> vcz = volcl::encodeVolume(cc, volume, o);
/// ```
struct CodecOptions {
    RateMode rate = RateMode::Lossless;
    double target = 0; ///< MaxError: E in data units; Psnr: dB; Bpv: bits per voxel; RelError, PwRelError: R
    /// Default: cdf53 for lossless, cdf97 for lossy.
    std::optional<Wavelet> wavelet;
    int levels = 4;
    Dims brick{64, 64, 64}; ///< each axis a multiple of 2^levels
    /// With the default brick and levels: single volumes up to 16 M voxels are also coded with 128-voxel
    /// bricks and the smaller file is kept (not for --bpv or a fixed step). False keeps `brick` as given.
    bool chooseExtent = true;
    EntropyMode entropy = EntropyMode::Dense;
    /// Lossy only: use this base quantiser step instead of searching one for the target (the search
    /// encodes several trials; benchmarks time a fixed-step encode separately).
    std::optional<double> step;
    unsigned threads = 2; ///< host threads for entropy coding
    /// --psnr / --bpv with a fixed `step`: reconstruct to report PSNR and max error. False skips that
    /// pass (the report's error fields are then NaN); --max-error always reconstructs to hold its bound.
    bool measureError = true;
    std::map<std::string, std::string> metadata;
    /// Series only: P/B frames predicted by block motion compensation, or every frame an I frame. Lossless
    /// float32 series (kept as raw bit patterns) are always I frames.
    MotionMode motion = MotionMode::Block;
    std::size_t gop = 10;    ///< frames per group, each starting with an I frame (1: I frames only)
    std::size_t bFrames = 0; ///< B frames between two I/P frames
    MotionSearchOptions motionSearch{.blockSize = 8, .radius = 4, .method = MotionSearchMethod::Hierarchical};
    /// P frames may predict from the reference moved by a global sub-voxel translation (Keys cubic) where
    /// that is estimated to be smaller; false keeps block motion alone (files any earlier decoder reads).
    bool globalShift = true;
};

/// What an encoding measured about itself (for benchmarks and `volcl encode` reports).
struct EncodeReport {
    std::size_t bytes = 0;
    double bitsPerVoxel = 0;
    double psnr = 0;             ///< against the input's value range; +inf when exact
    double maxError = 0;         ///< over every voxel
    std::size_t corrections = 0; ///< voxels stored exactly: --max-error outliers and NaN/Inf voxels
    double transformMs = 0;      ///< kernel time of the final forward transform
    double step = 0;             ///< base quantiser step chosen (lossy)
    CodecProfile profile;
};

/// Encodes one volume into .vcz bytes. Throws UsageError for invalid options. Lossless keeps float bit
/// patterns, NaN and Inf included; lossy modes store NaN/Inf voxels exactly as corrections and bound the
/// finite ones (docs/codec.md, "NaN and Inf").
std::vector<std::byte> encodeVolume(ComputeContext& cc, const Volume& volume, const CodecOptions& options,
                                    EncodeReport* report = nullptr);
/// What the encoder did with one frame of a series.
struct FrameReport {
    FrameType type = FrameType::I;
    std::int32_t reference0 = -1, reference1 = -1;
    std::size_t bytes = 0; ///< brick payloads and motion data of the frame
    double psnr = 0;       ///< of the reconstruction against the frame's own value range (NaN: not measured)
    double maxError = 0;   ///< over the frame's voxels (NaN: not measured)
    bool intraFallback = false; ///< planned as P/B, coded as I because that was smaller
};

/// Encodes a series: the first frame chooses the quantiser steps for the rate target, every frame uses
/// them. With motion, each group of `gop` frames is an I frame followed by P frames (and B frames), each
/// predicted from the reconstructions the decoder will make (closed loop) and coded as a residual; a
/// planned P/B frame whose coding is larger than coding it alone becomes an I frame. `frames`, when set,
/// receives one report per frame (display order).
std::vector<std::byte> encodeSeries(ComputeContext& cc, const TimeSeries& series, const CodecOptions& options,
                                    std::vector<FrameReport>* frames = nullptr);

/// Region [lo, hi) in full-resolution voxel indices.
struct Region {
    Dims lo, hi;
};
/// Parses "x0,y0,z0:x1,y1,z1" (half-open). Throws UsageError.
Region parseRegion(std::string_view text);

struct DecodeOptions {
    std::optional<Region> region; ///< default: the whole volume
    int level = 0;                ///< 2^level-downsampled approximation (no finer detail is decoded)
    std::size_t frame = 0;
    unsigned threads = 2;
    CodecProfile* profile = nullptr; ///< when set, receives the stage times of the decode
    /// Full-resolution decodes of whole bricks on CPU devices: the inverse kernel converts each brick to
    /// voxels and writes it into the output while the brick is in cache (no read-back). False places the
    /// voxels on host threads from the transform's buffers; both give the same voxels (tests compare them).
    bool placeOnDevice = true;
    /// Bricks entropy decoded while the caller started the device (see DecodeAhead); unused when it does
    /// not match this decode.
    DecodeAhead* ahead = nullptr;
};

/// Random access to a .vcz held in memory or mapped from its file: validates header and index on
/// construction, checks each brick's checksum when it is decoded. A mapped reader touches only the header,
/// the index and the payloads it decodes, and hands a brick's payload pages back after decoding it, so its
/// resident memory does not grow with the file (volumes larger than memory). Example:
/// ```
/// volcl::VczReader r(volcl::readFileBytes("head.vcz"), "head.vcz");
/// volcl::VczReader big(std::filesystem::path("cloud.vcz"));   // mapped
/// volcl::Volume coarse = r.decode(cc, {.level = 2});
/// volcl::Volume brick = r.decodeBrick(cc, 0, 5, 0);   // frame 0, brick 5, full resolution
/// ```
class VczReader {
public:
    VczReader(std::vector<std::byte> bytes, std::string name);
    /// Maps the file (named by its path in errors); throws IoError naming it as the other form does.
    explicit VczReader(const std::filesystem::path& path);
    VczReader(VczReader&&) noexcept = default; // the bytes stay where they are: the span stays valid
    VczReader& operator=(VczReader&&) noexcept = default;
    VczReader(const VczReader& other); ///< shares the mapping, or copies the bytes held
    VczReader& operator=(const VczReader& other);
    const VczHeader& header() const noexcept { return header_; }
    const std::string& name() const noexcept { return name_; }
    std::size_t fileSize() const noexcept { return bytes_.size(); }
    /// The file's bytes, as given.
    std::span<const std::byte> bytes() const noexcept { return bytes_; }
    /// One brick at level `level` (its voxel origin is header().brickOrigin(brick) / 2^level). Of a float64
    /// file, the brick of its float32 layer (what the renderers sample).
    Volume decodeBrick(ComputeContext& cc, std::size_t frame, std::size_t brick, int level = 0) const;
    /// The whole volume or a region, at full or reduced resolution (a float64 file gives float64 voxels: at
    /// full resolution the encoded ones, at a coarser level its float32 layer's approximation widened). Output
    /// spacing grows by 2^level and
    /// the origin moves to the first kept sample. P/B frames decode at level 0 only (their prediction
    /// needs the whole reference frames), decoding the frames they reference first.
    Volume decode(ComputeContext& cc, const DecodeOptions& options = {}) const;
    /// Frame `frame` whole at full resolution, decoding only the frames it references (directly or through
    /// other frames) that `decoded` does not hold: `decoded[i]`, when present and non-null, is frame i as
    /// this reader decodes it. Playback passes the frames it just showed.
    Volume decodeFrame(ComputeContext& cc, std::size_t frame, std::span<const Volume* const> decoded = {},
                       unsigned threads = 2, CodecProfile* profile = nullptr) const;
    /// The frames decodeFrame(frame) decodes when given nothing, in decoding order (`frame` last).
    std::vector<std::size_t> framesNeeded(std::size_t frame,
                                          std::span<const Volume* const> decoded = {}) const;

private:
    /// decode(), or with `float64` false a float64 file's float32 layer.
    Volume decodeStored(ComputeContext& cc, const DecodeOptions& options, bool float64) const;
    std::vector<std::byte> owned_;             ///< the bytes given (empty for a mapped file)
    std::shared_ptr<const MappedFile> mapped_; ///< the file, when mapped
    std::span<const std::byte> bytes_;         ///< either of the two
    std::string name_;
    VczHeader header_;
};

/// Decodes every frame whole, each once (P/B frames from the frames already decoded; a frame is
/// released after the last frame that references it), and hands each to `use` in frame order.
void decodeEachFrame(const VczReader& reader, ComputeContext& cc, unsigned threads, CodecProfile* profile,
                     const std::function<void(std::size_t frame, Volume&& volume)>& use);

/// The frames' times, empty when the file stores none (every time 0).
std::vector<double> vczFrameTimes(const VczHeader& header);

/// Metadata key listing, per frame, the bricks that hold NaN/Inf voxels ("frame:brick,brick;frame:..."),
/// written by the encoder when there are any: the brick renderer compiles the NaN colour for those frames
/// and keeps those bricks when the NaN colour is visible.
inline constexpr std::string_view kVczNonFiniteKey = "volcl:nonfinite";
/// Metadata key holding a volume's direction (9 numbers, row by row, shortest round-trip decimals), written
/// when it is not the identity: a decoded volume has the direction the encoded one had.
inline constexpr std::string_view kVczDirectionKey = "volcl:direction";
/// Metadata key present ("1") when the volume is placed in patient axes (Volume::anatomical).
inline constexpr std::string_view kVczAnatomicalKey = "volcl:anatomical";
/// Adds the keys above for a volume's direction (when not the identity) and anatomical flag, as the
/// encoders write them.
void addPlacementMetadata(std::map<std::string, std::string>& metadata, const Direction3& direction,
                          bool anatomical);
/// The direction stored under kVczDirectionKey, the identity when absent. Throws DataError when it is
/// malformed or not orthonormal.
Direction3 vczDirection(const VczHeader& header);

/// Bricks of `frame` listed under kVczNonFiniteKey (ascending; empty when none or the key is absent).
/// Malformed entries and brick numbers past the grid are ignored.
std::vector<std::size_t> vczNonFiniteBricks(const VczHeader& header, std::size_t frame);

/// Every frame of a .vcz with the frames' times (empty when the file stores none).
TimeSeries decodeAllFrames(const VczReader& reader, ComputeContext& cc, unsigned threads = 2,
                           CodecProfile* profile = nullptr);

/// Decodes .vcz bytes (whole volume or per `options`).
Volume decodeVolume(ComputeContext& cc, std::span<const std::byte> vcz, const DecodeOptions& options = {},
                    const std::string& name = "input");

} // namespace volcl
