// Atomic output: no partial target and no temporary after a failed, killed or size-limited write.
#include "TestUtil.hpp"
#include "core/AtomicFile.hpp"
#include "core/Error.hpp"
#include "host/io/VolumeIo.hpp"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cmath>
#include <csignal>
#include <cstring>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

namespace {

namespace fs = std::filesystem;
using namespace volcl;
using test::listing;
using test::readFile;
using test::writeFile;

TEST(AtomicFile, NoFileWithoutCommitAndOldContentKept) {
    const fs::path dir = test::tempDir("io-atomic");
    {
        AtomicFile f(dir / "out.bin");
        f.write(std::string_view("partial"));
        EXPECT_TRUE(fs::exists(f.tempPath()));
        // An unnamed temporary (O_TMPFILE) is invisible in the directory; a named one lives beside the target.
        if (f.unnamedTemporary())
            EXPECT_TRUE(listing(dir).empty());
        else
            EXPECT_EQ(f.tempPath().parent_path(), dir);
    }
    EXPECT_TRUE(listing(dir).empty());
    writeFile(dir / "out.bin", "old");
    try {
        AtomicFile f(dir / "out.bin");
        f.write(std::string_view("new but failing"));
        throw std::runtime_error("simulated failure before commit");
    } catch (const std::runtime_error&) {
    }
    EXPECT_EQ(readFile(dir / "out.bin"), "old");
    EXPECT_EQ(listing(dir), (std::set<std::string>{"out.bin"}));
    {
        AtomicFile f(dir / "out.bin");
        f.stream() << "new";
        f.commit();
        EXPECT_THROW(f.commit(), IoError);
    }
    EXPECT_EQ(readFile(dir / "out.bin"), "new");
    EXPECT_EQ(listing(dir), (std::set<std::string>{"out.bin"}));
}

// A writer killed with SIGKILL in the middle of a large write: the directory must hold no temporary.
TEST(AtomicFile, SigkillMidWriteLeavesNoTemporary) {
    const fs::path dir = test::tempDir("io-atomic-kill");
    for (int round = 0; round < 3; ++round) {
        int ready[2];
        ASSERT_EQ(::pipe(ready), 0);
        const pid_t child = ::fork();
        ASSERT_GE(child, 0);
        if (child == 0) {
            ::close(ready[0]);
            AtomicFile f(dir / "big.bin");
            const std::vector<std::byte> chunk(1 << 20, std::byte{0x5a});
            for (int i = 0; i < 128; ++i) {
                f.write(chunk);
                f.stream().flush();
                if (i == 8) {
                    const char c = 'x';
                    if (::write(ready[1], &c, 1) != 1) ::_exit(3);
                }
            }
            f.commit();
            ::_exit(0);
        }
        ::close(ready[1]);
        char c = 0;
        ASSERT_EQ(::read(ready[0], &c, 1), 1); // 9 MB are written: the child is mid-write
        ::close(ready[0]);
        ::kill(child, SIGKILL);
        int status = 0;
        ::waitpid(child, &status, 0);
        ASSERT_TRUE(WIFSIGNALED(status));
        EXPECT_TRUE(listing(dir).empty()) << "a killed writer left a temporary";
    }
}

// Where O_TMPFILE is unavailable the temporary has a name; a dead writer's one is removed at the next start.
TEST(AtomicFile, StaleTemporariesOfDeadWritersAreRemoved) {
    const fs::path dir = test::tempDir("io-atomic-stale");
    const pid_t dead = ::fork();
    ASSERT_GE(dead, 0);
    if (dead == 0) ::_exit(0);
    ::waitpid(dead, nullptr, 0);
    const std::string stale = ".out.bin.tmp-" + std::to_string(dead) + "-0-123";
    const std::string live = ".out.bin.tmp-" + std::to_string(::getppid()) + "-0-456"; // a live process
    const std::string other = ".other.bin.tmp-" + std::to_string(dead) + "-0-789";     // another target's
    for (const std::string& n : {stale, live, other})
        writeFile(dir / n, "left over");
    {
        AtomicFile f(dir / "out.bin");
        f.write(std::string_view("new"));
        f.commit();
    }
    EXPECT_EQ(listing(dir), (std::set<std::string>{"out.bin", live, other}));
}

TEST(AtomicFile, TemporariesAreUniqueAndErrorsAreClear) {
    const fs::path dir = test::tempDir("io-atomic2");
    AtomicFile a(dir / "x"), b(dir / "x");
    EXPECT_NE(a.tempPath(), b.tempPath());
    EXPECT_THROW(AtomicFile{dir / "missing" / "x"}, IoError);
    EXPECT_THROW(AtomicFile{dir}, IoError); // a directory is not a file target
    // Nor a FIFO or a device: the commit's rename replaced them by a regular file.
    ASSERT_EQ(::mkfifo((dir / "fifo").c_str(), 0600), 0);
    EXPECT_THROW(AtomicFile{dir / "fifo"}, IoError);
    EXPECT_THROW(AtomicFile{"/dev/null"}, IoError);
    EXPECT_TRUE(fs::is_fifo(dir / "fifo"));
    EXPECT_THROW(requireRegularFile(dir / "fifo"), IoError);
    EXPECT_THROW(requireRegularFile("/dev/zero"), IoError);
    EXPECT_THROW(readFileBytes(dir / "nothing"), IoError);
    EXPECT_THROW(readFileBytes(dir), IoError);
    writeFile(dir / "in.raw", "abc");
    EXPECT_THROW(checkNotSameFile(dir / "in.raw", dir / "." / "in.raw"), UsageError);
    EXPECT_NO_THROW(checkNotSameFile(dir / "in.raw", dir / "out.raw"));
    const auto bytes = readFileBytes(dir / "in.raw");
    ASSERT_EQ(bytes.size(), 3u);
    EXPECT_EQ(bytes[2], std::byte{'c'});
}

// The temporary once repeated the whole target name: a target of 234-255 bytes failed at the commit (its
// hidden temporary name went over NAME_MAX). Two long names that differ only at the end both commit.
TEST(AtomicFile, TargetNamesOf255BytesCommit) {
    const fs::path dir = test::tempDir("io-atomic-long");
    const std::string first = std::string(251, 'n') + ".one", second = std::string(251, 'n') + ".two";
    ASSERT_EQ(first.size(), 255u);
    {
        AtomicFile a(dir / first), b(dir / second);
        EXPECT_NE(a.tempPath(), b.tempPath());
        a.write(std::string_view("first"));
        b.write(std::string_view("second"));
        a.commit();
        b.commit();
    }
    EXPECT_EQ(readFile(dir / first), "first");
    EXPECT_EQ(readFile(dir / second), "second");
    EXPECT_EQ(listing(dir), (std::set<std::string>{first, second}));
}

TEST(AtomicFile, FailedVolumeWriteLeavesNothing) {
    // A real mid-write failure: the file-size limit makes the write fail with EFBIG after the first
    // kilobyte. The old target must survive untouched and no temporary may remain.
    const fs::path dir = test::tempDir("io-atomic3");
    writeFile(dir / "keep.nrrd", "previous");
    const Volume v = test::makeFloatVolume(
        {64, 64, 16}, [](double i, double j, double k) { return std::sin(i) + 0.5 * j - k; });
    struct rlimit old {};
    ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &old), 0);
    const auto oldHandler = std::signal(SIGXFSZ, SIG_IGN);
    struct rlimit small = old;
    small.rlim_cur = 1024;
    ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &small), 0);
    EXPECT_THROW(writeVolumeFile(v, dir / "keep.nrrd", {Endian::Little, false}), IoError);
    EXPECT_THROW(writeVolumeFile(v, dir / "new_64x64x16_float32.raw"), IoError);
    ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &old), 0);
    std::signal(SIGXFSZ, oldHandler);
    EXPECT_EQ(readFile(dir / "keep.nrrd"), "previous");
    EXPECT_EQ(listing(dir), (std::set<std::string>{"keep.nrrd"}));
    // With the limit lifted the same write succeeds and replaces the file completely.
    writeVolumeFile(v, dir / "keep.nrrd");
    EXPECT_EQ(readVolume(dir / "keep.nrrd"), v);
    EXPECT_EQ(listing(dir), (std::set<std::string>{"keep.nrrd"}));
}

} // namespace

namespace {

// Bytes no two offsets share within a period that is not a power of two, so a block written to the wrong
// place shows.
std::vector<std::byte> patternBytes(std::size_t n) {
    std::vector<std::byte> b(n);
    for (std::size_t i = 0; i < n; ++i)
        b[i] = static_cast<std::byte>((i * 2654435761u >> 13) ^ (i / 4093));
    return b;
}

} // namespace

TEST(AtomicFile, LargeWritesAtAnyOffsetKeepEveryByte) {
    // Blocks from kDirectWriteMinBytes up bypass the page cache with aligned requests: a header before them
    // (an unaligned start), an odd length and text after them must still land byte for byte.
    const fs::path dir = test::tempDir("io-atomic-direct");
    const std::vector<std::byte> big = patternBytes(3 * AtomicFile::kDirectWriteMinBytes + 4093);
    const std::vector<std::byte> aligned = patternBytes(AtomicFile::kDirectWriteMinBytes);
    for (const std::string_view header :
         {std::string_view(""), std::string_view("NRRD0004\n"), std::string_view("x")}) {
        {
            AtomicFile f(dir / "out.bin");
            f.write(header);
            f.write(big);
            f.write(std::string_view("tail"));
            f.write(aligned);
            f.commit();
        }
        const std::vector<std::byte> got = readFileBytes(dir / "out.bin");
        std::vector<std::byte> want(reinterpret_cast<const std::byte*>(header.data()),
                                    reinterpret_cast<const std::byte*>(header.data() + header.size()));
        want.insert(want.end(), big.begin(), big.end());
        for (const char c : std::string_view("tail"))
            want.push_back(static_cast<std::byte>(c));
        want.insert(want.end(), aligned.begin(), aligned.end());
        ASSERT_EQ(got.size(), want.size()) << "header of " << header.size() << " bytes";
        EXPECT_TRUE(got == want) << "header of " << header.size() << " bytes";
        EXPECT_EQ(listing(dir), (std::set<std::string>{"out.bin"}));
    }
}

TEST(AtomicFile, FileSizeLimitInALargeWriteLeavesNothing) {
    // The limit falls inside the direct-I/O part of a large block (a short write there), then inside its
    // first aligned request: both end in IoError with the old target intact and no temporary.
    const fs::path dir = test::tempDir("io-atomic-direct-limit");
    writeFile(dir / "keep.bin", "previous");
    const std::vector<std::byte> big = patternBytes(3 * AtomicFile::kDirectWriteMinBytes);
    struct rlimit old {};
    ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &old), 0);
    const auto oldHandler = std::signal(SIGXFSZ, SIG_IGN);
    for (const rlim_t limit : {rlim_t(AtomicFile::kDirectWriteMinBytes * 3 / 2 + 7), rlim_t(100)}) {
        struct rlimit small = old;
        small.rlim_cur = limit;
        ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &small), 0);
        bool refused = false;
        try {
            AtomicFile f(dir / "keep.bin");
            f.write(std::string_view("hdr"));
            f.write(big);
            f.commit();
        } catch (const IoError& e) {
            refused = std::string(e.what()).find("keep.bin") != std::string::npos;
        }
        ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &old), 0);
        EXPECT_TRUE(refused) << "limit " << limit;
        EXPECT_EQ(readFile(dir / "keep.bin"), "previous");
        EXPECT_EQ(listing(dir), (std::set<std::string>{"keep.bin"}));
    }
    std::signal(SIGXFSZ, oldHandler);
}

namespace {

// What a reader of a detached header finds, checked without volcl's reader: the header's z size and data
// file name, and whether the data file holds exactly that volume of writer `z - 10`'s value (z - 9).
struct NhdrPair {
    bool consistent = false;
    std::size_t z = 0;
    std::string dataFile, why;
};

NhdrPair readNhdrPair(const fs::path& header) {
    NhdrPair p;
    const std::string text = readFile(header);
    const std::size_t sizes = text.find("sizes: 16 16 "), data = text.find("data file: ");
    if (sizes == std::string::npos || data == std::string::npos) {
        p.why = "header without sizes or data file: " + text;
        return p;
    }
    p.z = std::stoul(text.substr(sizes + 13));
    p.dataFile = text.substr(data + 11, text.find('\n', data) - data - 11);
    const std::string bytes = readFile(header.parent_path() / p.dataFile);
    p.consistent = bytes == std::string(256 * p.z, static_cast<char>(p.z - 9));
    if (!p.consistent)
        p.why = "header of z " + std::to_string(p.z) + " over " + std::to_string(bytes.size()) +
                " bytes of " + (bytes.empty() ? std::string("nothing") : std::to_string(int(bytes[0])));
    return p;
}

Volume nhdrWriterVolume(int writer) {
    Volume v({16, 16, std::size_t(10 + writer)}, ScalarType::UInt8);
    for (auto& x : v.values<std::uint8_t>())
        x = static_cast<std::uint8_t>(writer + 1);
    return v;
}

} // namespace

// Four processes write one .nhdr at once, 60 times: the header and the data file it names always belong to
// the same writer (before unique data names, the shared t.raw gave a mixed pair in about a third of the
// rounds), and the old rounds' data files are gone.
TEST(AtomicFile, ConcurrentNhdrWritersNeverLeaveAMixedPair) {
    const fs::path dir = test::tempDir("io-atomic-nhdr-race");
    int mixed = 0;
    for (int round = 0; round < 60; ++round) {
        std::vector<pid_t> writers;
        for (int w = 0; w < 4; ++w) {
            const pid_t child = ::fork();
            ASSERT_GE(child, 0);
            if (child == 0) {
                try {
                    writeVolumeFile(nhdrWriterVolume(w), dir / "t.nhdr");
                } catch (...) {
                    ::_exit(1);
                }
                ::_exit(0);
            }
            writers.push_back(child);
        }
        for (const pid_t child : writers) {
            int status = 0;
            ::waitpid(child, &status, 0);
            EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "a writer failed";
        }
        const NhdrPair p = readNhdrPair(dir / "t.nhdr");
        if (!p.consistent) {
            ++mixed;
            ADD_FAILURE() << "round " << round << ": " << p.why;
        }
        EXPECT_EQ(listing(dir), (std::set<std::string>{"t.nhdr", p.dataFile})) << "round " << round;
    }
    EXPECT_EQ(mixed, 0);
}

namespace {

int movesBeforeKill = 0;

void killAtMove(const fs::path&) {
    if (--movesBeforeKill == 0) ::raise(SIGKILL);
}

} // namespace

// A writer killed at each move of a .nhdr commit (the data file's, then the header's): the header in place
// still names complete data of the same writer, and the next write removes what the dead one left.
TEST(AtomicFile, NhdrWriterKilledAtEitherMoveKeepsTheOldPair) {
    const fs::path dir = test::tempDir("io-atomic-nhdr-kill");
    for (int killAt = 1; killAt <= 2; ++killAt) {
        writeVolumeFile(nhdrWriterVolume(0), dir / "t.nhdr");
        const pid_t child = ::fork();
        ASSERT_GE(child, 0);
        if (child == 0) {
            movesBeforeKill = killAt;
            AtomicFile::beforeMoveForTesting = killAtMove;
            writeVolumeFile(nhdrWriterVolume(1), dir / "t.nhdr");
            ::_exit(0);
        }
        int status = 0;
        ::waitpid(child, &status, 0);
        ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL) << "kill at move " << killAt;
        const NhdrPair p = readNhdrPair(dir / "t.nhdr");
        EXPECT_TRUE(p.consistent) << "kill at move " << killAt << ": " << p.why;
        EXPECT_EQ(p.z, 10u) << "kill at move " << killAt;
        // The next writer finds the dead one's data file (and its own old pair) and removes them.
        writeVolumeFile(nhdrWriterVolume(2), dir / "t.nhdr");
        const NhdrPair next = readNhdrPair(dir / "t.nhdr");
        EXPECT_TRUE(next.consistent && next.z == 12) << next.why;
        EXPECT_EQ(listing(dir), (std::set<std::string>{"t.nhdr", next.dataFile}))
            << "kill at move " << killAt;
    }
}

// A header volcl did not write keeps the data file it names, even one that looks like volcl's.
TEST(AtomicFile, NhdrRewriteKeepsDataFilesVolclDidNotMake) {
    const fs::path dir = test::tempDir("io-atomic-nhdr-user");
    writeFile(dir / "t.0000000100000000.raw", std::string(256 * 10, '\x01'));
    writeFile(dir / "t.nhdr", "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 16 16 10\nencoding: raw\n"
                              "data file: t.0000000100000000.raw\n");
    EXPECT_EQ(volumeFilesWritten(dir / "t.nhdr"), std::vector<fs::path>{dir / "t.nhdr"});
    writeVolumeFile(nhdrWriterVolume(1), dir / "t.nhdr");
    EXPECT_TRUE(readNhdrPair(dir / "t.nhdr").consistent);
    EXPECT_EQ(readFile(dir / "t.0000000100000000.raw"), std::string(256 * 10, '\x01'));
    // volcl's own pair: the data file is named as replaced by the next write, and removed by it.
    const std::string ownData = readNhdrPair(dir / "t.nhdr").dataFile;
    EXPECT_EQ(volumeFilesWritten(dir / "t.nhdr"), (std::vector<fs::path>{dir / "t.nhdr", dir / ownData}));
    writeVolumeFile(nhdrWriterVolume(2), dir / "t.nhdr");
    EXPECT_FALSE(fs::exists(dir / ownData));
}

// A group moves nothing before its commit; dropped, it leaves nothing; a move that fails puts back every
// target the moves before it replaced.
TEST(AtomicCommitGroup, AllOrNothing) {
    const fs::path dir = test::tempDir("io-atomic-group");
    writeFile(dir / "b", "old b");
    writeFile(dir / "c", "old c");
    {
        AtomicCommitGroup group;
        for (const char* name : {"a", "b", "c"}) {
            AtomicFile f(dir / name);
            f.write(std::string_view("new"));
            f.commit();
        }
        EXPECT_EQ(listing(dir), (std::set<std::string>{"b", "c"})); // finished files are still unnamed
        EXPECT_EQ(readFile(dir / "b"), "old b");
    } // dropped without commit
    EXPECT_EQ(listing(dir), (std::set<std::string>{"b", "c"}));
    EXPECT_EQ(readFile(dir / "c"), "old c");
    {
        AtomicCommitGroup group;
        for (const char* name : {"a", "b", "c"}) {
            AtomicFile f(dir / name);
            f.write(std::string_view("new"));
            f.commit();
        }
        // The last target stops being a file before the moves: they all go back.
        fs::remove(dir / "c");
        fs::create_directory(dir / "c");
        EXPECT_THROW(group.commit(), IoError);
    }
    EXPECT_EQ(listing(dir), (std::set<std::string>{"b", "c"}));
    EXPECT_EQ(readFile(dir / "b"), "old b");
    EXPECT_TRUE(fs::is_directory(dir / "c"));
    fs::remove(dir / "c");
    {
        AtomicCommitGroup group;
        for (const char* name : {"a", "b", "c"}) {
            AtomicFile f(dir / name);
            f.write(std::string_view(name));
            f.commit();
        }
        group.commit();
    }
    EXPECT_EQ(listing(dir), (std::set<std::string>{"a", "b", "c"}));
    EXPECT_EQ(readFile(dir / "a") + readFile(dir / "b") + readFile(dir / "c"), "abc");
}

// OpenVDB and OpenImageIO write through their own file code: a write the file size limit cuts short must
// fail the write, keep the old target and leave no temporary (OpenVDB's unchecked stream gave a truncated
// file and success).
TEST(AtomicFile, LibraryWritersCutShortByTheFileSizeLimitFail) {
    const fs::path dir = test::tempDir("io-atomic-vdb-limit");
    writeFile(dir / "keep.vdb", "previous");
    Volume v({64, 64, 64}, ScalarType::Float32);
    auto vals = v.values<float>();
    for (std::size_t i = 0; i < vals.size(); ++i)
        vals[i] = static_cast<float>((i * 2654435761u) % 1000) + 1.0f; // no background: every voxel stored
    struct rlimit old {};
    ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &old), 0);
    const auto oldHandler = std::signal(SIGXFSZ, SIG_IGN);
    struct rlimit small = old;
    small.rlim_cur = 16384;
    ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &small), 0);
    bool refused = false;
    try {
        writeVolumeFile(v, dir / "keep.vdb", {Endian::Little, false});
    } catch (const IoError& e) {
        refused = std::string(e.what()).find("keep.vdb") != std::string::npos;
    }
    ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &old), 0);
    std::signal(SIGXFSZ, oldHandler);
    EXPECT_TRUE(refused) << "the VDB writer did not report the cut";
    EXPECT_EQ(readFile(dir / "keep.vdb"), "previous");
    EXPECT_EQ(listing(dir), (std::set<std::string>{"keep.vdb"}));
}

// SIGTERM arriving at the first move of a group waits until the last one, also with a second thread in the
// process (a process-directed signal goes to any thread that does not block it; OpenCL keeps threads).
TEST(AtomicCommitGroup, TerminationSignalsWaitForTheLastMove) {
    const fs::path dir = test::tempDir("io-atomic-group-sigterm");
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
        std::thread idle([] { ::pause(); }); // never joined: the process ends by the signal
        idle.detach();
        AtomicFile::beforeMoveForTesting = [](const fs::path& target) {
            if (target.filename() == "a") ::kill(::getpid(), SIGTERM);
            ::usleep(20000); // time for the signal to reach some thread
        };
        AtomicCommitGroup group;
        for (const char* name : {"a", "b", "c"}) {
            AtomicFile f(dir / name);
            f.write(std::string_view(name));
            f.commit();
        }
        group.commit();
        ::_exit(0); // not reached: the deferred SIGTERM ends the process after the moves
    }
    int status = 0;
    ::waitpid(child, &status, 0);
    EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGTERM) << "status " << status;
    EXPECT_EQ(listing(dir), (std::set<std::string>{"a", "b", "c"}));
}

// A writer that seeks back to patch its header (the streamed .vcz encoder) leaves the stream's position
// short of the file's end: the commit compares the file with the furthest byte written, not that position.
TEST(AtomicFile, SeekingBackToPatchAHeaderCommits) {
    const fs::path dir = test::tempDir("io-atomic-seek");
    std::string expected(4280, 'b');
    {
        AtomicFile f(dir / "patched.bin");
        f.stream() << std::string(4280, 'b');
        f.stream().seekp(0);
        f.stream() << "HEAD";
        expected.replace(0, 4, "HEAD");
        f.commit(); // failed: "4280 of 4 bytes reached the disk"
    }
    EXPECT_EQ(readFile(dir / "patched.bin"), expected);
    {
        // Patched in the middle, the last operation a seek: still the whole file.
        AtomicFile f(dir / "patched.bin");
        f.stream() << std::string(100, 'c');
        f.stream().seekp(10);
        f.stream() << "X";
        f.stream().seekp(5);
        f.commit();
    }
    std::string second(100, 'c');
    second[10] = 'X';
    EXPECT_EQ(readFile(dir / "patched.bin"), second);
    EXPECT_EQ(listing(dir), (std::set<std::string>{"patched.bin"}));
}

namespace {

// Frame f of writer w of a three-frame series: values no other (w, f) has.
Volume seriesFrame(int writer, int frame) {
    Volume v({6, 5, 4}, ScalarType::Float32);
    auto vals = v.values<float>();
    for (std::size_t i = 0; i < vals.size(); ++i)
        vals[i] = static_cast<float>(1000 * writer + 100 * frame) + static_cast<float>(i);
    return v;
}

// Which writer's frame `frame` the file holds (by its first value), -1 for neither.
int seriesWriterOf(const fs::path& file, int frame) {
    const Volume v = readVolumeFile(file).frames.front();
    const float first = v.values<float>()[0];
    for (int w = 0; w < 4; ++w)
        if (first == static_cast<float>(1000 * w + 100 * frame)) return w;
    return -1;
}

std::string frameName(int f) {
    return "t_0" + std::to_string(f) + ".nii";
}

void writeSeries(const fs::path& dir, int writer) {
    AtomicCommitGroup group;
    for (int f = 0; f < 3; ++f)
        writeVolumeFile(seriesFrame(writer, f), dir / frameName(f));
    group.commit();
}

// The frame file's first voxel, read without volcl (a foreign reader: NIfTI keeps raw voxels at the end).
int rawWriterOf(const fs::path& file, int frame) {
    const std::string bytes = readFile(file);
    float first = 0;
    std::memcpy(&first, bytes.data() + bytes.size() - 6 * 5 * 4 * sizeof(float), sizeof(float));
    return first == static_cast<float>(100 * frame)          ? 0
           : first == static_cast<float>(1000 + 100 * frame) ? 1
                                                             : -1;
}

} // namespace

// SIGKILL before each move of a series commit: the directory may hold a mix (another program sees one),
// but the next volcl reader of any frame, or the next writer of one, rolls the whole series forward.
TEST(AtomicCommitGroup, KilledSeriesCommitIsRolledForwardByTheNextVolclCommand) {
    const fs::path dir = test::tempDir("io-atomic-journal");
    for (int killAt = 1; killAt <= 3; ++killAt) {
        for (const auto& e : fs::directory_iterator(dir))
            fs::remove(e.path());
        writeSeries(dir, 0);
        const pid_t child = ::fork();
        ASSERT_GE(child, 0);
        if (child == 0) {
            movesBeforeKill = killAt;
            AtomicFile::beforeMoveForTesting = killAtMove;
            writeSeries(dir, 1);
            ::_exit(0);
        }
        int status = 0;
        ::waitpid(child, &status, 0);
        ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL) << "kill at move " << killAt;
        // What a foreign reader sees now: frames before the kill new, the rest old.
        for (int f = 0; f < 3; ++f)
            EXPECT_EQ(rawWriterOf(dir / frameName(f), f), f < killAt - 1 ? 1 : 0) << "kill at " << killAt;
        if (killAt == 2) {
            AtomicFile other(dir / frameName(2)); // a writer of one frame: completes it, then drops its own
        } else {
            EXPECT_EQ(seriesWriterOf(dir / frameName(killAt == 1 ? 0 : 2), killAt == 1 ? 0 : 2), 1);
        }
        for (int f = 0; f < 3; ++f)
            EXPECT_EQ(rawWriterOf(dir / frameName(f), f), 1) << "frame " << f << ", kill at " << killAt;
        EXPECT_EQ(listing(dir), (std::set<std::string>{frameName(0), frameName(1), frameName(2)}))
            << "kill at " << killAt;
    }
}

// A reader that comes while a writer is between its moves waits for the last one, and a second writer of
// the series commits after the first as a whole (before, the second's moves came between the first's).
TEST(AtomicCommitGroup, SeriesCommitsAndReadersWaitForAMoveLoopInProgress) {
    const fs::path dir = test::tempDir("io-atomic-journal-live");
    writeSeries(dir, 0);
    int paused[2];
    ASSERT_EQ(::pipe(paused), 0);
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
        ::close(paused[0]);
        static int writeEnd = paused[1];
        AtomicFile::beforeMoveForTesting = [](const fs::path& target) {
            if (target.filename() != "t_01.nii") return;
            const char c = 'p';
            if (::write(writeEnd, &c, 1) != 1) ::_exit(3);
            ::usleep(300000); // the parent's reader and writer come now
        };
        writeSeries(dir, 1);
        ::_exit(0);
    }
    ::close(paused[1]);
    char c = 0;
    ASSERT_EQ(::read(paused[0], &c, 1), 1);
    ::close(paused[0]);
    EXPECT_EQ(seriesWriterOf(dir / "t_02.nii", 2), 1); // waited: frame 2 was still old when it started
    writeSeries(dir, 2);
    int status = 0;
    ::waitpid(child, &status, 0);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status;
    for (int f = 0; f < 3; ++f)
        EXPECT_EQ(rawWriterOf(dir / frameName(f), f), -1) << "frame " << f; // writer 2's, not 0's or 1's
    for (int f = 0; f < 3; ++f)
        EXPECT_EQ(seriesWriterOf(dir / frameName(f), f), 2) << "frame " << f;
    EXPECT_EQ(listing(dir), (std::set<std::string>{frameName(0), frameName(1), frameName(2)}));
}
