// volcl-vdb-reader: decodes one .vdb grid in a process of its own and sends the dense volume to libvolcl.
#include "host/Error.hpp"
#include "host/io/VdbModule.hpp"
#include "host/io/VdbReader.hpp"
#include "host/runtime/RuntimeModule.hpp"

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <new>
#include <string>

#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <unistd.h>

namespace {

using volcl::io::VdbReplyStatus;

bool writeAll(int fd, const void* data, std::size_t n) {
    const auto* p = static_cast<const char*>(data);
    while (n > 0) {
        const ssize_t w = ::write(fd, p, n);
        if (w < 0 && errno == EINTR) continue;
        if (w <= 0) return false;
        p += w;
        n -= static_cast<std::size_t>(w);
    }
    return true;
}

// Caps the address space at what is mapped now (this program, libopenvdb and its libraries, and a
// sanitizer's shadow where there is one) plus twice the memory budget: the dense box and the grid it comes
// from. Sizes inside the grid data are libopenvdb's to trust, and a forged one made it allocate and touch
// 5 GB from an 11 KB file; past the cap the allocation fails and the read ends as a corrupt file.
void capAddressSpace(unsigned long long budget) {
    std::FILE* statm = std::fopen("/proc/self/statm", "r");
    unsigned long long pages = 0;
    const bool known = statm && std::fscanf(statm, "%llu", &pages) == 1;
    if (statm) std::fclose(statm);
    rlimit limit{};
    if (!known || ::getrlimit(RLIMIT_AS, &limit) != 0) return;
    const unsigned long long cap =
        pages * static_cast<unsigned long long>(::sysconf(_SC_PAGESIZE)) + 2ull * budget;
    if (limit.rlim_max != RLIM_INFINITY && cap > limit.rlim_max) return;
    if (limit.rlim_cur != RLIM_INFINITY && cap > limit.rlim_cur) return;
    limit.rlim_cur = static_cast<rlim_t>(cap);
    (void)::setrlimit(RLIMIT_AS, &limit);
}

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

bool readAndSend(const char* file, unsigned long long budget, const char* grid) {
    try {
        const auto& vdb = *static_cast<const volcl::io::VdbModule*>(volcl::loadRuntimeModule(
            volcl::io::kVdbModuleFile, volcl::io::kVdbModuleEntry, "OpenVDB file I/O"));
        capAddressSpace(budget);
        volcl::ReadOptions options;
        options.memoryBudget = static_cast<std::size_t>(budget);
        if (grid) options.vdbGrid = grid;
        volcl::TimeSeries series = vdb.read(file, options);
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

} // namespace

int main(int argc, char** argv) {
    // The reader never outlives the program that started it (it may be killed at its deadline).
    (void)::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (argc != 4 && argc != 5) {
        std::fprintf(stderr, "usage: %s <caller pid> <file> <memory budget> [<grid>] (started by libvolcl)\n",
                     argv[0]);
        return 2;
    }
    if (std::strtoll(argv[1], nullptr, 10) != static_cast<long long>(::getppid())) return 2; // caller gone
    const unsigned long long budget = std::strtoull(argv[3], nullptr, 10);
    const bool sent = readAndSend(argv[2], budget, argc == 5 ? argv[4] : nullptr);
    // No destructors or exit handlers: the reply is complete, and libopenvdb's teardown of a grid that was
    // corrupt is not worth the risk.
    ::_exit(sent ? 0 : 3);
}
