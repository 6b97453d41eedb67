// OpenVDB (.vdb): the file layout checked here, then the grid read through the OpenVDB module (VdbModule) in a
// forked child, so corrupt node data cannot crash or hang the caller; writing goes through the module too.
#include "host/MemoryBudget.hpp"
#include "host/io/AtomicFile.hpp"
#include "host/io/IoDetail.hpp"
#include "host/io/VdbModule.hpp"
#include "host/runtime/RuntimeModule.hpp"

#include <openvdb/version.h> // file-format version numbers only: libopenvdb is linked by the module

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>

#include <poll.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

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
// libopenvdb trusts the node data inside a grid: corrupt topology can make it free memory twice or
// loop. The grid is therefore decoded in a forked child that sends the dense volume (or the error)
// back through a pipe; a crash or hang there becomes an IoError here instead of killing the caller.

enum class ChildStatus : std::uint8_t { Ok, Io, Data, Usage };

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

// Caps the child's address space at what it maps now plus twice the memory budget (the dense box and the
// grid it comes from). Sizes inside the grid's data (buffers, node tables) are libopenvdb's to trust, and a
// forged one made the child allocate and touch 5 GB from an 11 KB file; past the cap an allocation fails
// and the read ends as a corrupt file instead of growing without bound.
// Measured in the parent, before the fork, so the child only calls setrlimit: a forked child of a
// multithreaded process should not take locks (stdio, the allocator) another thread may have held at the fork.
rlim_t childMemoryCap(const ReadOptions& options) {
    const std::size_t budget = options.memoryBudget ? options.memoryBudget : defaultMemoryBudget();
    std::FILE* statm = std::fopen("/proc/self/statm", "r");
    unsigned long long pages = 0;
    const bool known = statm && std::fscanf(statm, "%llu", &pages) == 1;
    if (statm) std::fclose(statm);
    if (!known) return RLIM_INFINITY;
    const unsigned long long mapped = pages * static_cast<unsigned long long>(::sysconf(_SC_PAGESIZE));
    rlimit limit{};
    if (::getrlimit(RLIMIT_AS, &limit) != 0) return RLIM_INFINITY;
    const unsigned long long cap = mapped + 2ull * budget;
    if (limit.rlim_max != RLIM_INFINITY && cap > limit.rlim_max) return RLIM_INFINITY;
    return static_cast<rlim_t>(cap);
}

void capChildMemory(rlim_t cap) {
    rlimit limit{};
    if (cap == RLIM_INFINITY || ::getrlimit(RLIMIT_AS, &limit) != 0) return;
    limit.rlim_cur = cap;
    (void)::setrlimit(RLIMIT_AS, &limit);
}

[[noreturn]] void childMain(const VdbModule& vdb, int fd, const fs::path& path, const ReadOptions& options,
                            rlim_t memoryCap) {
    capChildMemory(memoryCap);
    ChildStatus status = ChildStatus::Ok;
    std::string message;
    Volume v;
    try {
        TimeSeries s = vdb.read(path, options);
        v = std::move(s.frames.front());
    } catch (const UsageError& e) {
        status = ChildStatus::Usage, message = e.what();
    } catch (const DataError& e) {
        status = ChildStatus::Data, message = e.what();
    } catch (const Error& e) {
        status = ChildStatus::Io, message = e.what();
    } catch (const std::bad_alloc&) {
        status = ChildStatus::Io,
        message = path.string() + ": not enough memory to read the grid (corrupt or too large)";
    } catch (const std::exception& e) {
        status = ChildStatus::Io, message = path.string() + ": OpenVDB cannot read it: " + e.what();
    }
    bool ok = writeAll(fd, &status, 1);
    if (status != ChildStatus::Ok) {
        const std::uint64_t n = message.size();
        ok = ok && writeAll(fd, &n, 8) && writeAll(fd, message.data(), message.size());
    } else {
        const std::uint64_t head[4] = {v.dims().x, v.dims().y, v.dims().z,
                                       static_cast<std::uint64_t>(v.type())};
        ok = ok && writeAll(fd, head, sizeof(head)) && writeAll(fd, v.spacing.data(), 24) &&
             writeAll(fd, v.origin.data(), 24) && writeAll(fd, v.bytes().data(), v.byteSize());
    }
    ::close(fd);
    ::_exit(ok ? 0 : 3); // no atexit handlers or destructors of the parent's state
}

} // namespace

TimeSeries readVdb(ReadContext& ctx) {
    const fs::path& path = ctx.file();
    const ReadOptions& options = ctx.options();
    checkVdbLayout(path);
    // Loaded before the fork: the child then only runs code that is already mapped.
    const VdbModule& vdb = vdbModule();
    const rlim_t memoryCap = childMemoryCap(options);
    int fds[2];
    if (::pipe(fds) != 0) throw IoError(path.string() + ": cannot create a pipe: " + std::strerror(errno));
    const pid_t child = ::fork();
    if (child < 0) {
        ::close(fds[0]);
        ::close(fds[1]);
        throw IoError(path.string() + ": cannot fork the OpenVDB reader: " + std::strerror(errno));
    }
    if (child == 0) {
        ::close(fds[0]);
        childMain(vdb, fds[1], path, options, memoryCap);
    }
    ::close(fds[1]);
    std::vector<std::byte> reply;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::minutes(5);
    bool timedOut = false;
    std::byte buf[1 << 16];
    while (true) {
        const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
            deadline - std::chrono::steady_clock::now());
        if (left.count() <= 0) {
            timedOut = true;
            break;
        }
        pollfd pfd{fds[0], POLLIN, 0};
        const int pr = ::poll(&pfd, 1, static_cast<int>(std::min<long long>(left.count(), 1000)));
        if (pr < 0 && errno == EINTR) continue;
        if (pr == 0) continue;
        const ssize_t r = ::read(fds[0], buf, sizeof(buf));
        if (r < 0 && errno == EINTR) continue;
        if (r <= 0) break;
        reply.insert(reply.end(), buf, buf + r);
    }
    ::close(fds[0]);
    if (timedOut) ::kill(child, SIGKILL);
    int wstatus = 0;
    while (::waitpid(child, &wstatus, 0) < 0 && errno == EINTR) {
    }
    if (timedOut) fail(path, "OpenVDB did not finish reading within 5 minutes (corrupt grid data?)");
    if (WIFSIGNALED(wstatus))
        fail(path, "corrupt grid data: OpenVDB crashed reading it (signal " +
                       std::to_string(WTERMSIG(wstatus)) + ")");
    if (reply.empty()) fail(path, "corrupt grid data: the OpenVDB reader stopped without a result");

    std::size_t pos = 1;
    auto take = [&](void* dst, std::size_t n) {
        if (reply.size() - pos < n) fail(path, "corrupt grid data: the OpenVDB reader stopped early");
        std::memcpy(dst, reply.data() + pos, n);
        pos += n;
    };
    const auto status = static_cast<ChildStatus>(reply[0]);
    if (status != ChildStatus::Ok) {
        std::uint64_t n = 0;
        take(&n, 8);
        if (n > reply.size()) fail(path, "corrupt grid data: the OpenVDB reader stopped early");
        std::string message(static_cast<std::size_t>(n), '\0');
        take(message.data(), message.size());
        if (status == ChildStatus::Usage) throw UsageError(message);
        if (status == ChildStatus::Data) throw DataError(message);
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
