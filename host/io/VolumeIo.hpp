// Reading and writing volume files: format detection, per-format readers and writers, raw options.
#pragma once

#include "core/Channels.hpp"
#include "core/Volume.hpp"
#include "host/io/NiftiMetadata.hpp"

#include <filesystem>
#include <optional>
#include <string_view>
#include <vector>

namespace volcl {

enum class Endian : std::uint8_t { Little, Big };

enum class VolumeFormat : std::uint8_t {
    Raw,         ///< headerless; dims/type from `<name>_<X>x<Y>x<Z>_<type>.raw` or from ReadOptions
    Nrrd,        ///< .nrrd / .nhdr (raw or gzip encoding, detached data, `data file:` patterns)
    MetaImage,   ///< .mhd / .mha (raw or zlib)
    Nifti,       ///< .nii / .nii.gz, 3D or 4D
    VtkXmlImage, ///< .vti (inline/appended, raw/zlib)
    VtkLegacy,   ///< .vtk STRUCTURED_POINTS
    Slc,         ///< VolVis .slc (run-length)
    Vdb,         ///< OpenVDB float/double grid, densified over the active bounding box
    InviwoDat,   ///< Inviwo .dat text header + raw file
    VoreenVvd,   ///< Voreen .vvd XML header + raw file
    Npy,         ///< numpy .npy (versions 1.0-3.0): a[z, y, x] or a series a[t, z, y, x]; no grid
    Dicom,       ///< DICOM series through GDCM: a folder, a glob pattern of slices, or one slice (its series)
};

std::string_view volumeFormatName(VolumeFormat f) noexcept;
/// Format from extension (and magic bytes where the extension is ambiguous). Throws IoError if unknown.
VolumeFormat detectVolumeFormat(const std::filesystem::path& path);

/// Options for reading; only raw files need dims/type. Flags override what a raw file name says.
struct ReadOptions {
    std::optional<Dims> dims;
    std::optional<ScalarType> type;
    Endian endian = Endian::Little;
    std::size_t headerBytes = 0;        ///< raw only: bytes to skip before the payload
    std::optional<std::string> vdbGrid; ///< VDB: grid name (default: the first scalar grid)
    /// Data files a header names (NRRD/MetaImage `data file`, .dat/.vvd raw files) must lie in or below
    /// the header's directory; true lets a header point anywhere (an absolute path, `../x`).
    bool allowExternalData = false;
    /// Largest memory one input may claim, in bytes (0 = defaultMemoryBudget(): half the physical
    /// memory). Size claims above it are refused before allocation; raise it to read larger inputs.
    std::size_t memoryBudget = 0;
    /// NIfTI only: a file whose scl_slope/scl_inter scale an integer datatype the model holds
    /// (niftiStoredValuesExact) gives its stored integers unscaled; without it (and for other datatypes)
    /// every reader gives data units, float32(stored * slope + inter).
    bool niftiStoredValues = false;
    /// DICOM only: the Series Instance UID to read when the input holds several series (without it a
    /// folder of several series is refused with their UIDs; a slice file gives its own series).
    std::optional<std::string> dicomSeries;
    /// A multi-channel file (NRRD vector/colour axis, NIfTI vector dim[5] or RGB24/RGBA32, .vti
    /// NumberOfComponents, MetaImage ElementNumberOfChannels) reads as this channel (0-based) alone; without
    /// it (and without allChannels) such a file is refused with one line naming its channel count. Channel
    /// 0 of a scalar file is the file; a channel past the last is a UsageError.
    std::optional<std::size_t> channel;
    /// A multi-channel file reads as its channels, one frame each; a 4D file
    /// with components is then refused (choose a channel). readVolumeChannels() sets it.
    bool allChannels = false;
};

/// Reads every frame of a volume file (a 3D file gives one frame). Validates header against payload:
/// throws IoError for truncated, oversized or garbage files, DataError for unsupported content.
TimeSeries readVolumeFile(const std::filesystem::path& path, const ReadOptions& options = {});
/// Same, and lists every file the read consisted of (the header and each data file it names), so a
/// caller can refuse to write over any of them (checkNotSameFile).
TimeSeries readVolumeFile(const std::filesystem::path& path, const ReadOptions& options,
                          std::vector<std::filesystem::path>& filesRead);
/// readVolumeFile() that also says how many components per voxel the file holds (`channels`, 1 for scalar
/// files); with options.allChannels the frames of a multi-channel file are its channels.
TimeSeries readVolumeFile(const std::filesystem::path& path, const ReadOptions& options,
                          std::size_t& channels);
/// Reads every channel of a volume file (a scalar file gives one channel); `options.allChannels` is set.
/// Throws as readVolumeFile, and DataError for a file with both time frames and components.
ChannelVolume readVolumeChannels(const std::filesystem::path& path, ReadOptions options = {});
/// Reads a 3D volume; a 4D file gives its first frame.
Volume readVolume(const std::filesystem::path& path, const ReadOptions& options = {});

struct WriteOptions {
    Endian endian = Endian::Little; ///< raw and NRRD
    bool compress = true;           ///< NRRD gzip encoding, VDB Blosc/zip where available, VTI zlib blocks
    /// NIfTI header fields of the volume's source (readNiftiMetadata, or a .vcz's stored copy): a .nii /
    /// .nii.gz output keeps its qform/sform, units, intent and scaling, a .vti its orientation. Without
    /// it a NIfTI output describes the volume's own spacing and origin.
    std::optional<NiftiMetadata> nifti;
    /// The volume holds the stored integers of a scaled NIfTI source (`nifti` set and scaling): a NIfTI
    /// output writes them unchanged with its scl_slope/scl_inter; every other output gets data units
    /// (niftiDataUnits, float32).
    bool niftiStoredValues = false;
};

/// Writers: Raw (.raw, .raw.gz), Nrrd (.nrrd attached, .nhdr detached + .raw), NIfTI-1 (.nii, .nii.gz),
/// VTK XML ImageData (.vti, appended data in zlib blocks), Vdb (.vdb) and numpy .npy (a[z, y, x], C order;
/// no spacing or origin). The format comes from the
/// extension. Writes atomically (temporary + rename). Throws UsageError for an unsupported format.
void writeVolumeFile(const Volume& volume, const std::filesystem::path& path,
                     const WriteOptions& options = {});

/// True when the output format of `path` holds several frames in one file (.nii, .nii.gz, .nrrd, .nhdr,
/// .npy).
bool formatHoldsSeries(const std::filesystem::path& path);

/// Writes every frame of `series` into one file: a NIfTI output becomes 4D (dim[4] = frames, pixdim[4]
/// the source's time step, else the series' even time step in seconds), a NRRD output 4D (a fourth axis
/// of kind `list`; NRRD keeps no times); a one-frame series goes to any writer as writeVolumeFile does. Frames must share dims and type. Throws UsageError naming `path` when
/// the format holds one volume and the series has more.
void writeSeriesFile(const TimeSeries& series, const std::filesystem::path& path,
                     const WriteOptions& options = {});

/// Writes the channels into one file with a component axis: NRRD (a leading axis of kind `vector`, or
/// `RGB-color`/`RGBA-color` when `channels.color` and 3/4 channels), NIfTI (dim[5] = channels, intent
/// vector 1007) or VTI (NumberOfComponents). The channels must share one type. Throws UsageError for any
/// other format.
void writeChannelsFile(const ChannelVolume& channels, const std::filesystem::path& path,
                       const WriteOptions& options = {});

/// Every existing file writeVolumeFile(volume, path) replaces or removes: the path itself and, for a
/// detached .nhdr, the data file its present header names when volcl made it (`NAME.<16 hex>.raw`). The
/// new data file of a .nhdr gets a fresh unique name, so it can never be an input.
std::vector<std::filesystem::path> volumeFilesWritten(const std::filesystem::path& path);

/// Parses `<X>x<Y>x<Z>_<type>` from a raw file name such as `head_256x256x113_uint16.raw`.
std::optional<std::pair<Dims, ScalarType>> parseRawFileName(std::string_view fileName);

} // namespace volcl
