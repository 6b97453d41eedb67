// NIfTI-1 single files (.nii, .nii.gz): 3D and 4D, either byte order, scl_slope/inter, pixdim spacing.
#include "core/AtomicFile.hpp"
#include "host/io/IoDetail.hpp"
#include "host/io/NiftiMetadata.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace volcl::io {

namespace fs = std::filesystem;

namespace {

constexpr std::size_t kHeaderSize = 348;

class HeaderView {
public:
    HeaderView(std::span<const std::byte> h, bool swap) : h_(h), swap_(swap) {}
    template <class T> T get(std::size_t offset) const {
        std::byte tmp[sizeof(T)];
        std::memcpy(tmp, h_.data() + offset, sizeof(T));
        if (swap_) std::reverse(tmp, tmp + sizeof(T));
        T v;
        std::memcpy(&v, tmp, sizeof(T));
        return v;
    }

private:
    std::span<const std::byte> h_;
    bool swap_;
};

std::optional<SampleType> niftiType(int code) {
    switch (code) {
    case 2:
        return SampleType::UInt8;
    case 4:
        return SampleType::Int16;
    case 8:
        return SampleType::Int32;
    case 16:
        return SampleType::Float32;
    case 64:
        return SampleType::Float64;
    case 256:
        return SampleType::Int8;
    case 512:
        return SampleType::UInt16;
    case 768:
        return SampleType::UInt32;
    case 1024:
        return SampleType::Int64;
    case 1280:
        return SampleType::UInt64;
    default:
        return std::nullopt;
    }
}

/// What the reader needs from a header, plus the fields a writer restores.
struct ParsedHeader {
    Endian endian = Endian::Little;
    std::size_t sizes[7] = {1, 1, 1, 1, 1, 1, 1};
    SampleType sampleType = SampleType::UInt8;
    /// Components per voxel: dim[5] (stored as whole volumes one after another) or 3/4 of an RGB24/RGBA32
    /// datatype (interleaved per voxel).
    std::size_t components = 1;
    bool interleaved = false;
    NiftiMetadata meta;
};

std::string fixedText(std::span<const std::byte> head, std::size_t offset, std::size_t size) {
    std::string s(reinterpret_cast<const char*>(head.data()) + offset, size);
    s.resize(std::strlen(s.c_str()));
    return s;
}

ParsedHeader parseHeader(std::span<const std::byte> head, const fs::path& path) {
    if (head.size() < kHeaderSize)
        fail(path, "truncated: " + std::to_string(head.size()) + " bytes, a NIfTI-1 header needs 348");
    std::int32_t sizeofHdr = 0;
    std::memcpy(&sizeofHdr, head.data(), 4);
    bool swap = false;
    if (sizeofHdr != 348) {
        const auto swapped =
            static_cast<std::int32_t>(__builtin_bswap32(static_cast<std::uint32_t>(sizeofHdr)));
        if (swapped == 540 || sizeofHdr == 540) unsupported(path, "NIfTI-2 files are not supported");
        if (swapped != 348) fail(path, "not a NIfTI-1 file (sizeof_hdr is not 348 in either byte order)");
        swap = true;
    }
    ParsedHeader p;
    p.endian = (swap ? (hostIsLittleEndian() ? Endian::Big : Endian::Little) : hostEndian());
    const HeaderView h(head, swap);
    const std::string_view magic(reinterpret_cast<const char*>(head.data()) + 344, 4);
    if (magic == std::string_view("ni1\0", 4))
        unsupported(path,
                    "header/image pairs (.hdr/.img, magic 'ni1') are not supported; use a single .nii file");
    if (magic != std::string_view("n+1\0", 4)) fail(path, "bad NIfTI-1 magic (expected 'n+1')");

    const int rank = h.get<std::int16_t>(40);
    if (rank < 1 || rank > 7) fail(path, "dim[0] = " + std::to_string(rank) + " is outside 1..7");
    for (int i = 0; i < rank; ++i) {
        const int d = h.get<std::int16_t>(42 + 2 * i);
        if (d <= 0)
            fail(path, "dim[" + std::to_string(i + 1) + "] = " + std::to_string(d) + " must be positive");
        p.sizes[i] = static_cast<std::size_t>(d);
    }
    p.components = p.sizes[4]; // dim[5]: the components of a vector (or any) intent
    for (int i = 5; i < 7; ++i)
        if (p.sizes[i] != 1)
            unsupported(path, "dimension " + std::to_string(i + 1) + " has size " +
                                  std::to_string(p.sizes[i]) + ": only 3D and 4D volumes are supported");
    const int datatype = h.get<std::int16_t>(70);
    constexpr int kRgb24 = 128, kRgba32 = 2304; // uint8 colour components, interleaved per voxel
    if (datatype == kRgb24 || datatype == kRgba32) {
        if (p.components != 1) unsupported(path, "RGB datatype with dim[5] components");
        p.components = datatype == kRgb24 ? 3 : 4;
        p.interleaved = true;
        p.sampleType = SampleType::UInt8;
        const int bitpix = h.get<std::int16_t>(72);
        if (bitpix != static_cast<int>(8 * p.components))
            fail(path,
                 "bitpix " + std::to_string(bitpix) + " does not match datatype " + std::to_string(datatype));
    }
    const auto st = p.interleaved ? std::optional<SampleType>(SampleType::UInt8) : niftiType(datatype);
    if (!st)
        unsupported(path,
                    "datatype " + std::to_string(datatype) + " (complex, RGB or unknown) is not supported");
    p.sampleType = *st;
    const int bitpix = h.get<std::int16_t>(72);
    if (!p.interleaved && bitpix != static_cast<int>(8 * sampleSize(*st)))
        fail(path,
             "bitpix " + std::to_string(bitpix) + " does not match datatype " + std::to_string(datatype));

    NiftiMetadata& m = p.meta;
    m.datatype = static_cast<std::int16_t>(datatype);
    for (int i = 0; i < 3; ++i) {
        m.pixdim[i] = h.get<float>(80 + 4 * i);
        const double a = std::abs(static_cast<double>(m.pixdim[i]));
        // Zero is no spacing: reading it as 1 would silently change the geometry.
        if (!std::isfinite(a) || !(a > 0))
            fail(path, "pixdim[" + std::to_string(i + 1) + "] " + formatDouble(m.pixdim[i]) +
                           " is not a positive finite spacing");
        m.spacing[i] = a;
    }
    m.qformCode = h.get<std::int16_t>(252);
    m.sformCode = h.get<std::int16_t>(254);
    m.qfac = h.get<float>(76) < 0 ? -1.0f : 1.0f; // pixdim[0]: the standard reads anything but -1 as 1
    m.quaternB = h.get<float>(256);
    m.quaternC = h.get<float>(260);
    m.quaternD = h.get<float>(264);
    for (int i = 0; i < 3; ++i) {
        m.qoffset[i] = h.get<float>(268 + 4 * i);
        for (int j = 0; j < 4; ++j)
            m.srow[i][j] = h.get<float>(280 + 16 * i + 4 * j);
    }
    if (m.sformCode > 0) {
        for (int i = 0; i < 3; ++i)
            m.origin[i] = m.srow[i][3];
    } else if (m.qformCode > 0) {
        for (int i = 0; i < 3; ++i)
            m.origin[i] = m.qoffset[i];
    }
    for (double o : m.origin)
        if (!std::isfinite(o))
            fail(path, (m.sformCode > 0 ? "srow" : "qoffset") + std::string(" origin is not finite"));
    m.xyztUnits = static_cast<std::uint8_t>(std::to_integer<unsigned>(head[123]));
    m.timeStep = h.get<float>(92);
    m.toffset = h.get<float>(136);
    m.intentCode = h.get<std::int16_t>(68);
    for (int i = 0; i < 3; ++i)
        m.intentP[i] = h.get<float>(56 + 4 * i);
    m.intentName = fixedText(head, 328, 16);
    m.sclSlope = h.get<float>(112);
    m.sclInter = h.get<float>(116);
    m.calMax = h.get<float>(124);
    m.calMin = h.get<float>(128);
    m.descrip = fixedText(head, 148, 80);
    if (!std::isfinite(m.sclSlope) || !std::isfinite(m.sclInter))
        fail(path, "scl_slope " + formatDouble(m.sclSlope) + " / scl_inter " + formatDouble(m.sclInter) +
                       " is not finite");
    return p;
}

// Where the voxels start: vox_offset, checked. Single files keep their data at 352 or later; writers that
// leave vox_offset at 0 mean 352.
std::size_t dataOffset(const HeaderView& h, const fs::path& path) {
    const float voxOffsetF = h.get<float>(108);
    if (!std::isfinite(voxOffsetF) || voxOffsetF < 0 || voxOffsetF > 1e12f ||
        voxOffsetF != std::floor(voxOffsetF))
        fail(path, "vox_offset " + formatDouble(voxOffsetF) + " is not a valid byte offset");
    return voxOffsetF < static_cast<float>(kHeaderSize) ? kHeaderSize + 4
                                                        : static_cast<std::size_t>(voxOffsetF);
}

std::vector<std::byte> headerBytes(std::span<const std::byte> file, bool gz, const fs::path& path) {
    return gz ? inflatePrefix(file, kHeaderSize, path)
              : std::vector<std::byte>(file.begin(), file.begin() + std::min(file.size(), kHeaderSize));
}

} // namespace

TimeSeries readNifti(ReadContext& ctx) {
    const fs::path& path = ctx.file();
    const std::vector<std::byte> file = readFileBytes(path);
    const bool gz = looksCompressed(file); // .nii files are sometimes gzipped without the .gz suffix
    const std::vector<std::byte> head = headerBytes(file, gz, path);
    const ParsedHeader p = parseHeader(head, path);
    const HeaderView h(head, p.endian != hostEndian());
    const std::size_t(&sizes)[7] = p.sizes;
    const SampleType* st = &p.sampleType;
    const Endian endian = p.endian;
    const std::array<double, 3>& spacing = p.meta.spacing;
    const std::array<double, 3>& origin = p.meta.origin;

    const std::size_t voxOffset = dataOffset(h, path);

    const Dims dims{sizes[0], sizes[1], sizes[2]};
    refuseFramesWithComponents(sizes[3], p.components, path);
    requireChannelsWanted(ctx, p.components, p.interleaved ? "RGB datatype" : "dim[5]");
    const std::size_t frames = sizes[3] * p.components;
    const std::size_t payload = checkedByteCount(ctx.voxelCount(dims, frames, *st), sampleSize(*st), path);
    const std::size_t total = voxOffset + payload;
    std::vector<std::byte> inflated;
    std::span<const std::byte> all(file);
    if (gz) {
        inflated = inflateExact(file, total, path, "gzip data");
        all = inflated;
    } else if (file.size() != total) {
        fail(path, std::string(file.size() < total ? "truncated" : "oversized") + ": file has " +
                       std::to_string(file.size()) + " bytes, the header needs " + std::to_string(total));
    }
    TimeSeries series =
        p.interleaved
            ? decodeFrames(all.subspan(voxOffset, payload), *st, endian,
                           {p.components, dims.x * dims.y, dims.z}, 1, spacing, origin)
            : decodeFrames(all.subspan(voxOffset, payload), *st, endian, dims, frames, spacing, origin);
    if (p.interleaved) {
        Volume grid(dims, ScalarType::UInt8);
        grid.spacing = spacing;
        grid.origin = origin;
        series.frames = splitInterleaved(series.frames.front(), p.components, grid);
    }

    // The sform (else the qform) orients the grid in RAS; NIfTI is anatomical whatever its codes.
    const Direction3 direction = niftiDirection(p.meta);
    for (Volume& v : series.frames) {
        v.direction = direction;
        v.anatomical = true;
    }
    // scl_slope = 0 means "no scaling" by the standard; 1/0 is the identity. A caller asking for the
    // stored integers gets them when the model holds them exactly (the scale stays in the metadata).
    if (p.meta.scales() && !(ctx.options().niftiStoredValues && niftiStoredValuesExact(p.meta)))
        for (Volume& v : series.frames)
            v = niftiDataUnits(v, p.meta);
    if (p.components > 1)
        return channelsAsRequested(std::move(series.frames), ctx, p.interleaved ? "RGB datatype" : "dim[5]",
                                   p.interleaved);
    // pixdim[4] is the time step; xyzt_units says whether it is in s, ms or us. Times are in seconds.
    const double dt = p.meta.timeStep;
    if (frames > 1 && std::isfinite(dt) && dt > 0) {
        const int timeUnits = p.meta.xyztUnits & 0x38;
        const double scale = timeUnits == 16 ? 1e-3 : timeUnits == 24 ? 1e-6 : 1.0;
        for (std::size_t f = 0; f < frames; ++f)
            series.times.push_back(static_cast<double>(f) * dt * scale);
    }
    return series;
}

std::optional<SlabLayout> niftiSlabLayout(ReadContext& ctx) {
    const fs::path& path = ctx.file();
    const std::vector<std::byte> magic = readFilePrefix(path, 2, false);
    const bool gz = looksCompressed(magic);
    const std::vector<std::byte> head = readFilePrefix(path, kHeaderSize, gz);
    const ParsedHeader p = parseHeader(head, path);
    if (p.sizes[3] != 1 || p.components != 1) return std::nullopt; // a series or channels: read whole
    // Values scaled to data units become float32; stored integers stream only when the caller keeps them.
    if (p.meta.scales() && !(ctx.options().niftiStoredValues && niftiStoredValuesExact(p.meta)))
        return std::nullopt;
    const HeaderView h(head, p.endian != hostEndian());
    const std::size_t voxOffset = dataOffset(h, path);
    SlabLayout l;
    l.dataFile = path;
    l.gzip = gz;
    l.sampleType = p.sampleType;
    l.endian = p.endian;
    l.dims = {p.sizes[0], p.sizes[1], p.sizes[2]};
    l.spacing = p.meta.spacing;
    l.origin = p.meta.origin;
    l.direction = niftiDirection(p.meta);
    l.anatomical = true;
    const std::size_t payload =
        checkedByteCount(checkedVoxelCount(l.dims, 1, path), sampleSize(p.sampleType), path);
    if (gz) {
        l.skip = voxOffset;
        return l;
    }
    l.fileOffset = voxOffset;
    std::error_code ec;
    const std::uintmax_t size = fs::file_size(path, ec);
    if (ec) fail(path, "cannot determine the file size: " + ec.message());
    if (size != voxOffset + payload)
        fail(path, std::string(size < voxOffset + payload ? "truncated" : "oversized") + ": file has " +
                       std::to_string(size) + " bytes, the header needs " +
                       std::to_string(voxOffset + payload));
    return l;
}

} // namespace volcl::io

namespace volcl {

NiftiMetadata readNiftiMetadata(const std::filesystem::path& path) {
    // The header alone: the voxels of a volume larger than memory are never read here.
    const bool gz = io::looksCompressed(io::readFilePrefix(path, 2, false));
    return io::parseHeader(io::readFilePrefix(path, io::kHeaderSize, gz), path).meta;
}

std::optional<NiftiMetadata> readNiftiMetadataIfNifti(const std::filesystem::path& path) {
    if (detectVolumeFormat(path) != VolumeFormat::Nifti) return std::nullopt;
    return readNiftiMetadata(path);
}

} // namespace volcl
