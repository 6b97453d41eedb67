// .vdb reading: densified grids, forged sizes, and the reader service that isolates libopenvdb (it must
// work whatever the calling process is doing, leave no process behind its thread, and find its socket).
#include "TestUtil.hpp"
#include "core/Error.hpp"
#include "host/io/VolumeIo.hpp"

#include <gtest/gtest.h>
#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>
#include <openvdb/points/PointDataGrid.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <thread>
#include <vector>

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

namespace {

namespace fs = std::filesystem;
using namespace volcl;
using test::writeFile;

using test::expectIoError;

void initVdb() {
    static const bool once = (openvdb::initialize(), true);
    (void)once;
}

TEST(VdbReader, DensifiesActiveBoxWithBackgroundAndTiles) {
    initVdb();
    const fs::path dir = test::tempDir("io-vdb");
    auto grid = openvdb::DoubleGrid::create(-1.0);
    grid->setName("dens");
    grid->setTransform(openvdb::math::Transform::createLinearTransform(0.5));
    auto acc = grid->getAccessor();
    acc.setValueOn(openvdb::Coord(-2, 3, 1), 4.5);
    acc.setValueOn(openvdb::Coord(1, 4, 2), 2.0);
    acc.setValueOff(openvdb::Coord(0, 4, 2), 99.0); // inactive: must read as background, not 99
    auto tile = openvdb::FloatGrid::create(0.0f);
    tile->setName("tiles");
    tile->tree().addTile(1, openvdb::Coord(0, 0, 0), 3.0f, true); // one active 8^3 tile
    auto vec = openvdb::Vec3SGrid::create();
    vec->setName("velocity");
    vec->getAccessor().setValueOn(openvdb::Coord(0, 0, 0), openvdb::Vec3s(1, 2, 3));
    openvdb::io::File(dir.string() + "/g.vdb").write(openvdb::GridPtrVec{vec, grid, tile});
    // Default: the first scalar grid (the vector grid is skipped).
    const Volume v = readVolume(dir / "g.vdb");
    ASSERT_EQ(v.dims(), (Dims{4, 2, 2}));
    EXPECT_EQ(v.type(), ScalarType::Float32);
    EXPECT_EQ(v.origin, (std::array<double, 3>{-1, 1.5, 0.5}));
    EXPECT_EQ(v.spacing, (std::array<double, 3>{0.5, 0.5, 0.5}));
    EXPECT_EQ(v.values<float>()[v.index(0, 0, 0)], 4.5f);
    EXPECT_EQ(v.values<float>()[v.index(3, 1, 1)], 2.0f);
    EXPECT_EQ(v.values<float>()[v.index(2, 1, 1)], -1.0f);
    double sum = 0;
    for (float x : v.values<float>())
        sum += x;
    EXPECT_EQ(sum, 4.5 + 2.0 - 14.0);
    ReadOptions o;
    o.vdbGrid = "tiles";
    const Volume t = readVolume(dir / "g.vdb", o);
    ASSERT_EQ(t.dims(), (Dims{8, 8, 8}));
    for (float x : t.values<float>())
        ASSERT_EQ(x, 3.0f);
    o.vdbGrid = "velocity";
    try {
        (void)readVolume(dir / "g.vdb", o);
        ADD_FAILURE();
    } catch (const DataError& e) {
        EXPECT_NE(std::string(e.what()).find("velocity"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("vector"), std::string::npos) << e.what();
    }
    o.vdbGrid = "nope";
    EXPECT_THROW(readVolume(dir / "g.vdb", o), UsageError);
    // A points grid alone is refused with a message naming it.
    auto points = openvdb::points::PointDataGrid::create();
    points->setName("points");
    openvdb::io::File(dir.string() + "/p.vdb").write(openvdb::GridPtrVec{points});
    try {
        (void)readVolume(dir / "p.vdb");
        ADD_FAILURE();
    } catch (const DataError& e) {
        EXPECT_NE(std::string(e.what()).find("points"), std::string::npos) << e.what();
    }
}

// Found by fuzz_read_vdb: sizes inside the grid's data are libopenvdb's to trust, and a forged one made the
// reader allocate and touch 5 GB from an 11 KB file (67 s). The reader's address space is capped at twice
// the memory budget, so the read ends as a corrupt file.
void expectForgedBufferSizeRefused() {
    const fs::path finding =
        fs::path(VOLCL_SOURCE_DIR) / "fuzz/regressions/fuzz_read_vdb/forged-buffer-size.vdb";
    ASSERT_TRUE(fs::exists(finding));
    ReadOptions small;
    small.memoryBudget = std::size_t{64} << 20;
    expectIoError(finding, small);
}

TEST(VdbReader, ForgedGridDataSizeStaysWithinTheMemoryBudget) {
    expectForgedBufferSizeRefused();
}

// Found by fuzz_read_vdb: libopenvdb allocates and zero-fills a metadata string at its stated length before
// reading it, so an 11 KB file whose grid metadata claimed 1.8 GB grew the reader past 2 GB. The layout walk
// refuses every metadata length that runs past its grid, before OpenVDB sees the file.
TEST(VdbReader, ForgedGridMetadataLengthIsRefusedBeforeOpenVdbAllocates) {
    const fs::path dir = test::tempDir("io-vdb-forged-meta");
    Volume v(Dims{4, 4, 4}, ScalarType::UInt8);
    v.values<std::uint8_t>()[5] = 7;
    writeVolumeFile(v, dir / "ok.vdb");
    ASSERT_NO_THROW((void)readVolume(dir / "ok.vdb"));
    std::string bytes = test::readFile(dir / "ok.vdb");
    // The grid metadata entry "volcl:type": u32 name length, name, u32 type length, "string", u32 value size.
    const std::size_t name = bytes.find("volcl:type");
    ASSERT_NE(name, std::string::npos);
    const std::size_t size = name + 10 + 4 + 6;
    ASSERT_EQ(bytes.substr(name + 14, 6), "string");
    const std::uint32_t forged = 0x7fffff00u; // 2 GB: the file holds a few hundred bytes
    std::memcpy(bytes.data() + size, &forged, 4);
    writeFile(dir / "forged.vdb", bytes);
    expectIoError(dir / "forged.vdb");
    try {
        (void)readVolumeFile(dir / "forged.vdb");
    } catch (const IoError& e) {
        EXPECT_NE(std::string(e.what()).find("grid 0 metadata"), std::string::npos) << e.what();
    }
}

// The reader was once a forked copy of the caller, and under AddressSanitizer a fork taken while another
// thread held the allocator's lock left the copy waiting on that lock for ever (the read failed after its
// 5-minute deadline). The reader is now a fresh program: reads succeed while other threads allocate
// without pause.
TEST(VdbReader, ReadsWhileOtherThreadsAllocate) {
    const fs::path dir = test::tempDir("io-vdb-busy");
    Volume v(Dims{9, 7, 5}, ScalarType::Int16);
    for (std::size_t i = 0; i < v.voxelCount(); ++i)
        v.values<std::int16_t>()[i] = static_cast<std::int16_t>(i * 37 - 900);
    writeVolumeFile(v, dir / "v.vdb");
    std::atomic<bool> stop{false};
    std::vector<std::thread> churn;
    for (int t = 0; t < 3; ++t)
        churn.emplace_back([&stop, t] {
            std::vector<void*> held(64, nullptr);
            for (std::size_t i = 0; !stop.load(std::memory_order_relaxed); ++i) {
                void*& slot = held[(i * 7 + t) % held.size()];
                std::free(slot);
                slot = std::malloc(16 + (i % 4096));
            }
            for (void* p : held)
                std::free(p);
        });
    for (int read = 0; read < 20; ++read) {
        const Volume back = readVolume(dir / "v.vdb");
        ASSERT_EQ(back.dims(), v.dims());
        ASSERT_EQ(back.type(), ScalarType::Int16);
        ASSERT_EQ(std::memcmp(back.bytes().data(), v.bytes().data(), v.byteSize()), 0) << "read " << read;
    }
    stop = true;
    for (std::thread& t : churn)
        t.join();
}

// The children a thread has started (Linux lists them per thread).
std::vector<pid_t> childrenOfThisThread() {
    std::ifstream in("/proc/self/task/" + std::to_string(::gettid()) + "/children");
    std::vector<pid_t> pids;
    for (pid_t p; in >> p;)
        pids.push_back(p);
    return pids;
}

int threadCount(pid_t pid) {
    int n = 0;
    for (const auto& e : fs::directory_iterator("/proc/" + std::to_string(pid) + "/task"))
        n += e.is_directory() ? 1 : 0;
    return n;
}

// Every read, good or corrupt, reaps its reader: while the thread lives its one child is the reader
// service (single-threaded: libopenvdb's logging pool is stopped before it forks), and when the thread ends
// so does the service, reaped.
TEST(VdbReader, NoProcessOutlivesTheReadingThread) {
    const fs::path dir = test::tempDir("io-vdb-reaped");
    Volume v(Dims{4, 4, 4}, ScalarType::Float32);
    writeVolumeFile(v, dir / "ok.vdb");
    std::vector<pid_t> during;
    int serviceThreads = 0;
    std::thread reading([&] {
        for (int i = 0; i < 3; ++i) {
            (void)readVolume(dir / "ok.vdb");
            expectForgedBufferSizeRefused();
        }
        during = childrenOfThisThread();
        if (during.size() == 1) serviceThreads = threadCount(during[0]);
    });
    reading.join();
    ASSERT_EQ(during.size(), 1u) << "the service and no reader";
    EXPECT_EQ(serviceThreads, 1) << "the service must be single-threaded when it forks readers";
    EXPECT_EQ(::kill(during[0], 0), -1) << "the service outlived its thread";
    EXPECT_EQ(errno, ESRCH);
}

// The service's socket goes to it as descriptor 3. When the socket's end is itself descriptor 3 (0 and 3
// were free when the thread's service started), it must still reach the service open.
TEST(VdbReader, ServiceSocketReachesTheServiceWhenItIsDescriptorThree) {
    const fs::path dir = test::tempDir("io-vdb-fd3");
    Volume v(Dims{3, 2, 2}, ScalarType::UInt8);
    v.values<std::uint8_t>()[7] = 200;
    writeVolumeFile(v, dir / "v.vdb");
    const int savedStdin = ::fcntl(0, F_DUPFD_CLOEXEC, 10);
    const int savedThree = ::fcntl(3, F_GETFD) >= 0 ? ::fcntl(3, F_DUPFD_CLOEXEC, 10) : -1;
    ASSERT_GE(savedStdin, 0);
    ::close(0);
    ::close(3);
    // A new thread starts its own service: its socketpair now takes 0 and 3.
    Volume back;
    std::string error;
    std::thread reading([&] {
        try {
            back = readVolume(dir / "v.vdb");
        } catch (const std::exception& e) {
            error = e.what();
        }
    });
    reading.join();
    ::dup2(savedStdin, 0);
    ::close(savedStdin);
    if (savedThree >= 0) {
        ::dup2(savedThree, 3);
        ::close(savedThree);
    }
    ASSERT_EQ(error, "");
    ASSERT_EQ(back.dims(), v.dims());
    EXPECT_EQ(back.values<std::uint8_t>()[7], 200);
}

// A service that has died (killed, or its thread's parent-death signal) is started again by the next read.
TEST(VdbReader, AKilledServiceIsStartedAgain) {
    const fs::path dir = test::tempDir("io-vdb-restart");
    Volume v(Dims{5, 3, 2}, ScalarType::UInt8);
    v.values<std::uint8_t>()[11] = 99;
    writeVolumeFile(v, dir / "v.vdb");
    std::string error;
    std::thread reading([&] {
        try {
            (void)readVolume(dir / "v.vdb");
            const std::vector<pid_t> services = childrenOfThisThread();
            if (services.size() != 1) throw std::runtime_error("expected one service");
            ::kill(services[0], SIGKILL);
            for (int i = 0; i < 3; ++i)
                if (readVolume(dir / "v.vdb").values<std::uint8_t>()[11] != 99)
                    throw std::runtime_error("wrong voxels after the restart");
        } catch (const std::exception& e) {
            error = e.what();
        }
    });
    reading.join();
    EXPECT_EQ(error, "");
}

// Reads on several threads at once each go through their thread's own service.
TEST(VdbReader, ThreadsReadInParallelThroughTheirOwnServices) {
    const fs::path dir = test::tempDir("io-vdb-parallel");
    Volume v(Dims{6, 5, 4}, ScalarType::UInt16);
    for (std::size_t i = 0; i < v.voxelCount(); ++i)
        v.values<std::uint16_t>()[i] = static_cast<std::uint16_t>(i * 311);
    writeVolumeFile(v, dir / "v.vdb");
    std::atomic<int> good{0};
    std::vector<std::thread> readers;
    for (int t = 0; t < 4; ++t)
        readers.emplace_back([&] {
            for (int i = 0; i < 5; ++i) {
                const Volume back = readVolume(dir / "v.vdb");
                if (back.dims() == v.dims() &&
                    std::memcmp(back.bytes().data(), v.bytes().data(), v.byteSize()) == 0)
                    ++good;
            }
        });
    for (std::thread& t : readers)
        t.join();
    EXPECT_EQ(good.load(), 20);
}

} // namespace
