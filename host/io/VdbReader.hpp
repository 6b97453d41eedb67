// The OpenVDB reader program (volcl-vdb-reader): how libvolcl talks to it and the reply a read sends back.
#pragma once

#include <cstdint>

namespace volcl::io {

// libopenvdb trusts the node data inside a grid: corrupt topology can make it free memory twice, loop, or
// allocate without bound. libvolcl therefore decodes every grid in a process of its own and turns a crash,
// a hang or a refused allocation there into an error about the file.
//
// The program is a reader service: `volcl-vdb-reader <caller pid>`, started fresh with posix_spawn (a
// forked copy of a multithreaded caller could inherit locks held by its other threads and hang), with a
// SOCK_SEQPACKET socket as descriptor kVdbServiceFd. It loads the OpenVDB module once (about 50 ms of
// symbol binding), stops the thread pool that libopenvdb's logging library starts, and so is
// single-threaded; for each request it forks a reader, which is safe in a single-threaded process and
// costs about a millisecond. libvolcl keeps one service per thread that reads
// .vdb files and ends it with that thread.
//
// Request: one message, VdbRequest followed by the path and the grid name, with the write end of a reply
// pipe attached (SCM_RIGHTS). The service answers with two messages, each an int32: the reader's pid (-1:
// fork failed), then its wait status once it has ended. The reader writes one reply to the pipe:
//   status (1 byte, VdbReplyStatus); then for Ok: dims x, y, z and the ScalarType (4 x uint64), spacing
//   and origin (3 doubles each), the voxels; otherwise: the message length (uint64) and the message.

/// File name of the reader program, installed beside libvolcl and its modules.
inline constexpr const char* kVdbReaderFile = "volcl-vdb-reader";
/// The service's end of the request socket, and in a reader the reply pipe's write end.
inline constexpr int kVdbServiceFd = 3;
inline constexpr int kVdbReplyFd = 3;

struct VdbRequest {
    std::uint64_t memoryBudget; ///< bytes the read may allocate
    std::uint32_t pathBytes;    ///< path length, no terminator
    std::uint32_t gridBytes;    ///< grid name length; kNoGrid: the file's first scalar grid
};
inline constexpr std::uint32_t kNoGrid = 0xffffffffu;
/// Longest path plus grid name a request carries.
inline constexpr std::uint32_t kMaxVdbRequestText = 1u << 16;

/// Which of volcl's exceptions the reader's failure becomes in the caller.
enum class VdbReplyStatus : std::uint8_t { Ok, Io, Data, Usage };

} // namespace volcl::io
