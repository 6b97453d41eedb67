// Streaming lossless encoder: each brick row is coded by the in-memory encoder (bricks are coded
// independently, so a row's payloads are the whole volume's), its payloads appended to the output and its
// index entries and statistics kept; the header and index go in front at the end.
#include "wavelet/stream/StreamEncoder.hpp"

#include "core/Error.hpp"
#include "wavelet/container/LodStatistics.hpp"
#include "wavelet/container/VczFormat.hpp"

#include <algorithm>
#include <limits>

namespace volcl {

namespace {

void writeOrThrow(std::ostream& out, const void* data, std::size_t n, const std::string& name) {
    out.write(static_cast<const char*>(data), std::streamsize(n));
    if (!out) throw IoError(name + ": cannot write");
}

} // namespace

StreamEncodeReport encodeStreaming(ComputeContext& cc, const VolumeSource& source,
                                   const CodecOptions& options, bool lodStatistics, std::ostream& out,
                                   const std::string& name) {
    if (options.rate != RateMode::Lossless)
        throw UsageError("streaming encode is lossless only: a lossy rate search needs the whole volume");
    if (source.type == ScalarType::Float32)
        throw UsageError(
            "streaming encode needs integer voxels: float32 is kept as raw bits over the whole volume");
    if (source.dims.count() == 0) throw UsageError("cannot encode an empty volume");
    if (!source.fill) throw Error("internal: a volume source without a fill function");

    // Every row is coded with the brick asked for: the whole file shares one brick grid.
    CodecOptions rowOptions = options;
    rowOptions.chooseExtent = false;
    // The whole volume's header: brick grid and index size follow from dims and options alone.
    VczHeader h;
    h.dims = source.dims;
    h.brick = options.brick;
    const Dims grid = h.brickGrid();
    const std::size_t nb = grid.count(), perRow = grid.x, rows = grid.y * grid.z;
    h.bricks.assign(1, std::vector<VczBrickEntry>(nb));
    h.frames.resize(1);
    h.metadata = options.metadata;
    addPlacementMetadata(h.metadata, source.direction, source.anatomical);
    LodStatistics stats;
    stats.levels = options.levels;
    if (lodStatistics) {
        // The serialisation's size depends only on the entry count, so zero-valued statistics of the final
        // count bound the preamble's.
        stats.frames.assign(1, std::vector<BrickLevelStats>(nb * std::size_t(options.levels + 1)));
        h.metadata[std::string(kVczLodKey)] = stats.serialise();
    }
    // Payload sizes and ranges are known only at the end: the room reserved is a bound, padded at the end.
    const std::size_t preamble = vczPreambleBound(h);
    // Room for the preamble (zeros now, overwritten at the end: any stream that can seek back will do).
    const std::vector<char> room(preamble, 0);
    writeOrThrow(out, room.data(), room.size(), name);

    StreamEncodeReport report;
    std::size_t offset = preamble;
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (std::size_t r = 0; r < rows; ++r) {
        const Dims at{0, (r % grid.y) * h.brick.y, (r / grid.y) * h.brick.z};
        Volume row({source.dims.x, std::min(h.brick.y, source.dims.y - at.y),
                    std::min(h.brick.z, source.dims.z - at.z)},
                   source.type);
        row.spacing = source.spacing;
        row.origin = source.origin;
        row.direction = source.direction;
        row.anatomical = source.anatomical;
        source.fill(at, row);
        report.rowBytes = std::max(report.rowBytes, row.byteSize());
        std::vector<std::byte> coded = encodeVolume(cc, row, rowOptions);
        const VczHeader rh = readVczHeader(coded, name);
        if (r == 0) {
            // Everything the options decide (wavelet, transform, levels, entropy, steps) as the encoder set
            // it.
            VczHeader full = rh;
            full.dims = h.dims;
            full.spacing = source.spacing;
            full.origin = source.origin;
            full.bricks = std::move(h.bricks);
            full.metadata = h.metadata;
            h = std::move(full);
        }
        // A row's voxel-coded bricks (chosen by size, as in the whole-volume encode) make the file version 7.
        if (rh.voxelBricks) h.voxelBricks = true;
        if (rh.transform != TransformKind::IntegerLifting)
            throw UsageError("streaming encode needs a reversible integer transform");
        for (std::size_t i = 0; i < perRow; ++i) {
            const std::span<const std::uint8_t> p = vczBrickPayload(coded, rh, 0, i, name);
            VczBrickEntry e = rh.bricks[0][i];
            e.offset = offset;
            writeOrThrow(out, p.data(), p.size(), name);
            offset += p.size();
            lo = std::min(lo, e.min);
            hi = std::max(hi, e.max);
            h.bricks[0][r * perRow + i] = e;
        }
        if (lodStatistics) {
            // Measured on the row's own file; only the statistics are kept, the row is not rewritten.
            const LodStatistics rs = measureLodStatistics(cc, coded, std::span(&row, 1), name);
            const std::size_t n = std::size_t(options.levels + 1);
            std::copy_n(rs.frames[0].begin(), perRow * n,
                        stats.frames[0].begin() + std::ptrdiff_t(r * perRow * n));
        }
        ++report.rows;
    }
    h.valueMin = lo;
    h.valueMax = hi;
    if (lodStatistics) h.metadata[std::string(kVczLodKey)] = stats.serialise();
    const std::vector<std::byte> head = writeVcz(h, {}, preamble);
    if (head.size() != preamble) throw Error("internal: the streamed header changed size");
    out.seekp(0);
    if (!out) throw IoError(name + ": cannot seek back to write the header");
    writeOrThrow(out, head.data(), head.size(), name);
    out.flush();
    if (!out) throw IoError(name + ": cannot write");
    report.bytes = offset;
    return report;
}

} // namespace volcl
