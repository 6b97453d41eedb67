// Atomic file output: data goes to a temporary beside the target and is moved into place on commit.
#pragma once

#include <cstddef>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <ostream>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace volcl {

/// Writes a file so that readers never see a partial result: a failed or interrupted run leaves the
/// target untouched. On Linux the temporary is an unnamed file (O_TMPFILE) in the target's directory,
/// linked into place on commit, so even SIGKILL leaves nothing behind; where the file system refuses
/// O_TMPFILE it is a hidden `.NAME.tmp-PID-...` file, and the temporaries of dead processes for the same
/// target are removed when the next AtomicFile for it starts. Example:
/// ```
/// volcl::AtomicFile out("table.exr");
/// writeSomething(out.tempPath());   // or out.stream() << ...
/// out.commit();                     // rename into place; without it the temporary is removed
/// ```
class AtomicFile {
public:
    /// Refuses (IoError) when the target's directory does not exist (checkOutputPath()).
    explicit AtomicFile(std::filesystem::path target);
    ~AtomicFile(); // removes the temporary unless committed; never throws
    AtomicFile(const AtomicFile&) = delete;
    AtomicFile& operator=(const AtomicFile&) = delete;

    /// A path that opens the temporary (for libraries that write to a path): `/proc/self/fd/N` for an
    /// unnamed temporary, else the hidden file's name.
    const std::filesystem::path& tempPath() const noexcept { return temp_; }
    /// True when the temporary has no name in the directory (O_TMPFILE).
    bool unnamedTemporary() const noexcept { return fd_ >= 0; }
    const std::filesystem::path& target() const noexcept { return target_; }
    /// Binary stream on the temporary file (opened on first use). A writer may seek back to patch what it
    /// wrote (a header, an index): commit() checks the file against the furthest position written.
    std::ostream& stream();
    /// Appends bytes. Blocks of kDirectWriteMinBytes or more bypass the page cache (below).
    void write(std::span<const std::byte> bytes);
    void write(std::string_view text);
    /// Flushes, checks for write errors and that the temporary ends where the stream's furthest write ended,
    /// fsyncs, and moves it over the target. Throws IoError on failure (the target is then unchanged).
    /// Inside an AtomicCommitGroup of this thread the move waits for the group's commit.
    void commit();
    /// Called after the commit replaced an existing regular file, with a path that still opens the
    /// replaced file (removed right after the call). The `.nhdr` writer reads the old header there to
    /// remove the data file it named. The handler must not throw.
    void onReplaced(std::function<void(const std::filesystem::path& oldCopy)> handler) {
        onReplaced_ = std::move(handler);
    }

    /// Writes of at least this many bytes go to the disk with O_DIRECT, through an aligned bounce buffer,
    /// where the file system allows it. A one-shot `volcl decode` writes its whole volume at once; through
    /// the page cache that meant allocating and filling fresh cache pages and then flushing them in the
    /// commit's fsync (35 MB: 33-166 ms, typically 100 ms, in the test VM), directly 18-33 ms.
    static constexpr std::size_t kDirectWriteMinBytes = std::size_t(1) << 20;

    /// Test hook, null in production: called with the target right before each finished file moves into
    /// place, so a kill trial can stop a writer exactly at its commit point.
    static inline void (*beforeMoveForTesting)(const std::filesystem::path& target) = nullptr;

private:
    /// Writes the part of `bytes` that direct I/O can take at the stream's position; returns the rest
    /// (all of it where O_DIRECT is refused), which the stream writes.
    std::span<const std::byte> writeDirect(std::span<const std::byte> bytes);
    /// Everything of commit() but the move: checks, fsync, and a hidden name beside the target. Returns it.
    /// With `nameUnnamed` false an unnamed temporary keeps its /proc path (and its descriptor).
    std::filesystem::path finish(bool nameUnnamed);

    struct TrackedStream; ///< the stream on the temporary and the furthest position written through it
    std::filesystem::path target_, temp_;
    std::function<void(const std::filesystem::path&)> onReplaced_;
    std::unique_ptr<TrackedStream> stream_;
    int fd_ = -1; ///< the O_TMPFILE descriptor, -1 for a named temporary
    bool committed_ = false;
};

/// Makes the commits of several AtomicFiles one step (a series written as `t_%02d.nii`): while a group
/// is alive on a thread, AtomicFile::commit() there finishes its temporary (write checks, fsync) but moves
/// nothing, and an unnamed temporary stays unnamed (the first kMaxOpenDescriptors of them: later ones get a
/// hidden `.NAME.tmp-PID-...` name); commit() then names them and moves every file into place in order with
/// SIGINT, SIGTERM and SIGHUP deferred (recorded whichever thread gets them, raised after the last
/// move). A failed move puts back what the moves before it replaced (old files are kept under hidden
/// names until the end); a group destroyed without commit() removes every finished temporary, so a
/// failure before the moves leaves nothing. Several targets in one directory are committed through a
/// journal under an flock of the directory (concurrent groups there commit one after the other): every
/// finished file gets its hidden name, `.FIRST.volcl-commit` records hidden name -> target, then the
/// moves run. SIGKILL (or a crash) during them leaves the journal, and the next AtomicFile or volume
/// reader of any of those targets (completeInterruptedCommit) rolls the whole series forward; until then
/// other programs can see a mix of new and old targets.
class AtomicCommitGroup {
public:
    AtomicCommitGroup();
    ~AtomicCommitGroup(); // never throws
    AtomicCommitGroup(const AtomicCommitGroup&) = delete;
    AtomicCommitGroup& operator=(const AtomicCommitGroup&) = delete;
    /// Moves every finished file into place, all or none. Throws IoError naming the target that failed.
    void commit();

private:
    friend class AtomicFile;
    struct Entry {
        std::filesystem::path finished, target;
        std::function<void(const std::filesystem::path&)> onReplaced;
        int fd = -1; ///< an unnamed finished file's descriptor (finished is its /proc path)
    };
    /// Unnamed finished files kept open at most; later ones get their hidden names at once.
    static constexpr std::size_t kMaxOpenDescriptors = 256;
    std::vector<Entry> entries_;
    std::size_t openDescriptors_ = 0;
    AtomicCommitGroup* outer_ = nullptr; ///< the group this one hides while alive
    bool committed_ = false;
};

/// Completes a series commit that a killed volcl left half done, when a commit journal in `file`'s
/// directory names `file` as one of its targets (AtomicCommitGroup: a volcl reader never sees a mixed
/// series). Waits up to 10 s for a live writer's moves, then throws IoError naming `file`; also throws
/// when the journal cannot be completed (a read-only directory). Every AtomicFile and every volume reader
/// calls it first; without a journal in the directory it only lists the directory.
void completeInterruptedCommit(const std::filesystem::path& file);
/// Same for every journal in `dir`: a glob over a series there then lists its complete frames.
void completeInterruptedCommitsIn(const std::filesystem::path& dir);
/// Whole file as bytes; throws IoError naming the file when it cannot be read or is not a regular file
/// (a FIFO, device or directory is refused before any read, without blocking).
std::vector<std::byte> readFileBytes(const std::filesystem::path& path);
/// What AtomicFile(target) refuses, checked without creating anything, so a command can refuse a bad output
/// before any work: an empty path, a missing or unwritable directory, an existing target that is not a
/// regular file. Throws IoError naming the path.
void checkOutputPath(const std::filesystem::path& target);
/// Throws IoError naming the file when it does not exist or is not a regular file (FIFO, device,
/// directory, socket). Uses stat, so a FIFO never blocks. Every reader's input passes this check.
void requireRegularFile(const std::filesystem::path& path);
/// "a FIFO", "a directory", ... when `path` exists and is not a regular file; empty otherwise.
std::string nonRegularKind(const std::filesystem::path& path);
/// Refuses to write output over one of the inputs (compares canonical paths). Throws UsageError.
void checkNotSameFile(const std::filesystem::path& input, const std::filesystem::path& output);
/// Same for every file of an input (a header and its data files) against every file of an output.
void checkNotSameFile(const std::vector<std::filesystem::path>& inputs,
                      const std::vector<std::filesystem::path>& outputs);

} // namespace volcl
