// Atomic output: no partial target and no temporary after a failed, killed or size-limited write.
#include "TestUtil.hpp"
#include "core/AtomicFile.hpp"
#include "core/Error.hpp"
#include "host/io/VolumeIo.hpp"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cmath>
#include <csignal>
#include <set>
#include <string>
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
