// OpenVDB (.vdb) through libopenvdb: float/double grids densified over their box; exact FloatGrid writer.
#include "host/io/AtomicFile.hpp"
#include "host/MemoryBudget.hpp"
#include "host/io/IoDetail.hpp"

#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>

#include <bit>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <new>

#include <poll.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

namespace volcl::io {

namespace fs = std::filesystem;

namespace {

void initOpenVdb() {
    static const bool once = [] {
        openvdb::initialize();
        return true;
    }();
    (void)once;
}

std::string describeGrid(const openvdb::GridBase& g) {
    const std::string type = g.type();
    std::string what = "a " + g.valueType() + " grid";
    if (type.find("ptdataidx") != std::string::npos)
        what = "a point data grid";
    else if (type.find("vec3") != std::string::npos)
        what = "a vector grid";
    return "grid '" + g.getName() + "' is " + what + " (" + type + "), not a scalar float/double grid";
}

bool isScalarGrid(const openvdb::GridBase& g) {
    return g.isType<openvdb::FloatGrid>() || g.isType<openvdb::DoubleGrid>();
}

template <class GridT>
Volume densify(const GridT& grid, const openvdb::CoordBBox& box, const fs::path& path,
               std::size_t memoryBudget) {
    const openvdb::Coord size = box.dim();
    const Dims dims{static_cast<std::size_t>(size.x()), static_cast<std::size_t>(size.y()),
                    static_cast<std::size_t>(size.z())};
    const std::size_t voxels = checkedVoxelCount(dims, 1, path);
    // The dense float box and its copy in the volume model's type.
    if (voxels > std::numeric_limits<std::size_t>::max() / 8) fail(path, "dense box size overflows");
    checkMemoryBudget(voxels * 8, memoryBudget, path,
                      "dense box " + std::to_string(dims.x) + "x" + std::to_string(dims.y) + "x" +
                          std::to_string(dims.z));
    Volume v(dims, ScalarType::Float32);
    auto out = v.values<float>();
    std::fill(out.begin(), out.end(), static_cast<float>(grid.background()));
    const openvdb::Coord lo = box.min();
    // Active voxels and tiles only: inactive voxels read as the background, as the grid defines them.
    for (auto it = grid.cbeginValueOn(); it; ++it) {
        openvdb::CoordBBox b = it.getBoundingBox();
        b.intersect(box);
        if (b.empty()) continue;
        const float value = static_cast<float>(*it);
        for (int z = b.min().z(); z <= b.max().z(); ++z)
            for (int y = b.min().y(); y <= b.max().y(); ++y) {
                const std::size_t row =
                    v.index(0, static_cast<std::size_t>(y - lo.y()), static_cast<std::size_t>(z - lo.z()));
                for (int x = b.min().x(); x <= b.max().x(); ++x)
                    out[row + static_cast<std::size_t>(x - lo.x())] = value;
            }
    }
    return v;
}

std::optional<ScalarType> storedTypeOf(const openvdb::GridBase& g) {
    const auto meta = g.getMetadata<openvdb::StringMetadata>("volcl:type");
    if (!meta) return std::nullopt;
    const std::string& t = meta->value();
    if (t == "uint8") return ScalarType::UInt8;
    if (t == "uint16") return ScalarType::UInt16;
    if (t == "int16") return ScalarType::Int16;
    if (t == "float32") return ScalarType::Float32;
    return std::nullopt;
}

template <class T> void restoreIntegers(const Volume& f, Volume& out, const fs::path& path) {
    auto src = f.values<float>();
    auto dst = out.values<T>();
    for (std::size_t i = 0; i < src.size(); ++i) {
        const float x = src[i];
        if (!(x >= static_cast<float>(std::numeric_limits<T>::min()) &&
              x <= static_cast<float>(std::numeric_limits<T>::max())) ||
            x != std::floor(x))
            fail(path, "value " + formatDouble(x) + " does not fit the recorded volcl:type " +
                           std::string(scalarTypeName(out.type())));
        dst[i] = static_cast<T>(x);
    }
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

TimeSeries readVdbImpl(const fs::path& path, const ReadOptions& options) {
    initOpenVdb();
    openvdb::io::File file(path.string());
    file.open(false); // no delayed loading: the whole file is validated while reading, no mapping kept
    const openvdb::GridPtrVecPtr metas = file.readAllGridMetadata();
    if (!metas || metas->empty()) {
        file.close();
        fail(path, "contains no grids");
    }
    openvdb::GridBase::ConstPtr chosenMeta;
    if (options.vdbGrid) {
        std::string names;
        for (const auto& g : *metas) {
            names += (names.empty() ? "" : ", ") + g->getName();
            if (g->getName() == *options.vdbGrid) chosenMeta = g;
        }
        if (!chosenMeta)
            throw UsageError(path.string() + ": no grid named '" + *options.vdbGrid + "' (grids: " + names +
                             ")");
    } else {
        for (const auto& g : *metas)
            if (isScalarGrid(*g)) {
                chosenMeta = g;
                break;
            }
        if (!chosenMeta) chosenMeta = metas->front();
    }
    if (!isScalarGrid(*chosenMeta)) unsupported(path, describeGrid(*chosenMeta));

    const openvdb::GridBase::Ptr base = file.readGrid(chosenMeta->getName());
    file.close();
    const openvdb::math::Transform& xform = base->transform();
    if (!xform.isLinear())
        unsupported(path, "grid '" + base->getName() + "' has a non-linear (frustum) transform");

    // Our own files record the original box and type so zero voxels and integer types come back exactly.
    openvdb::CoordBBox box;
    const auto dimsMeta = base->getMetadata<openvdb::Vec3IMetadata>("volcl:dims");
    const auto minMeta = base->getMetadata<openvdb::Vec3IMetadata>("volcl:indexMin");
    // Serial on purpose: this runs in a forked child where TBB's worker pool must not be used.
    openvdb::CoordBBox active;
    auto expand = [&](const auto& grid) {
        for (auto it = grid.cbeginValueOn(); it; ++it)
            active.expand(it.getBoundingBox());
    };
    if (auto fg = openvdb::gridConstPtrCast<openvdb::FloatGrid>(base))
        expand(*fg);
    else if (auto dg = openvdb::gridConstPtrCast<openvdb::DoubleGrid>(base))
        expand(*dg);
    if (dimsMeta) {
        const openvdb::Vec3i d = dimsMeta->value();
        const openvdb::Vec3i m = minMeta ? minMeta->value() : openvdb::Vec3i(0, 0, 0);
        if (d.x() <= 0 || d.y() <= 0 || d.z() <= 0) fail(path, "volcl:dims metadata is not positive");
        box = openvdb::CoordBBox(openvdb::Coord(m.x(), m.y(), m.z()),
                                 openvdb::Coord(m.x() + d.x() - 1, m.y() + d.y() - 1, m.z() + d.z() - 1));
        if (!active.empty() && !box.isInside(active))
            fail(path, "active voxels lie outside the box recorded in volcl:dims");
    } else {
        box = active;
        if (box.empty()) unsupported(path, "grid '" + base->getName() + "' has no active voxels");
    }

    Volume dense;
    if (auto fg = openvdb::gridPtrCast<openvdb::FloatGrid>(base))
        dense = densify(*fg, box, path, options.memoryBudget);
    else if (auto dg = openvdb::gridPtrCast<openvdb::DoubleGrid>(base))
        dense = densify(*dg, box, path, options.memoryBudget);
    else
        unsupported(path, describeGrid(*base));

    const openvdb::Vec3d vs = xform.voxelSize();
    const openvdb::Vec3d o = xform.indexToWorld(box.min());
    for (int a = 0; a < 3; ++a) {
        dense.spacing[a] = vs[a] > 0 && std::isfinite(vs[a]) ? vs[a] : 1.0;
        dense.origin[a] = std::isfinite(o[a]) ? o[a] : 0.0;
    }
    // The transform may hold spacing/origin in single precision; our files also keep the exact doubles.
    if (const auto sp = base->getMetadata<openvdb::Vec3DMetadata>("volcl:spacing"); sp && dimsMeta) {
        for (int a = 0; a < 3; ++a)
            if (std::abs(sp->value()[a] - dense.spacing[a]) <= 1e-6 * std::abs(dense.spacing[a]))
                dense.spacing[a] = sp->value()[a];
    }
    if (const auto og = base->getMetadata<openvdb::Vec3DMetadata>("volcl:origin"); og && dimsMeta) {
        for (int a = 0; a < 3; ++a)
            if (std::abs(og->value()[a] - dense.origin[a]) <=
                1e-6 * (std::abs(dense.origin[a]) + dense.spacing[a]))
                dense.origin[a] = og->value()[a];
    }
    Volume result;
    const auto stored = storedTypeOf(*base);
    if (stored && *stored != ScalarType::Float32 && base->isType<openvdb::FloatGrid>()) {
        result = Volume(dense.dims(), *stored);
        switch (*stored) {
        case ScalarType::UInt8:
            restoreIntegers<std::uint8_t>(dense, result, path);
            break;
        case ScalarType::UInt16:
            restoreIntegers<std::uint16_t>(dense, result, path);
            break;
        case ScalarType::Int16:
            restoreIntegers<std::int16_t>(dense, result, path);
            break;
        case ScalarType::Float32:
            break;
        }
        result.spacing = dense.spacing;
        result.origin = dense.origin;
    } else {
        result = std::move(dense);
    }
    TimeSeries series;
    series.frames.push_back(std::move(result));
    return series;
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
void capChildMemory(const ReadOptions& options) {
    const std::size_t budget = options.memoryBudget ? options.memoryBudget : defaultMemoryBudget();
    std::FILE* statm = std::fopen("/proc/self/statm", "r");
    unsigned long long pages = 0;
    const bool known = statm && std::fscanf(statm, "%llu", &pages) == 1;
    if (statm) std::fclose(statm);
    if (!known) return;
    const unsigned long long mapped = pages * static_cast<unsigned long long>(::sysconf(_SC_PAGESIZE));
    rlimit limit{};
    if (::getrlimit(RLIMIT_AS, &limit) != 0) return;
    const unsigned long long cap = mapped + 2ull * budget;
    if (limit.rlim_max != RLIM_INFINITY && cap > limit.rlim_max) return;
    limit.rlim_cur = static_cast<rlim_t>(cap);
    (void)::setrlimit(RLIMIT_AS, &limit);
}

[[noreturn]] void childMain(int fd, const fs::path& path, const ReadOptions& options) {
    capChildMemory(options);
    ChildStatus status = ChildStatus::Ok;
    std::string message;
    Volume v;
    try {
        TimeSeries s = readVdbImpl(path, options);
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
        childMain(fds[1], path, options);
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
    initOpenVdb();
    const Dims& d = volume.dims();
    constexpr std::size_t kMaxCoord = static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max());
    if (d.x > kMaxCoord || d.y > kMaxCoord || d.z > kMaxCoord)
        throw UsageError(path.string() + ": volume too large for OpenVDB coordinates");
    auto grid = openvdb::FloatGrid::create(0.0f);
    grid->setName("density");
    grid->setGridClass(openvdb::GRID_FOG_VOLUME);
    openvdb::math::Mat4d m = openvdb::math::Mat4d::identity();
    m.setToScale(openvdb::Vec3d(volume.spacing[0], volume.spacing[1], volume.spacing[2]));
    m.setTranslation(openvdb::Vec3d(volume.origin[0], volume.origin[1], volume.origin[2]));
    grid->setTransform(openvdb::math::Transform::createLinearTransform(m));
    {
        const bool isFloat = volume.type() == ScalarType::Float32;
        const std::span<const float> floats = isFloat ? volume.values<float>() : std::span<const float>();
        auto acc = grid->getAccessor();
        for (std::size_t k = 0; k < d.z; ++k)
            for (std::size_t j = 0; j < d.y; ++j)
                for (std::size_t i = 0; i < d.x; ++i) {
                    const std::size_t n = volume.index(i, j, k);
                    const float value = isFloat ? floats[n] : static_cast<float>(volume.valueAt(n));
                    // Only +0.0 is left as background; -0.0 and NaN are stored so floats come back bit-exact.
                    if (std::bit_cast<std::uint32_t>(value) == 0u) continue;
                    acc.setValueOn(
                        openvdb::Coord(static_cast<int>(i), static_cast<int>(j), static_cast<int>(k)), value);
                }
    }
    grid->insertMeta("volcl:type", openvdb::StringMetadata(std::string(scalarTypeName(volume.type()))));
    grid->insertMeta("volcl:dims", openvdb::Vec3IMetadata(openvdb::Vec3i(
                                       static_cast<int>(d.x), static_cast<int>(d.y), static_cast<int>(d.z))));
    grid->insertMeta("volcl:indexMin", openvdb::Vec3IMetadata(openvdb::Vec3i(0, 0, 0)));
    grid->insertMeta("volcl:spacing", openvdb::Vec3DMetadata(openvdb::Vec3d(
                                          volume.spacing[0], volume.spacing[1], volume.spacing[2])));
    grid->insertMeta("volcl:origin", openvdb::Vec3DMetadata(openvdb::Vec3d(volume.origin[0], volume.origin[1],
                                                                           volume.origin[2])));

    AtomicFile out(path);
    try {
        openvdb::io::File file(out.tempPath().string());
        std::uint32_t compression = openvdb::io::COMPRESS_NONE;
        if (options.compress)
            compression = openvdb::io::COMPRESS_ACTIVE_MASK |
                          (openvdb::io::Archive::hasBloscCompression() ? openvdb::io::COMPRESS_BLOSC
                                                                       : openvdb::io::COMPRESS_ZIP);
        file.setCompression(compression);
        file.write(openvdb::GridCPtrVec{grid});
        file.close();
    } catch (const openvdb::Exception& e) {
        throw IoError(path.string() + ": OpenVDB cannot write it: " + e.what());
    }
    out.commit();
}

} // namespace volcl::io
