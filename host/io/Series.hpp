// Time-series input: a list of volume files, quoted glob patterns, ParaView .pvd collections, 4D files.
#pragma once

#include "core/Volume.hpp"
#include "host/io/VolumeIo.hpp"

#include <filesystem>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace volcl {

/// Natural order of names: runs of digits compare as numbers ("frame_2" < "frame_10"), everything else
/// byte by byte; equal numbers with more leading zeros sort first, so the order is total.
bool naturalLess(std::string_view a, std::string_view b) noexcept;

/// True when `text` holds a glob metacharacter (`*`, `?` or `[`).
bool hasGlobPattern(std::string_view text) noexcept;

/// Regular files matching a shell glob pattern (wildcards allowed in every path component), in natural
/// order. Throws IoError naming the pattern when nothing matches.
std::vector<std::filesystem::path> expandGlob(std::string_view pattern);

/// One data set of a ParaView collection (.pvd): the file, resolved against the .pvd's folder, and its time.
struct PvdEntry {
    std::filesystem::path file;
    double time = 0;
};

/// Most DataSets a .pvd may list (checked while they are listed, before any is read).
inline constexpr std::size_t kMaxCollectionMembers = 100000;

/// The data sets of a .pvd in time order (stable for equal times). Throws IoError for a malformed file,
/// a DataSet without `file`, more than kMaxCollectionMembers, a file listed twice, or no DataSet at all;
/// DataError for a multi-part collection (several parts
/// at one time step), which is not one volume per time. A DataSet file follows the data-file rule of
/// other headers: in or below the .pvd's directory unless options.allowExternalData, and a regular file.
std::vector<PvdEntry> readPvd(const std::filesystem::path& path, const ReadOptions& options = {});

/// Where each frame of a series came from, for messages: the file and the frame's index within it.
struct SeriesFrameSource {
    std::filesystem::path file;
    std::size_t indexInFile = 0;
    std::string describe(std::size_t frame) const; ///< "frame 3 (b.vti)" or "frame 3 (run.nii, volume 3)"
};

struct SeriesInput {
    TimeSeries series;
    std::vector<SeriesFrameSource> sources; ///< one per frame
};

/// Reads a time series from command-line style inputs, each one of:
/// - a volume file (a 4D NIfTI or NRRD contributes all its frames),
/// - a `.pvd` collection (its data sets in time order; their times are kept),
/// - a glob pattern that names no existing file (expanded here, natural order: quote it in a shell).
/// Frames follow the inputs' order. Every frame must share dims, type, spacing and origin with frame 0:
/// a mismatch throws DataError naming the frame's index and file. Missing files and empty globs throw
/// IoError. The frames' headers are not cheaper to read than their payload for most formats, so frames
/// are read one at a time and checked as they arrive (a mismatch stops before the next file is read).
SeriesInput readSeriesInputs(std::span<const std::string> inputs, const ReadOptions& options = {},
                             std::vector<std::filesystem::path>* filesRead = nullptr);

/// The file list the inputs name, in frame order, without reading any volume (the .pvd files are parsed).
std::vector<std::filesystem::path> expandSeriesInputs(std::span<const std::string> inputs,
                                                      const ReadOptions& options = {});

} // namespace volcl
