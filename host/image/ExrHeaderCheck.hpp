// A structural check of an OpenEXR file's headers, run before the file is handed to OpenEXR.
#pragma once

#include <cstddef>
#include <filesystem>

namespace volcl {

/// OpenEXR allocates from what a header claims while it opens a file: an attribute's size (a forged
/// 812-byte file claimed a 1.5 GB string and made it allocate 1.6 GB), the data window and the chunk
/// offset table. This walks every header of `path` (single- and multi-part) without allocating from
/// the file's claims and throws IoError naming the file when:
///  - an attribute name or type is unterminated or longer than OpenEXR allows (255 bytes),
///  - an attribute claims more bytes than remain in the file, or the header never ends,
///  - an attribute of a fixed-layout type (box2i, int, compression, ...), a channel list or a preview
///    states another size than its value has (OpenEXR would read on from another place than the check),
///  - a part has no dataWindow, or the window is empty or inverted,
///  - the part's pixels (as RGBA floats) exceed `memoryBudget` (0 = the default budget), or the image as
///    stored and as floats plus OpenEXR's decoding buffers (four chunks: a chunk is 1 to 256 lines by
///    compression, or a tile) do (a 693-byte strip claiming 589,825 pixels per line took 1 GB), or
///  - the part's chunk offset table (8 bytes per chunk) cannot fit in the file.
/// Files that do not start with the EXR magic number are left to the image library.
void checkExrHeaders(const std::filesystem::path& path, std::size_t memoryBudget);

} // namespace volcl
