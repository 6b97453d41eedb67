// Atomic file output (unique temporary + fsync + rename) and whole-file reading.
#include "core/AtomicFile.hpp"

#include "core/Error.hpp"

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <thread>

#include <fcntl.h>
#include <pthread.h>
#include <signal.h>
#include <stdio.h> // renameat2
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

namespace volcl {

namespace fs = std::filesystem;

namespace {

std::string systemError(int err) {
    return std::strerror(err);
}

// Longest part of the target's name a temporary repeats: with ".", ".tmp-" and the suffix of tempCandidate
// (at most 10 + 1 + 10 + 1 + 8 digits and dashes) a temporary name stays within NAME_MAX (255 bytes).
constexpr std::size_t kMaxNameInTemp = 200;

// ".NAME.tmp-": a NAME longer than kMaxNameInTemp is cut, and a hash of the whole name (FNV-1a) keeps the
// prefixes of two long names with a common beginning apart (removeStaleTemporaries matches by prefix).
std::string tempPrefix(const fs::path& target) {
    std::string name = target.filename().string();
    if (name.size() > kMaxNameInTemp) {
        std::uint64_t hash = 14695981039346656037ULL;
        for (const char c : name)
            hash = (hash ^ static_cast<unsigned char>(c)) * 1099511628211ULL;
        static constexpr char kHex[] = "0123456789abcdef";
        name.resize(kMaxNameInTemp - 17);
        name += '~';
        for (int shift = 60; shift >= 0; shift -= 4)
            name += kHex[(hash >> shift) & 15];
    }
    std::string prefix(1, '.'); // not "." + name: GCC 12 misreports that as an overlapping copy
    prefix.append(name).append(".tmp-");
    return prefix;
}

// "a FIFO", "a directory", ... for a file type that is not a regular file; empty for a regular file.
std::string kindOf(mode_t mode) {
    if (S_ISREG(mode)) return {};
    if (S_ISDIR(mode)) return "a directory";
    if (S_ISFIFO(mode)) return "a FIFO";
    if (S_ISCHR(mode)) return "a character device";
    if (S_ISBLK(mode)) return "a block device";
    if (S_ISSOCK(mode)) return "a socket";
    return "not a regular file";
}

fs::path directoryOf(const fs::path& target) {
    return target.parent_path().empty() ? fs::path(".") : target.parent_path();
}

// A unique name for a temporary of `target`: .NAME.tmp-PID-COUNTER-RANDOM.
fs::path tempCandidate(const fs::path& target) {
    static std::atomic<unsigned> counter{0};
    std::random_device rd;
    std::string name = tempPrefix(target);
    name.append(std::to_string(::getpid()))
        .append("-")
        .append(std::to_string(counter.fetch_add(1)))
        .append("-")
        .append(std::to_string(rd() & 0xffffff));
    return directoryOf(target) / name;
}

// Creates an empty file with a name nobody else holds (O_EXCL), so two writers never share a temporary.
fs::path createUniqueTemp(const fs::path& target) {
    const fs::path dir = directoryOf(target);
    for (int attempt = 0; attempt < 64; ++attempt) {
        const fs::path candidate = tempCandidate(target);
        const int fd = ::open(candidate.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        if (fd >= 0) {
            ::close(fd);
            return candidate;
        }
        if (errno != EEXIST)
            throw IoError(target.string() + ": cannot create a temporary file in " + dir.string() + ": " +
                          systemError(errno));
    }
    throw IoError(target.string() + ": cannot find a free temporary file name in " + dir.string());
}

// Removes named temporaries of `target` left by processes that no longer exist (killed before they could
// clean up). A live PID, even a reused one, keeps its files: only certainly-stale ones go.
void removeStaleTemporaries(const fs::path& target) {
    const std::string prefix = tempPrefix(target);
    std::error_code ec;
    for (fs::directory_iterator it(directoryOf(target), ec), end; !ec && it != end; it.increment(ec)) {
        const std::string name = it->path().filename().string();
        if (!name.starts_with(prefix)) continue;
        const std::string rest = name.substr(prefix.size());
        const std::size_t dash = rest.find('-');
        if (dash == 0 || dash == std::string::npos || dash > 10) continue;
        long pid = 0;
        for (std::size_t i = 0; i < dash; ++i) {
            if (rest[i] < '0' || rest[i] > '9') {
                pid = 0;
                break;
            }
            pid = pid * 10 + (rest[i] - '0');
        }
        if (pid <= 0 || pid == ::getpid()) continue;
        if (::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH) {
            std::error_code removeEc;
            fs::remove(it->path(), removeEc);
        }
    }
}

// An unnamed file in the target's directory, or -1 where the kernel or file system has no O_TMPFILE.
int openUnnamedTemp(const fs::path& target) {
#ifdef O_TMPFILE
    return ::open(directoryOf(target).c_str(), O_TMPFILE | O_WRONLY | O_CLOEXEC, 0666);
#else
    (void)target;
    return -1;
#endif
}

} // namespace

// The temporary's stream. A writer that seeks back to patch a header or an index leaves the stream's
// position short of the file's end, so the furthest position written is kept: before each seek (when
// something was written since the last one) and for the direct writes that bypass the stream.
struct AtomicFile::TrackedStream {
    struct Buffer : std::filebuf {
        std::streamoff end = 0;
        bool wrote = false;
        void noteEnd() {
            if (!wrote && pptr() == pbase()) return;
            const pos_type here = std::filebuf::seekoff(0, std::ios::cur, std::ios::out);
            if (here != pos_type(off_type(-1))) end = std::max<std::streamoff>(end, here);
            wrote = false;
        }
        pos_type seekoff(off_type off, std::ios::seekdir dir, std::ios::openmode which) override {
            noteEnd();
            return std::filebuf::seekoff(off, dir, which);
        }
        pos_type seekpos(pos_type pos, std::ios::openmode which) override {
            noteEnd();
            return std::filebuf::seekpos(pos, which);
        }
        int_type overflow(int_type c) override {
            wrote = true;
            return std::filebuf::overflow(c);
        }
        std::streamsize xsputn(const char* s, std::streamsize n) override {
            wrote = wrote || n > 0;
            return std::filebuf::xsputn(s, n);
        }
    };
    Buffer buffer;
    std::ostream out{&buffer};
    /// The file's expected size: the furthest position written, -1 after an error.
    std::streamoff expectedEnd() {
        out.flush();
        const std::streamoff here = out.tellp(); // also notes the end of the last writes
        return out && here >= 0 ? std::max(buffer.end, here) : -1;
    }
};

void checkOutputPath(const fs::path& target) {
    if (target.empty()) throw IoError("output path is empty");
    const fs::path dir = directoryOf(target);
    std::error_code ec;
    if (!fs::is_directory(dir, ec))
        throw IoError(target.string() + ": output directory " + dir.string() + " does not exist");
    if (::access(dir.c_str(), W_OK) != 0)
        throw IoError(target.string() + ": output directory " + dir.string() + " is not writable");
    // The commit's rename would replace a FIFO or a device node by a regular file (and a directory
    // cannot be replaced): an existing target must be a regular file. /dev/null is refused too.
    const std::string kind = nonRegularKind(target);
    if (!kind.empty())
        throw IoError(target.string() + ": output exists and is " + kind + ", not a regular file");
}

AtomicFile::AtomicFile(fs::path target) : target_(std::move(target)) {
    checkOutputPath(target_);
    // A dead writer's journal may name this target: its hidden files are the finished series, which
    // removeStaleTemporaries would otherwise delete.
    completeInterruptedCommit(target_);
    removeStaleTemporaries(target_);
    fd_ = openUnnamedTemp(target_);
    if (fd_ >= 0) {
        // The kernel frees an unnamed file with its last descriptor: nothing survives a crash or a kill.
        temp_ = fs::path("/proc/self/fd") / std::to_string(fd_);
        std::error_code procEc;
        if (fs::exists(temp_, procEc)) return;
        ::close(fd_); // no /proc: libraries could not open the temporary by path
        fd_ = -1;
    }
    temp_ = createUniqueTemp(target_);
}

AtomicFile::~AtomicFile() {
    if (committed_) return;
    try {
        if (stream_) stream_->buffer.close();
    } catch (...) {
    }
    if (fd_ >= 0) {
        ::close(fd_);
        return;
    }
    std::error_code ec;
    fs::remove(temp_, ec);
}

std::ostream& AtomicFile::stream() {
    if (committed_) throw IoError(target_.string() + ": already committed");
    if (!stream_) {
        auto opened = std::make_unique<TrackedStream>();
        if (!opened->buffer.open(temp_, std::ios::out | std::ios::binary | std::ios::trunc))
            throw IoError(target_.string() + ": cannot open temporary " + temp_.string() + " for writing");
        stream_ = std::move(opened);
    }
    return stream_->out;
}

// O_DIRECT wants the file offset, the length and the buffer aligned to the device's logical block; 4096
// covers 512-byte and 4 KiB devices. One MiB per request was the fastest of 1, 4 and 8 MiB.
constexpr std::size_t kDirectAlignment = 4096;
constexpr std::size_t kDirectChunkBytes = std::size_t(1) << 20;

std::span<const std::byte> AtomicFile::writeDirect(std::span<const std::byte> bytes) {
    std::ostream& s = stream();
    s.flush();
    const std::streamoff position = s.tellp();
    if (!s || position < 0) return bytes; // the stream reports the error on its own write
    auto offset = static_cast<std::size_t>(position);
    // The bytes before the next aligned offset go through the stream.
    const std::size_t head =
        std::min(bytes.size(), (kDirectAlignment - offset % kDirectAlignment) % kDirectAlignment);
    if (head > 0) {
        s.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(head));
        s.flush();
        if (!s) throw IoError(target_.string() + ": write failed (disk full or file size limit?)");
        bytes = bytes.subspan(head);
        offset += head;
    }
    const int fd = ::open(temp_.c_str(), O_WRONLY | O_DIRECT | O_CLOEXEC);
    if (fd < 0) return bytes; // a file system without direct I/O
    const std::unique_ptr<void, decltype(&std::free)> bounce(
        std::aligned_alloc(kDirectAlignment, kDirectChunkBytes), &std::free);
    std::size_t written = 0;
    const std::size_t whole = bytes.size() / kDirectAlignment * kDirectAlignment;
    while (bounce && written < whole) {
        const std::size_t n = std::min(kDirectChunkBytes, whole - written);
        std::memcpy(bounce.get(), bytes.data() + written, n);
        const ssize_t w = ::pwrite(fd, bounce.get(), n, static_cast<off_t>(offset + written));
        if (w < 0 && errno == EINTR) continue;
        // A refusal (EINVAL: no direct I/O here) or a short write (the file size limit) leaves the rest to
        // the stream, which writes what it can and reports the error.
        if (w <= 0) break;
        written += static_cast<std::size_t>(w);
        if (static_cast<std::size_t>(w) < n) break;
    }
    ::close(fd);
    if (written > 0) {
        stream_->buffer.end = std::max(stream_->buffer.end, static_cast<std::streamoff>(offset + written));
        s.seekp(static_cast<std::streamoff>(offset + written));
    }
    return bytes.subspan(written);
}

void AtomicFile::write(std::span<const std::byte> bytes) {
    std::ostream& s = stream();
    if (bytes.size() >= kDirectWriteMinBytes) bytes = writeDirect(bytes);
    s.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    if (!s) throw IoError(target_.string() + ": write failed (disk full or file size limit?)");
}

void AtomicFile::write(std::string_view text) {
    write(std::span<const std::byte>(reinterpret_cast<const std::byte*>(text.data()), text.size()));
}

namespace {

thread_local AtomicCommitGroup* activeGroup = nullptr;

// Gives the finished temporary a hidden name nobody else holds (linkat cannot replace a file). A kill
// after this leaves a .tmp-PID file that the next writer of the target removes.
fs::path linkUnnamed(const fs::path& procPath, const fs::path& target) {
    for (int attempt = 0; attempt < 64; ++attempt) {
        const fs::path named = tempCandidate(target);
        if (::linkat(AT_FDCWD, procPath.c_str(), AT_FDCWD, named.c_str(), AT_SYMLINK_FOLLOW) == 0)
            return named;
        if (errno != EEXIST)
            throw IoError(target.string() + ": cannot link the finished file into " +
                          directoryOf(target).string() + ": " + systemError(errno));
    }
    throw IoError(target.string() + ": cannot find a free temporary file name");
}

// Links the unnamed finished file at `procPath` as `target` when no file has that name: true when done,
// false when the name exists (a move must replace it).
bool linkIfAbsent(const fs::path& procPath, const fs::path& target) {
    if (::linkat(AT_FDCWD, procPath.c_str(), AT_FDCWD, target.c_str(), AT_SYMLINK_FOLLOW) == 0) return true;
    if (errno == EEXIST) return false;
    throw IoError(target.string() + ": cannot link the finished file into " + directoryOf(target).string() +
                  ": " + systemError(errno));
}

// Moves `finished` over `target` and returns a hidden name that still holds the file it replaced (empty
// when there was none). RENAME_EXCHANGE swaps the two names in one step, so the writer learns exactly which
// file it replaced even when other writers race for the target; where the file system has no exchange,
// the old file gets a second name first (link), then rename replaces it.
fs::path moveKeepingOld(const fs::path& finished, const fs::path& target) {
    for (int attempt = 0; attempt < 64; ++attempt) {
        if (::renameat2(AT_FDCWD, finished.c_str(), AT_FDCWD, target.c_str(), RENAME_EXCHANGE) == 0) {
            struct stat st {};
            if (::lstat(finished.c_str(), &st) == 0 && !S_ISREG(st.st_mode) && !S_ISLNK(st.st_mode)) {
                // Something else (a directory) took the target's name since the AtomicFile was made.
                ::renameat2(AT_FDCWD, finished.c_str(), AT_FDCWD, target.c_str(), RENAME_EXCHANGE);
                throw IoError(target.string() + ": output is now " + kindOf(st.st_mode) +
                              ", not a regular file");
            }
            return finished;
        }
        if (errno == ENOENT) { // no target yet: appear only if still nobody else made one
            if (::renameat2(AT_FDCWD, finished.c_str(), AT_FDCWD, target.c_str(), RENAME_NOREPLACE) == 0)
                return {};
            if (errno == EEXIST) continue;
        }
        if (errno != EINVAL && errno != ENOSYS && errno != ENOTSUP)
            throw IoError(target.string() +
                          ": cannot move the finished file into place: " + systemError(errno));
        // No renameat2 flags here: keep the old file under a second name, then replace it.
        fs::path old;
        for (int n = 0; n < 64 && old.empty(); ++n) {
            const fs::path candidate = tempCandidate(target);
            if (::linkat(AT_FDCWD, target.c_str(), AT_FDCWD, candidate.c_str(), 0) == 0)
                old = candidate;
            else if (errno != EEXIST)
                break; // ENOENT: nothing to keep
        }
        if (::rename(finished.c_str(), target.c_str()) != 0) {
            const int err = errno;
            if (!old.empty()) ::unlink(old.c_str());
            throw IoError(target.string() +
                          ": cannot move the finished file into place: " + systemError(err));
        }
        return old;
    }
    throw IoError(target.string() + ": cannot move the finished file into place (the target keeps changing)");
}

volatile std::sig_atomic_t deferredSignal = 0;

extern "C" void recordSignal(int sig) {
    deferredSignal = sig;
}

// SIGINT, SIGTERM and SIGHUP wait while alive. Blocking them in this thread is not enough: the kernel
// gives a process-directed signal to any thread that does not block it (OpenCL runtimes keep worker
// threads), so a handler that only records it replaces the default action meanwhile, and the signal is
// raised again, with the old action back, at the end. An ignored signal stays ignored.
class SignalsDeferred {
public:
    SignalsDeferred() {
        deferredSignal = 0;
        sigemptyset(&block_);
        for (std::size_t i = 0; i < kCount; ++i)
            sigaddset(&block_, kSignals[i]);
        pthread_sigmask(SIG_BLOCK, &block_, &savedMask_);
        struct sigaction record {};
        record.sa_handler = recordSignal;
        sigemptyset(&record.sa_mask);
        for (std::size_t i = 0; i < kCount; ++i) {
            struct sigaction current {};
            replaced_[i] = ::sigaction(kSignals[i], nullptr, &current) == 0 &&
                           current.sa_handler != SIG_IGN &&
                           ::sigaction(kSignals[i], &record, &saved_[i]) == 0;
        }
    }
    ~SignalsDeferred() {
        // A signal pending for this thread is taken before the old actions return, so it is raised once.
        const timespec now{0, 0};
        for (int sig; (sig = ::sigtimedwait(&block_, nullptr, &now)) > 0;)
            deferredSignal = sig;
        for (std::size_t i = 0; i < kCount; ++i)
            if (replaced_[i]) ::sigaction(kSignals[i], &saved_[i], nullptr);
        pthread_sigmask(SIG_SETMASK, &savedMask_, nullptr);
        if (deferredSignal != 0) ::raise(deferredSignal);
    }
    SignalsDeferred(const SignalsDeferred&) = delete;
    SignalsDeferred& operator=(const SignalsDeferred&) = delete;

private:
    static constexpr std::size_t kCount = 3;
    static constexpr int kSignals[kCount] = {SIGINT, SIGTERM, SIGHUP};
    sigset_t block_{}, savedMask_{};
    struct sigaction saved_[kCount] {};
    bool replaced_[kCount] = {};
};

// Removes the replaced file's last name at once, so that from here on a kill leaves nothing behind, then
// hands its content (through the open descriptor) to the writer's handler.
void retireOld(const fs::path& old, const std::function<void(const fs::path&)>& onReplaced) {
    if (old.empty()) return;
    const int fd = ::open(old.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK);
    ::unlink(old.c_str());
    if (fd < 0) return;
    struct stat st {};
    if (onReplaced && ::fstat(fd, &st) == 0 && S_ISREG(st.st_mode)) {
        try {
            onReplaced(fs::path("/proc/self/fd") / std::to_string(fd));
        } catch (...) { // the new file is in place; a leftover old data file is not worth failing for
        }
    }
    ::close(fd);
}

} // namespace

fs::path AtomicFile::finish(bool nameUnnamed) {
    if (committed_) throw IoError(target_.string() + ": already committed");
    const std::string writeFailed = target_.string() + ": write failed (disk full or file size limit?)";
    // What the stream put into the file: the temporary must end exactly at its furthest write.
    std::streamoff expected = -1;
    if (stream_) {
        expected = stream_->expectedEnd();
        const bool closed = stream_->buffer.close() != nullptr;
        stream_.reset();
        if (!closed || expected < 0) throw IoError(writeFailed);
    }
    // Data must be on disk before the rename makes it visible, or a crash could expose an empty file.
    const int fd = fd_ >= 0 ? fd_ : ::open(temp_.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) throw IoError(target_.string() + ": temporary file vanished: " + systemError(errno));
    struct stat st {};
    const int statRc = ::fstat(fd, &st);
    const int syncRc = statRc == 0 ? ::fsync(fd) : -1;
    const int syncErr = errno;
    if (fd_ < 0) ::close(fd);
    if (syncRc != 0) throw IoError(target_.string() + ": cannot flush to disk: " + systemError(syncErr));
    if (expected >= 0 && st.st_size != expected)
        throw IoError(target_.string() + ": write failed: " + std::to_string(st.st_size) + " of " +
                      std::to_string(expected) + " bytes reached the disk (disk full?)");
    if (fd_ >= 0 && !nameUnnamed) return temp_;
    fs::path named = fd_ >= 0 ? linkUnnamed(temp_, target_) : temp_;
    if (fd_ >= 0) {
        ::close(fd_);
        fd_ = -1;
        temp_ = named; // the destructor removes it if the move fails
    }
    return named;
}

void AtomicFile::commit() {
    if (activeGroup) {
        // An unnamed temporary stays unnamed (nothing for a kill to leave behind) while the group keeps
        // few descriptors; past that, finished files get their hidden names now.
        const bool keepUnnamed = activeGroup->openDescriptors_ < AtomicCommitGroup::kMaxOpenDescriptors;
        const fs::path finished = finish(!keepUnnamed);
        activeGroup->entries_.push_back({finished, target_, std::move(onReplaced_), fd_});
        if (fd_ >= 0) ++activeGroup->openDescriptors_;
        fd_ = -1; // the group owns the finished file now
        committed_ = true;
        return;
    }
    finish(false);
    if (beforeMoveForTesting) beforeMoveForTesting(target_);
    // SIGINT, SIGTERM and SIGHUP wait until the move and the old file's removal are done, so they never
    // leave a hidden name behind (SIGKILL can, for a few system calls; the next write removes it).
    const SignalsDeferred deferred;
    if (fd_ >= 0) {
        // A new target appears in one step, with no hidden name in between; an existing one is replaced.
        if (linkIfAbsent(temp_, target_)) {
            ::close(fd_);
            fd_ = -1;
            committed_ = true;
            return;
        }
        temp_ = linkUnnamed(temp_, target_); // the destructor removes it if the move fails
        ::close(fd_);
        fd_ = -1;
    }
    const fs::path old = moveKeepingOld(temp_, target_);
    committed_ = true;
    retireOld(old, onReplaced_);
}

namespace {

// A series commit journal: several names cannot be replaced in one POSIX step, so a group whose targets
// share a directory first gives every finished file its hidden name, then records hidden name -> target
// (with the finished file's inode) in `.FIRST.volcl-commit` beside them, then moves. Once the journal is
// on disk the commit is decided: whoever finds it with its writer gone (the directory's flock free) rolls
// it forward. A target whose inode is the journal's is moved; otherwise its hidden file is moved over it.
// The flock on the directory also serialises the move loops of concurrent groups there.

constexpr std::string_view kJournalSuffix = ".volcl-commit";
constexpr std::string_view kJournalMagic = "volcl commit journal 1";
// How long a reader waits for a live writer's moves before refusing.
constexpr std::chrono::seconds kJournalWait{10};

struct JournalEntry {
    std::string hidden, target;
    unsigned long long inode = 0;
};

fs::path journalPathFor(const fs::path& firstTarget) {
    std::string name = tempPrefix(firstTarget); // ".NAME.tmp-" -> ".NAME.volcl-commit"
    name.resize(name.size() - 5);
    name.append(kJournalSuffix);
    return directoryOf(firstTarget) / name;
}

bool isJournalName(const std::string& name) {
    return name.size() > kJournalSuffix.size() + 1 && name.front() == '.' && name.ends_with(kJournalSuffix);
}

// Flushes the directory of `file` (its names); an error names `file`.
void syncDirectoryOf(const fs::path& file) {
    const fs::path dir = directoryOf(file);
    const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0)
        throw IoError(file.string() + ": cannot open its directory " + dir.string() + ": " +
                      systemError(errno));
    const int rc = ::fsync(fd);
    const int err = errno;
    ::close(fd);
    if (rc != 0 && err != EINVAL)
        throw IoError(file.string() + ": cannot flush its directory " + dir.string() + ": " +
                      systemError(err));
}

// An exclusive flock on a directory, released by close (and by the kernel when its holder dies).
class DirectoryLock {
public:
    explicit DirectoryLock(const fs::path& dir)
        : fd_(::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC)) {
        if (fd_ < 0) throw IoError(dir.string() + ": cannot open the directory: " + systemError(errno));
    }
    ~DirectoryLock() { ::close(fd_); }
    DirectoryLock(const DirectoryLock&) = delete;
    DirectoryLock& operator=(const DirectoryLock&) = delete;
    void wait() {
        while (::flock(fd_, LOCK_EX) != 0)
            if (errno != EINTR) throw IoError("cannot lock a directory: " + systemError(errno));
    }
    bool waitFor(std::chrono::milliseconds limit) {
        const auto end = std::chrono::steady_clock::now() + limit;
        for (;;) {
            if (::flock(fd_, LOCK_EX | LOCK_NB) == 0) return true;
            if (errno != EWOULDBLOCK && errno != EINTR)
                throw IoError("cannot lock a directory: " + systemError(errno));
            if (std::chrono::steady_clock::now() >= end) return false;
            std::this_thread::sleep_for(std::chrono::milliseconds(5));
        }
    }

private:
    int fd_;
};

// Reads a journal's writer PID and entries; false when it is gone or not a journal.
bool readJournal(const fs::path& journal, std::vector<JournalEntry>& entries, long& pid) {
    std::error_code ec;
    if (!fs::is_regular_file(journal, ec)) return false;
    std::string text;
    try {
        const std::vector<std::byte> bytes = readFileBytes(journal);
        text.assign(reinterpret_cast<const char*>(bytes.data()), bytes.size());
    } catch (const IoError&) {
        return false;
    }
    std::istringstream in(text);
    std::string line;
    if (!std::getline(in, line) || line != kJournalMagic) return false;
    if (!std::getline(in, line) || !line.starts_with("pid ")) return false;
    pid = std::atol(line.c_str() + 4);
    entries.clear();
    while (std::getline(in, line)) {
        const std::size_t a = line.find('\t'), b = line.find('\t', a == std::string::npos ? a : a + 1);
        if (a == std::string::npos || b == std::string::npos) return false;
        JournalEntry e;
        e.inode = std::strtoull(line.c_str(), nullptr, 10);
        e.hidden = line.substr(a + 1, b - a - 1);
        e.target = line.substr(b + 1);
        if (e.hidden.empty() || e.target.empty()) return false;
        entries.push_back(std::move(e));
    }
    return true;
}

unsigned long long inodeOf(const fs::path& path) {
    struct stat st {};
    return ::lstat(path.c_str(), &st) == 0 ? static_cast<unsigned long long>(st.st_ino) : 0;
}

// Rolls a journal forward (its writer is gone: the caller holds the directory's lock) and removes it.
void completeJournal(const fs::path& journal) {
    const fs::path dir = directoryOf(journal);
    std::vector<JournalEntry> entries;
    long pid = 0;
    if (!readJournal(journal, entries, pid)) {
        std::error_code ec;
        if (fs::exists(journal, ec))
            throw IoError(journal.string() + ": not a volcl commit journal; remove it by hand");
        return;
    }
    for (const JournalEntry& e : entries) {
        const fs::path hidden = dir / e.hidden, target = dir / e.target;
        if (inodeOf(target) == e.inode) {
            ::unlink(hidden.c_str()); // moved: a hidden file left is the file it replaced
            continue;
        }
        if (inodeOf(hidden) != e.inode) continue; // neither: something newer owns the name
        if (::rename(hidden.c_str(), target.c_str()) != 0)
            throw IoError(target.string() + ": cannot complete the interrupted volcl commit " +
                          journal.string() + ": " + systemError(errno));
    }
    syncDirectoryOf(journal);
    if (::unlink(journal.c_str()) != 0 && errno != ENOENT)
        throw IoError(journal.string() +
                      ": cannot remove the completed commit journal: " + systemError(errno));
    syncDirectoryOf(journal);
}

// Completes every journal in `dir` (the caller holds its lock, so their writers are gone).
void completeJournalsIn(const fs::path& dir) {
    std::error_code ec;
    std::vector<fs::path> journals;
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec))
        if (isJournalName(it->path().filename().string())) journals.push_back(it->path());
    for (const fs::path& j : journals)
        completeJournal(j);
}

// Writes the journal atomically (unique temporary, fsync, rename) and flushes the directory.
void writeJournal(const fs::path& journal, const std::vector<JournalEntry>& entries) {
    std::string text(kJournalMagic);
    text.append("\npid ").append(std::to_string(::getpid())).append("\n");
    for (const JournalEntry& e : entries)
        text.append(std::to_string(e.inode))
            .append("\t")
            .append(e.hidden)
            .append("\t")
            .append(e.target)
            .append("\n");
    const fs::path temp = createUniqueTemp(journal);
    const int fd = ::open(temp.c_str(), O_WRONLY | O_CLOEXEC);
    bool ok = fd >= 0;
    std::size_t done = 0;
    while (ok && done < text.size()) {
        const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
        if (n < 0 && errno == EINTR) continue;
        ok = n > 0;
        if (ok) done += static_cast<std::size_t>(n);
    }
    int err = errno;
    if (ok && ::fsync(fd) != 0) {
        ok = false;
        err = errno;
    }
    if (fd >= 0 && ::close(fd) != 0 && ok) {
        ok = false;
        err = errno;
    }
    if (ok && ::rename(temp.c_str(), journal.c_str()) != 0) {
        ok = false;
        err = errno;
    }
    if (!ok) {
        ::unlink(temp.c_str());
        throw IoError(journal.string() + ": cannot write the commit journal: " + systemError(err));
    }
    syncDirectoryOf(journal);
}

} // namespace

AtomicCommitGroup::AtomicCommitGroup() : outer_(activeGroup) {
    activeGroup = this;
}

AtomicCommitGroup::~AtomicCommitGroup() {
    if (activeGroup == this) activeGroup = outer_;
    for (const Entry& e : entries_) {
        if (e.fd >= 0)
            ::close(e.fd); // an unnamed file vanishes with its descriptor
        else if (!committed_)
            ::unlink(e.finished.c_str());
    }
}

namespace {

// Completes the journals in `dir` once their writers are gone, when one names `name` (any, when null):
// waits up to kJournalWait for a live one's lock, then throws IoError naming `what`.
void completeJournalsNaming(const fs::path& dir, const std::string* name, const fs::path& what) {
    std::error_code ec;
    long pid = 0;
    bool found = false;
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end && !found; it.increment(ec)) {
        if (!isJournalName(it->path().filename().string())) continue;
        std::vector<JournalEntry> entries;
        if (!readJournal(it->path(), entries, pid)) continue;
        found = !name || std::any_of(entries.begin(), entries.end(),
                                     [&](const JournalEntry& e) { return e.target == *name; });
    }
    if (!found) return;
    DirectoryLock lock(dir);
    if (!lock.waitFor(kJournalWait))
        throw IoError(what.string() + ": volcl process " + std::to_string(pid) +
                      " is still moving a series into place there; try again when it ends");
    completeJournalsIn(dir);
}

} // namespace

void completeInterruptedCommit(const fs::path& file) {
    const std::string name = file.filename().string();
    completeJournalsNaming(directoryOf(file), &name, file);
}

void completeInterruptedCommitsIn(const fs::path& dir) {
    const fs::path where = dir.empty() ? fs::path(".") : dir;
    completeJournalsNaming(where, nullptr, where);
}

void AtomicCommitGroup::commit() {
    if (activeGroup == this) activeGroup = outer_;
    if (committed_) throw IoError("output files already committed");
    // Several targets in one directory go through a journal (see completeJournal); a single file, targets
    // in several directories or names a journal line cannot hold are moved in order without one.
    bool journaled = entries_.size() > 1;
    for (const Entry& e : entries_) {
        const std::string n = e.target.filename().string();
        journaled = journaled && directoryOf(e.target) == directoryOf(entries_.front().target) &&
                    n.find_first_of("\t\n") == std::string::npos;
    }
    std::optional<DirectoryLock> lock;
    if (journaled) {
        // Another group's move loop in this directory finishes first (the last commit wins as a whole),
        // and a journal left by a dead one is completed before this one's.
        lock.emplace(directoryOf(entries_.front().target));
        lock->wait();
        completeJournalsIn(directoryOf(entries_.front().target));
        removeStaleTemporaries(journalPathFor(entries_.front().target)); // a dead writer's unfinished journal
    }
    // A terminal's Ctrl-C or a supervisor's SIGTERM during the moves would leave a mix of new and old
    // targets: they wait until every move is done (or undone).
    const SignalsDeferred deferred;
    std::vector<fs::path> olds;
    const fs::path journal = journaled ? journalPathFor(entries_.front().target) : fs::path();
    bool journalWritten = false;
    try {
        if (journaled) {
            // (a) every finished file gets its hidden name, (b) the journal records them: from here on
            // a kill is rolled forward by the next volcl command that touches the series.
            std::vector<JournalEntry> lines;
            for (Entry& e : entries_) {
                if (e.fd >= 0) {
                    e.finished = linkUnnamed(e.finished, e.target);
                    ::close(e.fd);
                    e.fd = -1;
                }
                lines.push_back(
                    {e.finished.filename().string(), e.target.filename().string(), inodeOf(e.finished)});
            }
            syncDirectoryOf(entries_.front().target);
            writeJournal(journal, lines);
            journalWritten = true;
        }
        for (Entry& e : entries_) {
            if (AtomicFile::beforeMoveForTesting) AtomicFile::beforeMoveForTesting(e.target);
            if (e.fd >= 0) {
                const bool linked = linkIfAbsent(e.finished, e.target);
                if (!linked) e.finished = linkUnnamed(e.finished, e.target);
                ::close(e.fd);
                e.fd = -1;
                if (linked) {
                    olds.emplace_back(); // nothing replaced: undoing removes the target
                    continue;
                }
            }
            olds.push_back(moveKeepingOld(e.finished, e.target));
        }
    } catch (...) {
        // Undo in reverse: an old file goes back over its target, a target that did not exist goes. With
        // a journal the new file goes back to its hidden name, so a kill here still rolls forward whole.
        for (std::size_t i = olds.size(); i-- > 0;) {
            const Entry& e = entries_[i];
            if (journalWritten) {
                if (!olds[i].empty() &&
                    ::renameat2(AT_FDCWD, olds[i].c_str(), AT_FDCWD, e.target.c_str(), RENAME_EXCHANGE) == 0)
                    continue;
                if (olds[i].empty() && ::renameat2(AT_FDCWD, e.target.c_str(), AT_FDCWD, e.finished.c_str(),
                                                   RENAME_NOREPLACE) == 0)
                    continue;
            }
            if (!olds[i].empty())
                ::rename(olds[i].c_str(), e.target.c_str());
            else
                ::unlink(e.target.c_str());
        }
        if (journaled) { // ours: the lock keeps other groups out
            ::unlink(journal.c_str());
            try {
                syncDirectoryOf(journal);
            } catch (const IoError&) {
            }
        }
        for (const Entry& e : entries_) {
            if (e.fd >= 0) continue; // the destructor closes it
            ::unlink(e.finished.c_str());
        }
        committed_ = true; // nothing left to remove
        throw;
    }
    committed_ = true;
    for (std::size_t i = 0; i < entries_.size(); ++i)
        retireOld(olds[i], entries_[i].onReplaced);
    if (journalWritten) {
        // (d) the replaced files are gone before the journal: a kill before this line is still completed.
        // The moves are done, so the flushes are best effort: a journal that a lost unlink brings back
        // after a crash names frames already in place, and completing it changes nothing.
        try {
            syncDirectoryOf(journal);
            ::unlink(journal.c_str());
            syncDirectoryOf(journal);
        } catch (const IoError&) {
            ::unlink(journal.c_str());
        }
    }
}

std::string nonRegularKind(const fs::path& path) {
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0) return {};
    return kindOf(st.st_mode);
}

void requireRegularFile(const fs::path& path) {
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0) {
        if (errno == ENOENT) throw IoError(path.string() + ": file does not exist");
        throw IoError(path.string() + ": cannot read: " + systemError(errno));
    }
    const std::string kind = kindOf(st.st_mode);
    if (!kind.empty()) throw IoError(path.string() + ": is " + kind + ", not a regular file");
}

std::vector<std::byte> readFileBytes(const fs::path& path) {
    // O_NONBLOCK: opening a FIFO must not wait for a writer; fstat then refuses it (and devices,
    // directories) before the first read, which would block or never end.
    const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) {
        if (errno == ENOENT) throw IoError(path.string() + ": file does not exist");
        if (errno == EISDIR) throw IoError(path.string() + ": is a directory, not a regular file");
        throw IoError(path.string() + ": cannot open for reading: " + systemError(errno));
    }
    struct Closer {
        int fd;
        ~Closer() { ::close(fd); }
    } closer{fd};
    struct stat st {};
    if (::fstat(fd, &st) != 0) throw IoError(path.string() + ": cannot read: " + systemError(errno));
    const std::string kind = kindOf(st.st_mode);
    if (!kind.empty()) throw IoError(path.string() + ": is " + kind + ", not a regular file");
    const auto size = static_cast<std::size_t>(st.st_size);
    std::vector<std::byte> bytes(size);
    std::size_t done = 0;
    while (done < size) {
        const ssize_t n = ::read(fd, bytes.data() + done, size - done);
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) throw IoError(path.string() + ": read error: " + systemError(errno));
        if (n == 0) throw IoError(path.string() + ": read error (file changed while reading?)");
        done += static_cast<std::size_t>(n);
    }
    return bytes;
}

void checkNotSameFile(const fs::path& input, const fs::path& output) {
    std::error_code ec;
    bool same = false;
    if (fs::exists(output, ec) && fs::exists(input, ec)) {
        same = fs::equivalent(input, output, ec);
    } else {
        const fs::path a = fs::weakly_canonical(input, ec);
        const fs::path b = fs::weakly_canonical(output, ec);
        same = !ec && a == b;
    }
    if (same) throw UsageError("output " + output.string() + " is the same file as input " + input.string());
}

void checkNotSameFile(const std::vector<fs::path>& inputs, const std::vector<fs::path>& outputs) {
    for (const fs::path& in : inputs)
        for (const fs::path& out : outputs)
            checkNotSameFile(in, out);
}

} // namespace volcl
