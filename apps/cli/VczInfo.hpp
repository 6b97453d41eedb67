// .vcz files in the CLI: `volcl info`'s header and frame table, and the frames and NIfTI header decode/convert write.
#pragma once

#include "host/io/VolumeIo.hpp"
#include "wavelet/Codec.hpp"

#include <functional>
#include <ostream>
#include <string>

namespace volcl::cli {

/// Prints the .vcz file's grid, codec settings and one line per frame (JSON with `json`). Reads only
/// the header and index (validated); no frame is decoded.
void printVczInfo(std::ostream& out, const std::string& path, bool json);

/// Write options for a volume decoded from `header`: the NIfTI source's header it keeps (for NIfTI
/// outputs) and whether its voxels are that source's stored integers (data units for other outputs).
/// Throws IoError naming `name` for malformed metadata.
WriteOptions vczWriteOptions(const VczHeader& header, const std::string& name);

/// Decodes every frame whole, each once (P/B frames from the frames already decoded; a frame is
/// released after the last frame that references it), and hands each to `use` in frame order.
void decodeEachFrame(const VczReader& reader, ComputeContext& cc, unsigned threads, CodecProfile* profile,
                     const std::function<void(std::size_t frame, Volume&& volume)>& use);

/// The frames' times, empty when the file stores none (every time 0).
std::vector<double> vczFrameTimes(const VczHeader& header);

/// Every frame of a .vcz with the frames' times (empty when the file stores none).
TimeSeries decodeAllFrames(const VczReader& reader, ComputeContext& cc, unsigned threads = 2,
                           CodecProfile* profile = nullptr);

} // namespace volcl::cli
