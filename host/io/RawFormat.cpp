// Headerless raw volumes (optionally gzipped): dims/type from the file name or ReadOptions.
#include "core/AtomicFile.hpp"
#include "host/io/IoDetail.hpp"

namespace volcl::io {

namespace fs = std::filesystem;

TimeSeries readRaw(ReadContext& ctx) {
    const fs::path& path = ctx.file();
    const ReadOptions& options = ctx.options();
    const auto fromName = parseRawFileName(path.filename().string());
    std::optional<Dims> dims = options.dims;
    std::optional<ScalarType> type = options.type;
    if (fromName) {
        if (!dims) dims = fromName->first;
        if (!type) type = fromName->second;
    }
    if (!dims || !type)
        throw UsageError(path.string() +
                         ": a raw file needs its size and type: name it <name>_<X>x<Y>x<Z>_<type>.raw "
                         "or give --dims and --type");
    const SampleType st = sampleTypeOf(*type);
    const std::size_t voxels = ctx.voxelCount(*dims, 1, st);
    const std::size_t payload = checkedByteCount(voxels, sampleSize(st), path);
    const std::size_t expected = payload + options.headerBytes;
    const std::string what = std::to_string(dims->x) + "x" + std::to_string(dims->y) + "x" +
                             std::to_string(dims->z) + " " + std::string(scalarTypeName(*type));

    std::error_code ec;
    const std::uintmax_t fileSize = fs::file_size(path, ec);
    if (ec) fail(path, "cannot determine the file size: " + ec.message());
    const std::string name = path.filename().string();
    const bool gz = endsWithI(name, ".gz") || endsWithI(name, "-gz");
    if (!gz && fileSize != expected)
        fail(path, std::string(fileSize < expected ? "truncated" : "oversized") + ": file has " +
                       std::to_string(fileSize) + " bytes, " + what + " needs " + std::to_string(expected) +
                       (options.headerBytes
                            ? " (including " + std::to_string(options.headerBytes) + " header bytes)"
                            : ""));
    std::vector<std::byte> bytes = readFileBytes(path);
    if (gz) bytes = inflateExact(bytes, expected, path, "gzip data for " + what);
    Volume v(*dims, *type);
    decodeSamples(std::span<const std::byte>(bytes).subspan(options.headerBytes), st, options.endian, v);
    TimeSeries series;
    series.frames.push_back(std::move(v));
    return series;
}

std::optional<SlabLayout> rawSlabLayout(ReadContext& ctx) {
    const fs::path& path = ctx.file();
    const ReadOptions& options = ctx.options();
    const auto fromName = parseRawFileName(path.filename().string());
    const std::optional<Dims> dims = options.dims ? options.dims
                                     : fromName   ? std::optional(fromName->first)
                                                  : std::nullopt;
    const std::optional<ScalarType> type = options.type ? options.type
                                           : fromName   ? std::optional(fromName->second)
                                                        : std::nullopt;
    if (!dims || !type) return std::nullopt; // readRaw refuses it with its usage message
    SlabLayout l;
    l.dataFile = path;
    l.sampleType = sampleTypeOf(*type);
    l.endian = options.endian;
    l.dims = *dims;
    const std::size_t payload =
        checkedByteCount(checkedVoxelCount(*dims, 1, path), sampleSize(l.sampleType), path);
    const std::string name = path.filename().string();
    l.gzip = endsWithI(name, ".gz") || endsWithI(name, "-gz");
    if (l.gzip) {
        l.skip = options.headerBytes;
        return l;
    }
    l.fileOffset = options.headerBytes;
    std::error_code ec;
    const std::uintmax_t fileSize = fs::file_size(path, ec);
    if (ec) fail(path, "cannot determine the file size: " + ec.message());
    if (fileSize != payload + options.headerBytes)
        fail(path, std::string(fileSize < payload + options.headerBytes ? "truncated" : "oversized") +
                       ": file has " + std::to_string(fileSize) + " bytes, " + std::to_string(dims->x) + "x" +
                       std::to_string(dims->y) + "x" + std::to_string(dims->z) + " " +
                       std::string(scalarTypeName(*type)) + " needs " +
                       std::to_string(payload + options.headerBytes));
    return l;
}

void writeRaw(const Volume& volume, const fs::path& path, const WriteOptions& options) {
    if (endsWithI(path.filename().string(), ".gz")) {
        writeFileAtomically(path, bytesInOrder(volume, options.endian));
        return;
    }
    AtomicFile out(path);
    writeVoxelsInOrder(out, volume, options.endian);
    out.commit();
}

} // namespace volcl::io
