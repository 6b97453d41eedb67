// Multi-channel volumes: N scalar channels on one grid, each with its own voxel type.
#pragma once

#include "core/Volume.hpp"

#include <cstddef>
#include <string>
#include <vector>

namespace volcl {

/// A multi-channel volume (microscopy, multi-modal MRI, RGB(A) volumes): one scalar Volume per channel, all
/// on one grid (dims, spacing, origin, direction), each keeping its own voxel type. A file's components share
/// its one type; channels taken from several files (a uint8 atlas beside a float32 MRI) need not, so the type
/// is per channel and every scalar tool reads one channel as the Volume it always had. Example:
/// ```
/// volcl::ChannelVolume cv = volcl::readVolumeChannels("rgb.nrrd");  // host/io/VolumeIo.hpp
/// const volcl::Volume& red = cv.channels[0];
/// ```
struct ChannelVolume {
    std::vector<Volume> channels;
    std::vector<std::string> names; ///< optional; empty or one per channel
    /// The file stored the components as colour (NRRD RGB-color/RGBA-color, NIfTI RGB24/RGBA32, an
    /// OpenImageIO stack): a renderer may draw them directly as colour.
    bool color = false;

    std::size_t count() const noexcept { return channels.size(); }
    /// Throws DataError when there is no channel, channels differ in dims, spacing, origin or direction
    /// (types may differ), or names are given but not one per channel.
    void validate() const;
};

/// Splits `components` interleaved samples per voxel (component fastest, as NRRD, VTK, MetaImage and
/// NIfTI RGB store them) into one volume per component on the grid of `grid` (its dims, spacing, origin,
/// direction). `interleaved` holds grid.voxelCount() * components samples of one type, in any shape.
std::vector<Volume> splitInterleaved(const Volume& interleaved, std::size_t components, const Volume& grid);
/// The inverse: the channels (one type) interleaved into dims {components, nx * ny, nz}.
Volume interleaveChannels(const std::vector<Volume>& channels);

} // namespace volcl
