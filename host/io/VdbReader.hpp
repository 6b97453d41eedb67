// The OpenVDB reader program (volcl-vdb-reader): how libvolcl starts it and the reply it sends back.
#pragma once

#include <cstdint>

namespace volcl::io {

// libopenvdb trusts the node data inside a grid: corrupt topology can make it free memory twice, loop, or
// allocate without bound. libvolcl therefore decodes a grid in a separate program, started fresh with
// posix_spawn (a forked copy of a multithreaded caller could inherit locks held by its other threads and
// hang), and turns a crash, a hang or a refused allocation there into an error about the file.
//
// Command line: volcl-vdb-reader <caller pid> <file> <memory budget in bytes> [<grid name>]
// The reader writes one reply to file descriptor kVdbReplyFd and exits 0:
//   status (1 byte, VdbReplyStatus); then for Ok: dims x, y, z and the ScalarType (4 x uint64), spacing
//   and origin (3 doubles each), the voxels; otherwise: the message length (uint64) and the message.

/// File name of the reader program, installed beside libvolcl and its modules.
inline constexpr const char* kVdbReaderFile = "volcl-vdb-reader";
/// The reader's end of the reply pipe.
inline constexpr int kVdbReplyFd = 3;

/// Which of volcl's exceptions the reader's failure becomes in the caller.
enum class VdbReplyStatus : std::uint8_t { Ok, Io, Data, Usage };

} // namespace volcl::io
