// Internal helpers shared by the format readers and writers: sample decoding, size checks, zlib, text.
#pragma once

#include "core/AtomicFile.hpp"
#include "core/Channels.hpp"
#include "core/Error.hpp"
#include "core/Volume.hpp"
#include "host/io/VolumeIo.hpp"

#include <charconv>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace volcl::io {

/// Sample types found in files. The volume model holds fewer; volumeTypeFor() says where each lands.
enum class SampleType : std::uint8_t {
    Int8,
    UInt8,
    Int16,
    UInt16,
    Int32,
    UInt32,
    Int64,
    UInt64,
    Float32,
    Float64
};

std::size_t sampleSize(SampleType t) noexcept;
std::string_view sampleTypeName(SampleType t) noexcept;
/// int8 -> Int16 (exact); 32/64-bit integers -> Float32 (rounded); the rest (float64 included) keep their type.
ScalarType volumeTypeFor(SampleType t) noexcept;
SampleType sampleTypeOf(ScalarType t) noexcept;

/// Legacy VTK type names (`unsigned_char` ... `double`, `vtktypeint64`); `long` is 64-bit as VTK writes it on Linux.
std::optional<SampleType> vtkLegacyType(std::string_view name);

/// Throws IoError "<file>: <problem>"; every reader reports through it so messages look alike.
[[noreturn]] void fail(const std::filesystem::path& file, const std::string& problem);
[[noreturn]] void unsupported(const std::filesystem::path& file, const std::string& problem); // DataError

/// What one read needs besides its path: the caller's options, the memory budget, and the data files the
/// header names (resolved, confined to the header's directory, and recorded for same-file checks).
class ReadContext {
public:
    ReadContext(std::filesystem::path file, const ReadOptions& options);
    const ReadOptions& options() const noexcept { return options_; }
    const std::filesystem::path& file() const noexcept { return file_; }
    /// Data file `name` from the header, relative to the header's directory. Refuses (IoError naming the
    /// header) a file outside that directory unless options().allowExternalData, and a file that does not
    /// exist or is not a regular file.
    std::filesystem::path dataFile(std::string_view name);
    /// checkedVoxelCount() plus the memory check: `voxels` samples of `st` read and converted to the
    /// model's type must fit the memory budget.
    std::size_t voxelCount(const Dims& dims, std::size_t frames, SampleType st) const;
    /// Refuses `bytes` of memory for `what` above the budget.
    void claimMemory(std::size_t bytes, std::string_view what) const;
    /// Components per voxel of the file (1 until a reader of a multi-channel file notes more) and whether
    /// they are RGB(A) colour: channelsAsRequested() records them, readVolumeFile() checks --channel with them.
    void noteChannels(std::size_t count, bool color) noexcept {
        channels_ = count;
        colorChannels_ = color;
    }
    std::size_t channels() const noexcept { return channels_; }
    bool colorChannels() const noexcept { return colorChannels_; }
    /// The header followed by every data file resolved so far.
    const std::vector<std::filesystem::path>& files() const noexcept { return files_; }

private:
    std::filesystem::path file_;
    const ReadOptions& options_;
    std::vector<std::filesystem::path> files_;
    std::size_t channels_ = 1;
    bool colorChannels_ = false;
    std::filesystem::path headerDirectory_; ///< its real path, resolved by the first dataFile() that needs it
};

/// Voxel count of `dims` times `frames`, refusing zero sizes and products that overflow or exceed
/// what any file could hold (a lying header must not reach an allocation).
std::size_t checkedVoxelCount(const Dims& dims, std::size_t frames, const std::filesystem::path& file);
std::size_t checkedByteCount(std::size_t voxels, std::size_t sampleBytes, const std::filesystem::path& file);

/// Decodes `count` samples of type `st` stored with byte order `endian` into `dst` from voxel
/// `firstVoxel` on; dst.type() must be volumeTypeFor(st). `src` must hold exactly count samples.
void decodeSamples(std::span<const std::byte> src, SampleType st, Endian endian, Volume& dst,
                   std::size_t firstVoxel = 0);
/// Decodes `src` (whole samples of type `st` in byte order `endian`) into doubles: meshes keep their
/// coordinates, indices and scalars at full precision until they are checked.
std::vector<double> decodeToDouble(std::span<const std::byte> src, SampleType st, Endian endian);
/// Splits a payload of `frames` consecutive volumes into a time series with the model's types.
TimeSeries decodeFrames(std::span<const std::byte> payload, SampleType st, Endian endian, const Dims& dims,
                        std::size_t frames, const std::array<double, 3>& spacing,
                        const std::array<double, 3>& origin);
/// What a reader returns for a file of one time point whose voxels hold `channels.size()` components
/// (`kind` names them in messages: "vector", "RGB-color"): the channel ReadOptions::channel asks for, every
/// channel (ReadOptions::allChannels), or, asked for neither, a DataError naming `file` and the count. One
/// channel is the scalar file it is. `color`: the components are RGB(A) colour. Notes both in `ctx`.
TimeSeries channelsAsRequested(std::vector<Volume> channels, ReadContext& ctx, std::string_view kind,
                               bool color = false);
/// Refuses (DataError naming the file and the count, before any voxel is read) a file of `count` > 1 channels
/// when the options ask for neither one channel nor all of them; channelsAsRequested() checks it again.
void requireChannelsWanted(const ReadContext& ctx, std::size_t count, std::string_view kind);
/// Refuses (DataError naming `file`) a file holding both time frames and `components` > 1 components.
void refuseFramesWithComponents(std::size_t frames, std::size_t components,
                                const std::filesystem::path& file);
/// Refuses ASCII text too short to hold `count` values (each needs a character and a separator)
/// before the caller allocates a volume for them.
void requireAsciiCapacity(std::string_view text, std::size_t count, const std::filesystem::path& file);
/// Parses whitespace-separated numbers (ASCII encodings) into a volume of the model's type.
void decodeAsciiSamples(std::string_view text, SampleType st, Volume& dst, std::size_t firstVoxel,
                        std::size_t count, const std::filesystem::path& file);

/// Decompression budget: an output above kInflateAnyRatioBytes may come from at most
/// kMaxInflateRatio times fewer compressed bytes. Deflate's own limit is ~1032:1, reached only by
/// (nearly) constant data: a 255 KB .nii.gz of 256 MB zeros took 12 s and 521 MB for `info`.
inline constexpr std::size_t kMaxInflateRatio = 1000;
inline constexpr std::size_t kInflateAnyRatioBytes = std::size_t{64} << 20;
/// Refuses (IoError naming `file` and `what`) `expected` decompressed bytes from `compressed` bytes
/// beyond the decompression budget, before anything is allocated.
void checkInflateRatio(std::size_t compressed, std::size_t expected, const std::filesystem::path& file,
                       std::string_view what);

/// Inflates a zlib or gzip stream (detected from its first bytes; concatenated gzip members are
/// joined) that must decompress to exactly `expected` bytes. Truncated, corrupted (CRC/Adler), short,
/// long or trailing-garbage streams raise IoError naming `file` and `what`. The size is checked against
/// the decompression budget (checkInflateRatio) before anything is allocated.
std::vector<std::byte> inflateExact(std::span<const std::byte> compressed, std::size_t expected,
                                    const std::filesystem::path& file, std::string_view what);
/// The first `n` decompressed bytes of a zlib/gzip stream (fewer when the stream is shorter).
std::vector<std::byte> inflatePrefix(std::span<const std::byte> compressed, std::size_t n,
                                     const std::filesystem::path& file);
bool looksCompressed(std::span<const std::byte> bytes) noexcept; ///< gzip magic or a zlib header
enum class Wrapper : std::uint8_t { Gzip, Zlib };
std::vector<std::byte> deflateBytes(std::span<const std::byte> data, Wrapper wrapper, int level = 6);

/// Writes `bytes` to `path` atomically, gzip-compressed when the name ends in `.gz`.
void writeFileAtomically(const std::filesystem::path& path, std::span<const std::byte> bytes);

/// Writes all `n` bytes to a pipe or socket, retrying after signals; false when the other end is gone.
bool writeAll(int fd, const void* data, std::size_t n) noexcept;

bool hostIsLittleEndian() noexcept;
Endian hostEndian() noexcept;
/// Copy of a volume's bytes in the requested byte order.
std::vector<std::byte> bytesInOrder(const Volume& v, Endian endian);
/// Writes a volume's bytes in the requested byte order to `out`: straight from the volume in the host's
/// order (no copy: a one-shot decode would otherwise touch a second volume's worth of fresh memory), else
/// swapped through a small buffer.
void writeVoxelsInOrder(AtomicFile& out, const Volume& v, Endian endian);

// ---- text helpers -------------------------------------------------------------------------------
std::string_view trim(std::string_view s) noexcept;
std::string lower(std::string_view s);
bool iequals(std::string_view a, std::string_view b) noexcept;
bool endsWithI(std::string_view s, std::string_view suffix) noexcept;
std::vector<std::string_view> splitWords(std::string_view s); ///< on spaces, tabs, CR, LF
std::string_view asText(std::span<const std::byte> bytes) noexcept;

/// Reads one line from `text` starting at `pos` (without CR/LF); advances pos past the newline.
/// Returns nullopt at the end of the text.
std::optional<std::string_view> nextLine(std::string_view text, std::size_t& pos);

template <class T> std::optional<T> parseNumber(std::string_view token) noexcept {
    token = trim(token);
    if (!token.empty() && token.front() == '+') token.remove_prefix(1);
    T value{};
    const char* end = token.data() + token.size();
    auto [ptr, ec] = std::from_chars(token.data(), end, value);
    if (ec != std::errc() || ptr != end || token.empty()) return std::nullopt;
    return value;
}
/// Parses a number or throws IoError "<file>: <what>: '<token>' is not a number".
double requireDouble(std::string_view token, const std::filesystem::path& file, std::string_view what);
long long requireInt(std::string_view token, const std::filesystem::path& file, std::string_view what);
/// Three numbers (spacing, origin); `positive` also refuses zero, negative and non-finite values.
std::array<double, 3> requireTriple(const std::vector<std::string_view>& words, std::size_t first,
                                    const std::filesystem::path& file, std::string_view what, bool positive);
/// `count` positive sizes (NRRD `sizes`, MetaImage `DimSize`), padded with 1 to four axes.
std::array<std::size_t, 4> requireSizes(std::string_view text, std::size_t count,
                                        const std::filesystem::path& file, std::string_view what);
Dims requireDims(const std::vector<std::string_view>& words, std::size_t first, std::size_t count,
                 const std::filesystem::path& file, std::string_view what);

/// Shortest text that reads back to the same double.
std::string formatDouble(double v);

/// File names of a NRRD/MetaImage `<printf pattern> <min> <max> <step>` list. Only one integer
/// conversion (%d, %i or %u with optional 0/- flags and width) is accepted. A range of more than
/// `maxFiles` names is refused before any name is built (each file must hold at least one sample).
/// Most data files a volume of `dims` x `frames` may be split into: each holds at least one row of x
/// samples, and no header may list more than 10^6 (checked before a file name is built).
std::size_t maxDataFiles(const Dims& dims, std::size_t frames) noexcept;
/// `evenlyHeldBytes` (0: not checked): the payload the files hold in equal parts; a count that does not
/// divide it is refused before any name is built (each name costs a path check).
std::vector<std::string> expandFilePattern(std::string_view pattern, long long first, long long last,
                                           long long step, const std::filesystem::path& header,
                                           std::size_t maxFiles, std::size_t evenlyHeldBytes = 0);

enum class PayloadEncoding : std::uint8_t { Raw, Compressed, Ascii };
/// Payload of `totalBytes` spread evenly over detached data files (one file, a LIST or a pattern).
/// Per file: `lineSkip` text lines are dropped, then (raw) `byteSkip` bytes, -1 meaning "the data
/// sits at the end of the file"; compressed files are inflated first and byteSkip applies to the
/// inflated bytes. Ascii files are returned joined by newlines (totalBytes is then ignored).
std::vector<std::byte> readDetachedPayload(const std::filesystem::path& header,
                                           const std::vector<std::filesystem::path>& files,
                                           std::size_t totalBytes, PayloadEncoding encoding,
                                           long long byteSkip, std::size_t lineSkip);

// ---- per-format entry points ---------------------------------------------------------------------
// Each reads ctx.file(); ctx carries the options, the memory budget and the data-file confinement.
/// Where a file's voxels lie, for reading them by slabs without loading the file (host/io/SlabReader.hpp):
/// the samples start `skip` bytes into the data at `fileOffset` of `dataFile`, stored raw, or a gzip
/// stream starting there whose decompressed bytes hold them after `skip` bytes.
struct SlabLayout {
    std::filesystem::path dataFile;
    std::uint64_t fileOffset = 0, skip = 0;
    bool gzip = false;
    SampleType sampleType = SampleType::UInt8;
    Endian endian = Endian::Little;
    Dims dims;
    std::array<double, 3> spacing{1, 1, 1}, origin{0, 0, 0};
    Direction3 direction = kIdentityDirection;
    bool anatomical = false;
};
/// The layout of a 3D raw, NRRD or NIfTI file whose samples are raw or one gzip stream in one file, with
/// the same header checks and size checks of uncompressed data as the whole-file readers (IoError naming
/// the file); nullopt for what only the whole-file readers take (ascii, several data files, 4D, line
/// skips, NIfTI values scaled to data units). Nothing past the header is read.
std::optional<SlabLayout> rawSlabLayout(ReadContext& ctx);
std::optional<SlabLayout> nrrdSlabLayout(ReadContext& ctx);
std::optional<SlabLayout> niftiSlabLayout(ReadContext& ctx);
/// The first `n` bytes of a file (fewer when it is shorter), raw, or decompressed when `gzip`.
std::vector<std::byte> readFilePrefix(const std::filesystem::path& path, std::size_t n, bool gzip);

TimeSeries readRaw(ReadContext& ctx);
TimeSeries readNrrd(ReadContext& ctx);
TimeSeries readMetaImage(ReadContext& ctx);
TimeSeries readNifti(ReadContext& ctx);
TimeSeries readVtkXmlImage(ReadContext& ctx);
TimeSeries readVtkLegacy(ReadContext& ctx);
TimeSeries readSlc(ReadContext& ctx);
TimeSeries readVdb(ReadContext& ctx);
TimeSeries readInviwoDat(ReadContext& ctx);
TimeSeries readVoreenVvd(ReadContext& ctx);
TimeSeries readNpy(ReadContext& ctx);
/// True when `path` is a DICOM Part 10 file ("DICM" after the 128-byte preamble).
bool isDicomFile(const std::filesystem::path& path);
/// One DICOM series from a folder, a glob pattern of slice files, or one slice (its folder's files of the
/// same series); options.dicomSeries picks among several. `filesRead` gets the series' files.
TimeSeries readDicom(const std::filesystem::path& input, const ReadOptions& options,
                     std::vector<std::filesystem::path>& filesRead);

void writeRaw(const Volume& volume, const std::filesystem::path& path, const WriteOptions& options);
void writeNrrd(const Volume& volume, const std::filesystem::path& path, const WriteOptions& options);
/// A 4D NRRD of every frame (same dims and type): a fourth axis of kind `list` after the three spatial ones.
void writeNrrdSeries(std::span<const Volume> frames, const std::filesystem::path& path,
                     const WriteOptions& options);
/// Channels of one type as a 4D NRRD with a leading component axis (kind vector, RGB-color or RGBA-color).
void writeNrrdChannels(const ChannelVolume& channels, const std::filesystem::path& path,
                       const WriteOptions& options);
/// Channels of one type as a 5D NIfTI (dim[4] = 1, dim[5] = channels, intent vector 1007).
void writeNiftiChannels(const ChannelVolume& channels, const std::filesystem::path& path,
                        const WriteOptions& options);
/// Channels of one type as a .vti point-data array of NumberOfComponents = channels.
void writeVtkXmlChannels(const ChannelVolume& channels, const std::filesystem::path& path,
                         const WriteOptions& options);
/// The data file a detached `.nhdr` writer made for the header now at `header` (`NAME.<16 hex>.raw`, named
/// by a header that says "written by volcl"), which writing that header again removes; nullopt otherwise.
std::optional<std::filesystem::path> nhdrOwnedDataFile(const std::filesystem::path& header);
void writeVdb(const Volume& volume, const std::filesystem::path& path, const WriteOptions& options);
void writeNifti(const Volume& volume, const std::filesystem::path& path, const WriteOptions& options);
/// A 4D NIfTI of every frame (same dims and type); `times` (empty or one per frame, seconds) gives
/// pixdim[4] when the source metadata has no time step and the times are evenly spaced.
void writeNiftiSeries(std::span<const Volume> frames, const std::vector<double>& times,
                      const std::filesystem::path& path, const WriteOptions& options);
void writeVtkXmlImage(const Volume& volume, const std::filesystem::path& path, const WriteOptions& options);
/// One .npy array of every frame (same dims and type): a[z, y, x] for one frame, a[t, z, y, x] for more.
void writeNpy(std::span<const Volume> frames, const std::filesystem::path& path, const WriteOptions& options);

} // namespace volcl::io
