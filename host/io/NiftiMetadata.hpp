// NIfTI-1 header fields a volume keeps through conversion and compression: orientation, units, intent, scaling.
#pragma once

#include "core/Volume.hpp"

#include <array>
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <string_view>

namespace volcl {

/// The parts of a NIfTI-1 header that the volume model (axis-aligned spacing and origin) cannot hold.
/// readNiftiMetadata() fills it from a .nii/.nii.gz file; writeVolumeFile() writes it back into a NIfTI
/// output (re-anchored when the volume was cropped or downsampled) and uses its orientation for a .vti;
/// `volcl encode` stores it in the .vcz so `volcl decode -o x.nii.gz` restores it. Field names follow the
/// NIfTI-1 header (nifti1.h). Floats are kept as the file stores them, so an untouched volume writes
/// them back bit for bit.
struct NiftiMetadata {
    /// The grid the header describes in the volume model's terms (what the reader set as the volume's
    /// spacing and origin). A volume written with this metadata is placed relative to it: a crop or a
    /// coarser level moves the voxel-to-world transforms with it.
    std::array<double, 3> spacing{1, 1, 1}, origin{0, 0, 0};
    std::int16_t datatype = 0; ///< the source's datatype code (2 uint8, 4 int16, 512 uint16, 16 float32, ...)
    std::int16_t qformCode = 0, sformCode = 0;
    float quaternB = 0, quaternC = 0, quaternD = 0;
    float qfac = 1; ///< pixdim[0]: -1 flips the third axis of the qform
    std::array<float, 3> qoffset{0, 0, 0};
    std::array<float, 3> pixdim{1, 1, 1};       ///< pixdim[1..3] as stored
    std::array<std::array<float, 4>, 3> srow{}; ///< srow_x, srow_y, srow_z
    std::uint8_t xyztUnits = 0;                 ///< spatial units | temporal units (NIFTI_UNITS_*)
    float timeStep = 0, toffset = 0;            ///< pixdim[4] and toffset
    std::int16_t intentCode = 0;
    std::array<float, 3> intentP{0, 0, 0};
    std::string intentName;           ///< up to 15 characters
    float sclSlope = 0, sclInter = 0; ///< slope 0 means "no scaling", as in the file
    float calMin = 0, calMax = 0;     ///< display range
    std::string descrip;              ///< up to 79 characters

    /// True when scl_slope/scl_inter change values (slope not 0 and not the identity 1/0).
    bool scales() const noexcept { return sclSlope != 0 && (sclSlope != 1 || sclInter != 0); }
    bool operator==(const NiftiMetadata&) const = default;
};

/// Metadata key under which `volcl encode` stores a NIfTI source's header fields (niftiMetadataToText), so a NIfTI output of `volcl decode` keeps the source's orientation. Files
/// without it decode as before; readers that do not know it ignore it.
inline constexpr std::string_view kVczNiftiMetadataKey = "volcl:nifti";
/// Metadata key whose value "stored" says the voxels are the NIfTI source's stored integers and its
/// scl_slope/scl_inter (under kVczNiftiMetadataKey) turn them into data units: value = stored * slope +
/// inter. Without it the voxels are data units.
inline constexpr std::string_view kVczNiftiValuesKey = "volcl:nifti-values";

/// A .vcz's NIfTI fields, read from its key/value metadata by niftiFromVczMetadata.
struct VczNifti {
    NiftiMetadata meta;
    /// The voxels are the source's stored integers and meta's scale turns them into data units.
    bool storedValues = false;
};
/// The NIfTI fields a .vcz's metadata carries, or nullopt. Throws IoError naming `name` when the text is
/// damaged or kVczNiftiValuesKey is other than "stored" or comes without the header fields.
std::optional<VczNifti> niftiFromVczMetadata(const std::map<std::string, std::string>& metadata,
                                             const std::string& name);

/// True when scl_slope/scl_inter change values and the datatype is an integer type the volume model
/// holds exactly (uint8, int16, uint16): a volume can then carry the file's stored integers, the scale
/// kept beside them, instead of float32 data units (ReadOptions/WriteOptions::niftiStoredValues).
bool niftiStoredValuesExact(const NiftiMetadata& meta) noexcept;

/// Data units of a volume of stored values: float32(stored * scl_slope + scl_inter), the values the NIfTI
/// reader gives (and nibabel's get_fdata). A volume of a metadata that does not scale is returned as is.
Volume niftiDataUnits(const Volume& stored, const NiftiMetadata& meta);

/// Voxel-to-world transform (3 rows of [R | t]) the metadata describes: the sform when its code is set,
/// else the qform, else spacing and origin along the axes.
std::array<std::array<double, 4>, 3> niftiVoxelToWorld(const NiftiMetadata& meta);

/// Orientation of the index axes in RAS world axes (Volume::direction): the columns of
/// niftiVoxelToWorld()'s 3x3 part (the sform when sform_code > 0, else the qform when qform_code > 0, as
/// nibabel and 3D Slicer choose) made orthonormal; a singular sform falls back to the qform, and
/// identity when neither code is set or both are singular.
Direction3 niftiDirection(const NiftiMetadata& meta);

/// The metadata moved to `volume`'s grid: a volume cropped or downsampled from the source grid (its
/// spacing and origin changed in the volume model) gets the qform and sform composed with that index
/// change and pixdim set to its spacing; a volume on the source grid gets the fields unchanged.
NiftiMetadata niftiMetadataOnGrid(const NiftiMetadata& source, const Volume& volume);

/// Metadata for a volume that did not come from a NIfTI file: qform and sform (code 1, scanner) both
/// the axis-aligned transform of its spacing and origin, units unknown, no scaling or intent.
NiftiMetadata niftiMetadataForVolume(const Volume& volume);

/// The header fields of a NIfTI-1 file (reads only the header). Throws IoError as readVolumeFile does.
NiftiMetadata readNiftiMetadata(const std::filesystem::path& path);
/// readNiftiMetadata() when `path` is a NIfTI file, else nullopt.
std::optional<NiftiMetadata> readNiftiMetadataIfNifti(const std::filesystem::path& path);

/// Text form stored in a .vcz (JSON object; field names as above).
std::string niftiMetadataToText(const NiftiMetadata& meta);
/// Parses niftiMetadataToText() output. Throws IoError "<name>: NIfTI metadata: <problem>" on text that
/// is not that form or holds non-finite or out-of-range values.
NiftiMetadata niftiMetadataFromText(std::string_view text, const std::string& name);

} // namespace volcl
