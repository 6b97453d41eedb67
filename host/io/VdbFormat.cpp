// OpenVDB (.vdb): the file layout checked here, then the grid read through the OpenVDB module by a separate
// reader program (VdbReader.hpp), so corrupt node data cannot crash or hang the caller; writing goes through
// the module in process.
#include "host/MemoryBudget.hpp"
#include "host/io/AtomicFile.hpp"
#include "host/io/IoDetail.hpp"
#include "host/io/VdbModule.hpp"
#include "host/io/VdbReader.hpp"
#include "host/runtime/RuntimeModule.hpp"

#include <openvdb/version.h> // file-format version numbers only: libopenvdb is linked by the module

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

extern char** environ;

namespace volcl::io {

namespace fs = std::filesystem;

namespace {

// A failed load throws and is retried on the next call (a function-local static is initialised only once it
// succeeds).
const VdbModule& vdbModule() {
    static const auto* module =
        static_cast<const VdbModule*>(loadRuntimeModule(kVdbModuleFile, kVdbModuleEntry, "OpenVDB file I/O"));
    return *module;
}

// Walks the file header, the chain of grid descriptors (each names where its grid ends) and each grid's
// metadata before libopenvdb sees the file: libopenvdb trusts these offsets and sizes, so a truncated or
// padded file would otherwise be read past its end or accepted with missing data, and a forged metadata
// length made it allocate and zero-fill that many bytes (gigabytes from an 11 KB file) before reading.
void checkVdbLayout(const fs::path& path) {
    const std::vector<std::byte> bytes = readFileBytes(path);
    std::size_t pos = 0;
    // Fields are read up to `limit`: the end of the file, or of the grid whose metadata is walked.
    std::size_t limit = bytes.size();
    std::string inGrid;
    auto need = [&](std::size_t n, const char* what) {
        if (limit - pos < n) {
            if (inGrid.empty()) fail(path, std::string("truncated: ") + what + " is cut off");
            fail(path, "corrupt " + inGrid + ": " + what + " runs past the grid's end");
        }
    };
    auto u32 = [&](const char* what) {
        need(4, what);
        std::uint32_t v;
        std::memcpy(&v, bytes.data() + pos, 4);
        pos += 4;
        return v;
    };
    auto i64 = [&](const char* what) {
        need(8, what);
        std::int64_t v;
        std::memcpy(&v, bytes.data() + pos, 8);
        pos += 8;
        return v;
    };
    auto skipString = [&](const char* what) {
        const std::uint32_t n = u32(what);
        need(n, what);
        pos += n;
    };
    if (i64("the magic number") != 0x56444220) fail(path, "not an OpenVDB file (bad magic number)");
    const std::uint32_t version = u32("the file version");
    if (version < openvdb::OPENVDB_FILE_VERSION_BOOST_UUID || version > 1000)
        unsupported(path, "OpenVDB file format version " + std::to_string(version) + " is not supported");
    u32("the library version");
    u32("the library version");
    need(1, "the header");
    const bool hasOffsets = bytes[pos++] != std::byte{0};
    if (version >= openvdb::OPENVDB_FILE_VERSION_SELECTIVE_COMPRESSION &&
        version < openvdb::OPENVDB_FILE_VERSION_NODE_MASK_COMPRESSION) {
        need(1, "the header");
        ++pos;
    }
    need(36, "the file UUID");
    pos += 36;
    const std::uint32_t metaCount = u32("the file metadata");
    for (std::uint32_t m = 0; m < metaCount; ++m) {
        skipString("a metadata name");
        skipString("a metadata type");
        skipString("a metadata value");
    }
    if (!hasOffsets) unsupported(path, "OpenVDB files without grid offsets are not supported");
    const std::uint32_t grids = u32("the grid count");
    if (grids == 0) fail(path, "contains no grids");
    for (std::uint32_t g = 0; g < grids; ++g) {
        skipString("a grid name");
        skipString("a grid type");
        if (version >= openvdb::OPENVDB_FILE_VERSION_GRID_INSTANCING) skipString("a grid instance name");
        const std::int64_t gridPos = i64("a grid descriptor"), blockPos = i64("a grid descriptor"),
                           endPos = i64("a grid descriptor");
        if (gridPos < static_cast<std::int64_t>(pos) || blockPos < gridPos || endPos < blockPos)
            fail(path, "corrupt grid descriptor " + std::to_string(g) + " (offsets out of order)");
        if (static_cast<std::uint64_t>(endPos) > bytes.size())
            fail(path, "truncated: grid " + std::to_string(g) + " ends at byte " + std::to_string(endPos) +
                           " of " + std::to_string(bytes.size()));
        // The grid starts with its compression flags and its metadata: names, types and sized values.
        pos = static_cast<std::size_t>(gridPos);
        limit = static_cast<std::size_t>(endPos);
        inGrid = "grid " + std::to_string(g) + " metadata";
        if (version >= openvdb::OPENVDB_FILE_VERSION_NODE_MASK_COMPRESSION) u32("the compression flags");
        const std::uint32_t gridMetaCount = u32("the metadata count");
        for (std::uint32_t m = 0; m < gridMetaCount; ++m) {
            skipString("a metadata name");
            skipString("a metadata type");
            skipString("a metadata value");
        }
        inGrid.clear();
        limit = bytes.size();
        pos = static_cast<std::size_t>(endPos);
    }
    if (pos != bytes.size())
        fail(path, "oversized: " + std::to_string(bytes.size() - pos) + " bytes after the last grid");
}

// ---- isolation ------------------------------------------------------------------------------------
// The grid itself is decoded by the reader program (VdbReader.hpp), whose reply is read back here.

// Starts the reader on `path` with its reply pipe on kVdbReplyFd and the terminal on /dev/null (libopenvdb
// and a sanitizer may print; volcl's errors are one line). Returns its pid; `replyFd` is the read end.
pid_t startReader(const fs::path& path, const ReadOptions& options, int& replyFd) {
    const fs::path reader = findRuntimeHelper(kVdbReaderFile, (path.string() + ": reading it").c_str());
    int fds[2];
    if (::pipe2(fds, O_CLOEXEC) != 0)
        throw IoError(path.string() + ": cannot create a pipe: " + std::strerror(errno));
    // dup2 onto itself would keep close-on-exec set, and the reader would start without its reply pipe.
    if (fds[1] == kVdbReplyFd) {
        const int moved = ::fcntl(fds[1], F_DUPFD_CLOEXEC, kVdbReplyFd + 1);
        ::close(fds[1]);
        fds[1] = moved;
        if (moved < 0) {
            ::close(fds[0]);
            throw IoError(path.string() + ": cannot create a pipe: " + std::strerror(errno));
        }
    }
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_adddup2(&actions, fds[1], kVdbReplyFd);
    const std::string caller = std::to_string(::getpid());
    const std::string budget =
        std::to_string(options.memoryBudget ? options.memoryBudget : defaultMemoryBudget());
    std::vector<std::string> args = {reader.string(), caller, path.string(), budget};
    if (options.vdbGrid) args.push_back(*options.vdbGrid);
    std::vector<char*> argv;
    for (std::string& a : args)
        argv.push_back(a.data());
    argv.push_back(nullptr);
    pid_t pid = -1;
    const int rc = ::posix_spawn(&pid, reader.c_str(), &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    ::close(fds[1]);
    if (rc != 0) {
        ::close(fds[0]);
        throw IoError(path.string() + ": cannot start " + reader.string() + ": " + std::strerror(rc));
    }
    replyFd = fds[0];
    return pid;
}

// Reads the reader's whole reply, or stops at the deadline and kills it; then reaps it.
struct ReaderOutcome {
    std::vector<std::byte> reply;
    bool timedOut = false;
    int waitStatus = 0;
};

ReaderOutcome collectReply(pid_t reader, int replyFd, std::chrono::steady_clock::duration timeout) {
    ReaderOutcome out;
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    std::byte buf[1 << 16];
    while (true) {
        const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
            deadline - std::chrono::steady_clock::now());
        if (left.count() <= 0) {
            out.timedOut = true;
            break;
        }
        pollfd pfd{replyFd, POLLIN, 0};
        const int pr = ::poll(&pfd, 1, static_cast<int>(std::min<long long>(left.count(), 1000)));
        if (pr < 0 && errno == EINTR) continue;
        if (pr == 0) continue;
        const ssize_t r = ::read(replyFd, buf, sizeof(buf));
        if (r < 0 && errno == EINTR) continue;
        if (r <= 0) break;
        out.reply.insert(out.reply.end(), buf, buf + r);
    }
    ::close(replyFd);
    if (out.timedOut) ::kill(reader, SIGKILL);
    while (::waitpid(reader, &out.waitStatus, 0) < 0 && errno == EINTR) {
    }
    return out;
}

} // namespace

TimeSeries readVdb(ReadContext& ctx) {
    const fs::path& path = ctx.file();
    const ReadOptions& options = ctx.options();
    checkVdbLayout(path);
    int replyFd = -1;
    const pid_t reader = startReader(path, options, replyFd);
    const ReaderOutcome outcome = collectReply(reader, replyFd, std::chrono::minutes(5));
    const std::vector<std::byte>& reply = outcome.reply;
    const int wstatus = outcome.waitStatus;
    if (outcome.timedOut) fail(path, "OpenVDB did not finish reading within 5 minutes (corrupt grid data?)");
    if (WIFSIGNALED(wstatus))
        fail(path, "corrupt grid data: OpenVDB crashed reading it (signal " +
                       std::to_string(WTERMSIG(wstatus)) + ")");
    if (reply.empty() || !WIFEXITED(wstatus) || WEXITSTATUS(wstatus) != 0)
        fail(path, "corrupt grid data: the OpenVDB reader stopped without a result (exit status " +
                       std::to_string(WIFEXITED(wstatus) ? WEXITSTATUS(wstatus) : -1) + ")");

    std::size_t pos = 1;
    auto take = [&](void* dst, std::size_t n) {
        if (reply.size() - pos < n) fail(path, "corrupt grid data: the OpenVDB reader stopped early");
        std::memcpy(dst, reply.data() + pos, n);
        pos += n;
    };
    const auto status = static_cast<VdbReplyStatus>(reply[0]);
    if (status != VdbReplyStatus::Ok) {
        std::uint64_t n = 0;
        take(&n, 8);
        if (n > reply.size()) fail(path, "corrupt grid data: the OpenVDB reader stopped early");
        std::string message(static_cast<std::size_t>(n), '\0');
        take(message.data(), message.size());
        if (status == VdbReplyStatus::Usage) throw UsageError(message);
        if (status == VdbReplyStatus::Data) throw DataError(message);
        throw IoError(message);
    }
    std::uint64_t head[4];
    take(head, sizeof(head));
    if (head[3] > static_cast<std::uint64_t>(ScalarType::Float32))
        fail(path, "corrupt reply from the OpenVDB reader");
    Volume v(Dims{static_cast<std::size_t>(head[0]), static_cast<std::size_t>(head[1]),
                  static_cast<std::size_t>(head[2])},
             static_cast<ScalarType>(head[3]));
    take(v.spacing.data(), 24);
    take(v.origin.data(), 24);
    take(v.bytes().data(), v.byteSize());
    TimeSeries series;
    series.frames.push_back(std::move(v));
    return series;
}

void writeVdb(const Volume& volume, const fs::path& path, const WriteOptions& options) {
    vdbModule().write(volume, path, options);
}

} // namespace volcl::io
