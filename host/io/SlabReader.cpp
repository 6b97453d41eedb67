// Slab reads of raw/NRRD/NIfTI voxels: pread at sample offsets for raw data, one forward zlib stream for gzip.
#include "host/io/SlabReader.hpp"

#include "host/io/IoDetail.hpp"

#include <zlib.h>

#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace volcl {

namespace io {

namespace {

/// A file descriptor closed on scope exit.
struct Fd {
    int fd = -1;
    // O_NONBLOCK: a FIFO must not block the open; fstat refuses it (and directories, devices) before a read.
    explicit Fd(const std::filesystem::path& path)
        : fd(::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC)) {
        if (fd < 0) {
            if (errno == ENOENT) fail(path, "file does not exist");
            fail(path, std::string("cannot open for reading: ") + std::strerror(errno));
        }
        struct stat st {};
        if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
            ::close(fd);
            fd = -1;
            fail(path, "not a regular file");
        }
    }
    ~Fd() {
        if (fd >= 0) ::close(fd);
    }
    Fd(const Fd&) = delete;
    Fd& operator=(const Fd&) = delete;
};

/// `n` bytes at `offset`, or fewer at the end of the file.
std::size_t preadAll(int fd, std::byte* out, std::size_t n, std::uint64_t offset,
                     const std::filesystem::path& path) {
    std::size_t done = 0;
    while (done < n) {
        const ssize_t r = ::pread(fd, out + done, n - done, off_t(offset + done));
        if (r < 0) {
            if (errno == EINTR) continue;
            fail(path, std::string("cannot read: ") + std::strerror(errno));
        }
        if (r == 0) break;
        done += std::size_t(r);
    }
    return done;
}

/// A zlib gzip reader over a file from a byte offset on (gzdopen owns a duplicate of the descriptor).
class GzStream {
public:
    GzStream(const std::filesystem::path& path, std::uint64_t offset) : path_(path) {
        Fd f(path);
        if (::lseek(f.fd, off_t(offset), SEEK_SET) < 0) fail(path, "cannot seek to the data");
        const int dup = ::dup(f.fd);
        if (dup < 0) fail(path, "cannot open for reading");
        gz_ = gzdopen(dup, "rb");
        if (!gz_) {
            ::close(dup);
            fail(path, "cannot open the gzip stream");
        }
        gzbuffer(gz_, 1 << 18);
    }
    ~GzStream() {
        if (gz_) gzclose(gz_);
    }
    GzStream(const GzStream&) = delete;
    GzStream& operator=(const GzStream&) = delete;
    /// Reads up to `n` bytes; returns how many there were.
    std::size_t read(std::byte* out, std::size_t n) {
        std::size_t done = 0;
        while (done < n) {
            const unsigned chunk = unsigned(std::min<std::size_t>(n - done, 1u << 30));
            const int r = gzread(gz_, out + done, chunk);
            if (r < 0) {
                int err = 0;
                fail(path_, std::string("gzip data is corrupt: ") + gzerror(gz_, &err));
            }
            if (r == 0) break;
            done += std::size_t(r);
        }
        return done;
    }

private:
    std::filesystem::path path_;
    gzFile gz_ = nullptr;
};

} // namespace

std::vector<std::byte> readFilePrefix(const std::filesystem::path& path, std::size_t n, bool gzip) {
    std::vector<std::byte> out(n);
    if (gzip) {
        GzStream g(path, 0);
        out.resize(g.read(out.data(), n));
    } else {
        Fd f(path);
        out.resize(preadAll(f.fd, out.data(), n, 0, path));
    }
    return out;
}

} // namespace io

struct VolumeSlabReader::State {
    io::SlabLayout layout;
    std::filesystem::path header;
    ScalarType type = ScalarType::UInt8;
    std::size_t sampleBytes = 1;
    std::optional<io::Fd> raw;
    std::unique_ptr<io::GzStream> gz;
    std::vector<std::byte> slab; ///< gzip: the slices [slabZ, slabZ + slabSlices)
    std::size_t slabZ = 0, slabSlices = 0, nextZ = 0;
    std::vector<std::byte> lines; ///< raw: one slice's lines of a box
};

VolumeSlabReader::VolumeSlabReader(std::unique_ptr<State> state) : s_(std::move(state)) {}
VolumeSlabReader::~VolumeSlabReader() = default;
VolumeSlabReader::VolumeSlabReader(VolumeSlabReader&&) noexcept = default;
VolumeSlabReader& VolumeSlabReader::operator=(VolumeSlabReader&&) noexcept = default;

std::optional<VolumeSlabReader> VolumeSlabReader::open(const std::filesystem::path& path,
                                                       const ReadOptions& options) {
    io::ReadContext ctx(path, options);
    std::optional<io::SlabLayout> layout;
    switch (detectVolumeFormat(path)) {
    case VolumeFormat::Raw:
        layout = io::rawSlabLayout(ctx);
        break;
    case VolumeFormat::Nrrd:
        layout = io::nrrdSlabLayout(ctx);
        break;
    case VolumeFormat::Nifti:
        layout = io::niftiSlabLayout(ctx);
        break;
    default:
        break;
    }
    if (!layout) return std::nullopt;
    auto s = std::make_unique<State>();
    s->layout = std::move(*layout);
    s->header = path;
    s->type = io::volumeTypeFor(s->layout.sampleType);
    s->sampleBytes = io::sampleSize(s->layout.sampleType);
    if (s->layout.gzip) {
        s->gz = std::make_unique<io::GzStream>(s->layout.dataFile, s->layout.fileOffset);
        std::vector<std::byte> skipped(std::size_t(std::min<std::uint64_t>(s->layout.skip, 1 << 20)));
        for (std::uint64_t left = s->layout.skip; left > 0;) {
            const std::size_t n = std::size_t(std::min<std::uint64_t>(left, skipped.size()));
            if (s->gz->read(skipped.data(), n) != n) io::fail(s->layout.dataFile, "truncated gzip data");
            left -= n;
        }
    } else {
        s->raw.emplace(s->layout.dataFile);
    }
    return VolumeSlabReader(std::move(s));
}

Dims VolumeSlabReader::dims() const noexcept {
    return s_->layout.dims;
}
ScalarType VolumeSlabReader::type() const noexcept {
    return s_->type;
}
std::array<double, 3> VolumeSlabReader::spacing() const noexcept {
    return s_->layout.spacing;
}
std::array<double, 3> VolumeSlabReader::origin() const noexcept {
    return s_->layout.origin;
}
Direction3 VolumeSlabReader::direction() const noexcept {
    return s_->layout.direction;
}
bool VolumeSlabReader::anatomical() const noexcept {
    return s_->layout.anatomical;
}
bool VolumeSlabReader::gzip() const noexcept {
    return s_->layout.gzip;
}

std::vector<std::filesystem::path> VolumeSlabReader::files() const {
    std::vector<std::filesystem::path> f{s_->header};
    if (s_->layout.dataFile != s_->header) f.push_back(s_->layout.dataFile);
    return f;
}

void VolumeSlabReader::read(Dims lo, Volume& out) {
    State& s = *s_;
    const Dims d = s.layout.dims, n = out.dims();
    if (lo.x != 0 || n.x != d.x || lo.y + n.y > d.y || lo.z + n.z > d.z || out.type() != s.type)
        throw UsageError("internal: a slab read must span whole x lines inside the volume");
    const std::size_t lineBytes = d.x * s.sampleBytes, boxLine = n.y * lineBytes;
    const std::size_t sliceBytes = d.y * lineBytes;
    if (!s.gz) {
        s.lines.resize(boxLine);
        for (std::size_t z = 0; z < n.z; ++z) {
            const std::uint64_t at = s.layout.fileOffset + ((lo.z + z) * d.y + lo.y) * lineBytes;
            if (io::preadAll(s.raw->fd, s.lines.data(), boxLine, at, s.layout.dataFile) != boxLine)
                io::fail(s.layout.dataFile,
                         "truncated: the data ends before slice " + std::to_string(lo.z + z));
            io::decodeSamples(s.lines, s.layout.sampleType, s.layout.endian, out, z * n.x * n.y);
        }
        return;
    }
    if (lo.z != s.slabZ || n.z != s.slabSlices || s.slab.empty()) {
        if (lo.z != s.nextZ)
            throw UsageError("internal: gzip slabs must be read in order (z " + std::to_string(lo.z) +
                             " after " + std::to_string(s.nextZ) + ")");
        s.slab.resize(n.z * sliceBytes);
        if (s.gz->read(s.slab.data(), s.slab.size()) != s.slab.size())
            io::fail(s.layout.dataFile,
                     "truncated: the gzip data ends before slice " + std::to_string(lo.z + n.z));
        s.slabZ = lo.z;
        s.slabSlices = n.z;
        s.nextZ = lo.z + n.z;
    }
    for (std::size_t z = 0; z < n.z; ++z)
        io::decodeSamples(
            std::span<const std::byte>(s.slab).subspan(z * sliceBytes + lo.y * lineBytes, boxLine),
            s.layout.sampleType, s.layout.endian, out, z * n.x * n.y);
}

} // namespace volcl
