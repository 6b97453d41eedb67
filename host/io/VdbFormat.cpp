// OpenVDB (.vdb): the file layout checked here, then the grid read through the OpenVDB module by a reader
// process of the reader service (VdbReader.hpp), so corrupt node data cannot crash or hang the caller;
// writing goes through the module in process.
#include "core/AtomicFile.hpp"
#include "core/MemoryBudget.hpp"
#include "core/runtime/RuntimeModule.hpp"
#include "host/io/IoDetail.hpp"
#include "host/io/VdbModule.hpp"
#include "host/io/VdbReader.hpp"

#include <openvdb/version.h> // file-format version numbers only: libopenvdb is linked by the module

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
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
// The grid itself is decoded by a reader that the reader service forks (VdbReader.hpp); its reply is read
// back here.

struct ReaderOutcome {
    std::vector<std::byte> reply;
    bool timedOut = false;
    int waitStatus = 0;
};

// Waits until `fd` is readable or `deadline` passes; false at the deadline.
bool waitReadable(int fd, std::chrono::steady_clock::time_point deadline) {
    while (true) {
        const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
            deadline - std::chrono::steady_clock::now());
        if (left.count() <= 0) return false;
        pollfd pfd{fd, POLLIN, 0};
        const int pr = ::poll(&pfd, 1, static_cast<int>(std::min<long long>(left.count(), 1000)));
        if (pr > 0) return true;
        if (pr < 0 && errno != EINTR) return true; // let the read report it
    }
}

// Closes a pipe end when it goes out of scope.
struct PipeEnd {
    explicit PipeEnd(int end) : fd(end) {}
    PipeEnd(const PipeEnd&) = delete;
    PipeEnd& operator=(const PipeEnd&) = delete;
    ~PipeEnd() { ::close(fd); }
    const int fd;
};

// The reader service of one calling thread: started on the thread's first read, ended with the thread
// (the service's parent-death signal follows the thread that spawned it). Reads on other threads use
// their own services, so they run in parallel as before.
class ReaderService {
public:
    ReaderService() = default;
    ReaderService(const ReaderService&) = delete;
    ReaderService& operator=(const ReaderService&) = delete;
    ~ReaderService() { stop(); }

    ReaderOutcome read(const fs::path& path, const ReadOptions& options,
                       std::chrono::steady_clock::duration timeout) {
        // A forked copy of the caller shares the socket with its parent's service: it starts its own.
        if (pid_ > 0 && owner_ != ::getpid()) {
            ::close(socket_);
            socket_ = -1;
            pid_ = -1;
        }
        const std::string request = requestMessage(path, options);
        if (pid_ < 0) start(path);
        int fds[2];
        if (::pipe2(fds, O_CLOEXEC) != 0)
            throw IoError(path.string() + ": cannot create a pipe: " + std::strerror(errno));
        const PipeEnd replyEnd{fds[0]};
        const auto deadline = std::chrono::steady_clock::now() + timeout;
        std::int32_t reader = -1;
        {
            const PipeEnd writeEnd{fds[1]}; // the service forwards it; this copy closes after the request
            // A service that has ended (killed, or its thread's parent-death signal) fails the send or, when it
            // ends while the request is under way, answers nothing: it is started once more.
            for (int attempt = 0; attempt < 2 && reader < 0; ++attempt) {
                if (attempt > 0) {
                    stop();
                    start(path);
                }
                if (send(request, writeEnd.fd) && !receive(reader, deadline)) reader = -1;
            }
        }
        if (reader < 0) {
            stop();
            throw IoError(path.string() + ": the OpenVDB reader service could not start a reader");
        }
        // The service now owes the reader's wait status; a read that ends early leaves it unread, so it ends
        // the service too (the next read starts a fresh one).
        try {
            return collect(path, reader, replyEnd.fd, deadline);
        } catch (...) {
            stop();
            throw;
        }
    }

private:
    // Reads the reader's reply until the pipe closes or the deadline passes (then kills it), and its wait
    // status.
    ReaderOutcome collect(const fs::path& path, pid_t reader, int replyFd,
                          std::chrono::steady_clock::time_point deadline) {
        ReaderOutcome out;
        std::byte buf[1 << 16];
        while (true) {
            if (!waitReadable(replyFd, deadline)) {
                out.timedOut = true;
                ::kill(reader, SIGKILL);
                break;
            }
            const ssize_t r = ::read(replyFd, buf, sizeof(buf));
            if (r < 0 && errno == EINTR) continue;
            if (r <= 0) break;
            out.reply.insert(out.reply.end(), buf, buf + r);
        }
        // The service reaps the reader and sends its wait status; a killed reader ends at once.
        std::int32_t status = 0;
        if (!receive(status, std::max(deadline, std::chrono::steady_clock::now()) + std::chrono::seconds(10)))
            throw IoError(path.string() + ": the OpenVDB reader service stopped during the read");
        out.waitStatus = status;
        return out;
    }

    void start(const fs::path& path) {
        const fs::path program = findRuntimeHelper(kVdbReaderFile, (path.string() + ": reading it").c_str());
        int fds[2];
        if (::socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, fds) != 0)
            throw IoError(path.string() + ": cannot create a socket: " + std::strerror(errno));
        // dup2 onto itself would keep close-on-exec set, and the service would start without its socket.
        if (fds[1] == kVdbServiceFd) {
            const int moved = ::fcntl(fds[1], F_DUPFD_CLOEXEC, kVdbServiceFd + 1);
            ::close(fds[1]);
            fds[1] = moved;
            if (moved < 0) {
                ::close(fds[0]);
                throw IoError(path.string() + ": cannot create a socket: " + std::strerror(errno));
            }
        }
        posix_spawn_file_actions_t actions;
        posix_spawn_file_actions_init(&actions);
        posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
        posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
        posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);
        posix_spawn_file_actions_adddup2(&actions, fds[1], kVdbServiceFd);
        std::string caller = std::to_string(::getpid()), name = program.string();
        char* argv[] = {name.data(), caller.data(), nullptr};
        pid_t pid = -1;
        const int rc = ::posix_spawn(&pid, program.c_str(), &actions, nullptr, argv, environ);
        posix_spawn_file_actions_destroy(&actions);
        ::close(fds[1]);
        if (rc != 0) {
            ::close(fds[0]);
            throw IoError(path.string() + ": cannot start " + program.string() + ": " + std::strerror(rc));
        }
        pid_ = pid;
        owner_ = ::getpid();
        socket_ = fds[0];
    }

    // Closing the socket ends the service; it is reaped here so no process outlives the thread.
    void stop() noexcept {
        if (socket_ >= 0) ::close(socket_);
        socket_ = -1;
        if (pid_ > 0 && owner_ == ::getpid()) {
            int status = 0;
            while (::waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
            }
        }
        pid_ = -1;
    }

    // The request: VdbRequest, the path, the grid name.
    static std::string requestMessage(const fs::path& path, const ReadOptions& options) {
        const std::string file = path.string();
        const std::uint64_t text = file.size() + (options.vdbGrid ? options.vdbGrid->size() : 0);
        if (text > kMaxVdbRequestText) throw UsageError(file + ": path and grid name are too long");
        const VdbRequest head{options.memoryBudget ? options.memoryBudget : defaultMemoryBudget(),
                              static_cast<std::uint32_t>(file.size()),
                              options.vdbGrid ? static_cast<std::uint32_t>(options.vdbGrid->size())
                                              : kNoGrid};
        std::string message(reinterpret_cast<const char*>(&head), sizeof(head));
        message += file;
        if (options.vdbGrid) message += *options.vdbGrid;
        return message;
    }

    // Sends the request with the reply pipe's write end attached.
    bool send(std::string message, int replyFd) {
        iovec iov{message.data(), message.size()};
        alignas(cmsghdr) char control[CMSG_SPACE(sizeof(int))] = {};
        msghdr msg{};
        msg.msg_iov = &iov;
        msg.msg_iovlen = 1;
        msg.msg_control = control;
        msg.msg_controllen = sizeof(control);
        cmsghdr* c = CMSG_FIRSTHDR(&msg);
        c->cmsg_level = SOL_SOCKET;
        c->cmsg_type = SCM_RIGHTS;
        c->cmsg_len = CMSG_LEN(sizeof(int));
        std::memcpy(CMSG_DATA(c), &replyFd, sizeof(int));
        while (true) {
            const ssize_t w = ::sendmsg(socket_, &msg, MSG_NOSIGNAL);
            if (w < 0 && errno == EINTR) continue;
            return w == static_cast<ssize_t>(message.size());
        }
    }

    bool receive(std::int32_t& value, std::chrono::steady_clock::time_point deadline) {
        if (!waitReadable(socket_, deadline)) return false;
        while (true) {
            const ssize_t r = ::recv(socket_, &value, sizeof(value), 0);
            if (r < 0 && errno == EINTR) continue;
            return r == sizeof(value);
        }
    }

    pid_t pid_ = -1;
    pid_t owner_ = -1; // the process that started the service
    int socket_ = -1;
};

ReaderService& readerService() {
    thread_local ReaderService service;
    return service;
}

} // namespace

TimeSeries readVdb(ReadContext& ctx) {
    const fs::path& path = ctx.file();
    const ReadOptions& options = ctx.options();
    checkVdbLayout(path);
    const ReaderOutcome outcome = readerService().read(path, options, std::chrono::minutes(5));
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
