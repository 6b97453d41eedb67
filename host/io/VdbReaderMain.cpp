// volcl-vdb-reader: the OpenVDB reader service; each .vdb grid is decoded in a forked reader of its own.
#include "core/Error.hpp"
#include "core/MemoryBudget.hpp"
#include "core/runtime/RuntimeModule.hpp"
#include "host/io/IoDetail.hpp"
#include "host/io/VdbModule.hpp"
#include "host/io/VdbReader.hpp"

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <new>
#include <string>
#include <vector>

#include <dlfcn.h>
#include <link.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

namespace {

using volcl::io::VdbReplyStatus;

using volcl::io::writeAll;

bool sendFailure(VdbReplyStatus status, const std::string& message) {
    const std::uint64_t n = message.size();
    return writeAll(volcl::io::kVdbReplyFd, &status, 1) && writeAll(volcl::io::kVdbReplyFd, &n, 8) &&
           writeAll(volcl::io::kVdbReplyFd, message.data(), message.size());
}

bool sendVolume(const volcl::Volume& v) {
    const int fd = volcl::io::kVdbReplyFd;
    const VdbReplyStatus status = VdbReplyStatus::Ok;
    const std::uint64_t head[4] = {v.dims().x, v.dims().y, v.dims().z, static_cast<std::uint64_t>(v.type())};
    return writeAll(fd, &status, 1) && writeAll(fd, head, sizeof(head)) &&
           writeAll(fd, v.spacing.data(), 24) && writeAll(fd, v.origin.data(), 24) &&
           writeAll(fd, v.bytes().data(), v.byteSize());
}

// In a reader (a fork of the service): reads the file with the module the service loaded and replies.
bool readAndSend(const volcl::io::VdbModule* vdb, const std::string& loadError, const char* file,
                 unsigned long long budget, const char* grid) {
    try {
        if (!vdb) throw volcl::IoError(loadError);
        volcl::capAddressSpace(budget);
        volcl::ReadOptions options;
        options.memoryBudget = static_cast<std::size_t>(budget);
        if (grid) options.vdbGrid = grid;
        volcl::TimeSeries series = vdb->read(file, options);
        return sendVolume(series.frames.front());
    } catch (const volcl::UsageError& e) {
        return sendFailure(VdbReplyStatus::Usage, e.what());
    } catch (const volcl::DataError& e) {
        return sendFailure(VdbReplyStatus::Data, e.what());
    } catch (const volcl::Error& e) {
        return sendFailure(VdbReplyStatus::Io, e.what());
    } catch (const std::bad_alloc&) {
        return sendFailure(VdbReplyStatus::Io,
                           std::string(file) + ": not enough memory to read the grid (corrupt or too large)");
    } catch (const std::exception& e) {
        return sendFailure(VdbReplyStatus::Io, std::string(file) + ": OpenVDB cannot read it: " + e.what());
    }
}

// libopenvdb's logging library, log4cplus, starts a pool of worker threads when it is loaded; they serve
// asynchronous appenders, which volcl never configures (OpenVDB logs synchronously). The pool is stopped
// so that the service is single-threaded when it forks a reader: a fork copies only the calling thread,
// and a lock another thread held at that moment would stay held in the reader for ever.
void stopLoggingThreads() {
    std::string library;
    ::dl_iterate_phdr(
        [](dl_phdr_info* info, std::size_t, void* out) {
            const std::string name = info->dlpi_name ? info->dlpi_name : "";
            if (name.find("liblog4cplus") == std::string::npos) return 0;
            *static_cast<std::string*>(out) = name;
            return 1;
        },
        &library);
    if (library.empty()) return;
    void* handle = ::dlopen(library.c_str(), RTLD_LAZY | RTLD_NOLOAD);
    if (!handle) return;
    using Shutdown = void (*)();
    if (auto shutdown = reinterpret_cast<Shutdown>(::dlsym(handle, "_ZN9log4cplus18shutdownThreadPoolEv")))
        shutdown();
    ::dlclose(handle);
}

// One request from the socket: its text and the reply pipe. One Request and its receive buffer serve every
// request: the service allocates nothing per read, so its heap, which every reader's fork copies and every
// reader's exit unmaps, stays the size it had after loading libopenvdb. (A 64 KiB buffer per request had
// grown a sanitizer build's service to 100 MB of freed memory in quarantine; each fork then copied its
// page tables.)
struct Request {
    volcl::io::VdbRequest head{};
    std::string path, grid;
    bool hasGrid = false;
    int replyFd = -1;
    std::vector<char> buf = std::vector<char>(sizeof(volcl::io::VdbRequest) + volcl::io::kMaxVdbRequestText);
};

// Fills `r` with the next request; false when the caller has closed the socket.
bool receive(Request& r) {
    using namespace volcl::io;
    std::vector<char>& buf = r.buf;
    alignas(cmsghdr) char control[CMSG_SPACE(sizeof(int))];
    for (;;) {
        iovec iov{buf.data(), buf.size()};
        msghdr msg{};
        msg.msg_iov = &iov;
        msg.msg_iovlen = 1;
        msg.msg_control = control;
        msg.msg_controllen = sizeof(control);
        const ssize_t n = ::recvmsg(kVdbServiceFd, &msg, MSG_CMSG_CLOEXEC);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) return false;
        r.head = VdbRequest{};
        r.hasGrid = false;
        r.replyFd = -1;
        for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c; c = CMSG_NXTHDR(&msg, c))
            if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_RIGHTS)
                std::memcpy(&r.replyFd, CMSG_DATA(c), sizeof(int));
        if (r.replyFd < 0 || std::size_t(n) < sizeof(VdbRequest)) {
            if (r.replyFd >= 0) ::close(r.replyFd);
            continue; // not a request libvolcl sends: no pipe to answer on
        }
        std::memcpy(&r.head, buf.data(), sizeof(VdbRequest));
        r.hasGrid = r.head.gridBytes != kNoGrid;
        const std::uint64_t text = std::uint64_t(r.head.pathBytes) + (r.hasGrid ? r.head.gridBytes : 0);
        if (text != std::uint64_t(n) - sizeof(VdbRequest)) {
            ::close(r.replyFd);
            continue;
        }
        r.path.assign(buf.data() + sizeof(VdbRequest), r.head.pathBytes);
        if (r.hasGrid) r.grid.assign(buf.data() + sizeof(VdbRequest) + r.head.pathBytes, r.head.gridBytes);
        return true;
    }
}

bool answer(std::int32_t value) {
    while (true) {
        const ssize_t w = ::send(volcl::io::kVdbServiceFd, &value, sizeof(value), MSG_NOSIGNAL);
        if (w < 0 && errno == EINTR) continue;
        return w == sizeof(value);
    }
}

} // namespace

int main(int argc, char** argv) {
    // The service never outlives the thread that started it (nor a reader its service).
    (void)::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (argc != 2) {
        std::fprintf(stderr, "usage: %s <caller pid> (started by libvolcl, request socket on descriptor 3)\n",
                     argv[0]);
        return 2;
    }
    if (std::strtoll(argv[1], nullptr, 10) != static_cast<long long>(::getppid())) return 2; // caller gone
    const volcl::io::VdbModule* vdb = nullptr;
    std::string loadError;
    try {
        vdb = static_cast<const volcl::io::VdbModule*>(volcl::loadRuntimeModule(
            volcl::io::kVdbModuleFile, volcl::io::kVdbModuleEntry, "OpenVDB file I/O"));
    } catch (const std::exception& e) {
        loadError = e.what(); // every request is answered with it
    }
    stopLoggingThreads();
    Request r;
    while (receive(r)) {
        const pid_t reader = ::fork();
        if (reader == 0) {
            (void)::prctl(PR_SET_PDEATHSIG, SIGKILL);
            if (::dup2(r.replyFd, volcl::io::kVdbReplyFd) < 0) ::_exit(3); // over the socket: closes it
            const bool sent = readAndSend(vdb, loadError, r.path.c_str(), r.head.memoryBudget,
                                          r.hasGrid ? r.grid.c_str() : nullptr);
            // No destructors or exit handlers: the reply is complete, and libopenvdb's teardown of a grid
            // that was corrupt is not worth the risk.
            ::_exit(sent ? 0 : 3);
        }
        ::close(r.replyFd);
        if (!answer(reader < 0 ? -1 : reader)) break;
        if (reader < 0) continue;
        int status = 0;
        while (::waitpid(reader, &status, 0) < 0 && errno == EINTR) {
        }
        if (!answer(status)) break;
    }
    ::_exit(0);
}
