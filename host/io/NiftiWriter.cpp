// NIfTI-1 single-file writer (.nii, .nii.gz): orientation, units, intent and scaling from NiftiMetadata.
#include "host/io/IoDetail.hpp"
#include "host/io/NiftiMetadata.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>

namespace volcl::io {

namespace fs = std::filesystem;

namespace {

constexpr std::size_t kHeaderSize = 348, kDataOffset = 352; // 4 zero bytes: no extensions

// NIfTI datatype codes of the model's types.
constexpr std::pair<ScalarType, std::int16_t> kTypeCodes[] = {{ScalarType::UInt8, 2},
                                                              {ScalarType::Int16, 4},
                                                              {ScalarType::UInt16, 512},
                                                              {ScalarType::Float32, 16},
                                                              {ScalarType::Float64, 64}};

std::int16_t niftiCode(ScalarType t) {
    for (const auto& [type, code] : kTypeCodes)
        if (type == t) return code;
    return 0;
}

std::optional<ScalarType> integerTypeOfCode(std::int16_t c) {
    for (const auto& [type, code] : kTypeCodes)
        if (code == c && !isFloatType(type)) return type;
    return std::nullopt;
}

template <class T> void put(std::vector<std::byte>& h, std::size_t offset, T v) {
    static_assert(std::endian::native == std::endian::little, "the header is written in host byte order");
    std::memcpy(h.data() + offset, &v, sizeof(T));
}

void putText(std::vector<std::byte>& h, std::size_t offset, std::size_t size, const std::string& s) {
    std::memcpy(h.data() + offset, s.data(), std::min(s.size(), size - 1));
}

// The stored integers of a float volume read from a scaled integer file: each value v must come back
// bit for bit from the reader's float(stored * slope + inter). Nullopt when any voxel does not (lossy
// decodes, edits), so the caller writes float32 instead.
template <class T> std::optional<Volume> unscaled(const Volume& v, double slope, double inter) {
    Volume out(v.dims(), scalarTypeOf<T>());
    out.spacing = v.spacing;
    out.origin = v.origin;
    const auto in = v.values<float>();
    auto dst = out.values<T>();
    for (std::size_t i = 0; i < in.size(); ++i) {
        const double raw = std::nearbyint((static_cast<double>(in[i]) - inter) / slope);
        if (!(raw >= std::numeric_limits<T>::min() && raw <= std::numeric_limits<T>::max()))
            return std::nullopt;
        if (static_cast<float>(raw * slope + inter) != in[i]) return std::nullopt;
        dst[i] = static_cast<T>(raw);
    }
    return out;
}

std::optional<Volume> unscaled(const Volume& v, ScalarType stored, double slope, double inter) {
    switch (stored) {
    case ScalarType::UInt8:
        return unscaled<std::uint8_t>(v, slope, inter);
    case ScalarType::Int16:
        return unscaled<std::int16_t>(v, slope, inter);
    case ScalarType::UInt16:
        return unscaled<std::uint16_t>(v, slope, inter);
    case ScalarType::Float32:
    case ScalarType::Float64:
        break;
    }
    return std::nullopt;
}

// pixdim[4] and xyzt_units of the output: the source's time step as stored, else the series' even
// time step in seconds (NIFTI_UNITS_SEC), else none.
std::pair<float, std::uint8_t> timeStepOf(const NiftiMetadata& m, const std::vector<double>& times,
                                          std::size_t frames) {
    if (m.timeStep > 0 || frames < 2 || times.size() != frames) return {m.timeStep, m.xyztUnits};
    const double dt = times[1] - times[0];
    if (!(dt > 0) || !std::isfinite(dt)) return {m.timeStep, m.xyztUnits};
    for (std::size_t f = 2; f < frames; ++f)
        if (std::abs((times[f] - times[f - 1]) - dt) > 1e-9 * std::max(1.0, std::abs(dt)))
            return {m.timeStep, m.xyztUnits};
    constexpr std::uint8_t kSeconds = 8;
    return {static_cast<float>(dt), static_cast<std::uint8_t>((m.xyztUnits & 0x07) | kSeconds)};
}

} // namespace

namespace {

// One NIfTI writer for a volume, a series (dim[4] = frames) and channels (`asChannels`: dim[4] = 1,
// dim[5] = channels, intent vector): both store whole volumes one after another.
void writeNiftiVolumes(std::span<const Volume> frames, const std::vector<double>& times, const fs::path& path,
                       const WriteOptions& options, bool asChannels) {
    const Volume& first = frames.front();
    for (std::size_t d : {first.dims().x, first.dims().y, first.dims().z, frames.size()})
        if (d > static_cast<std::size_t>(std::numeric_limits<std::int16_t>::max()))
            throw UsageError(path.string() +
                             ": NIfTI-1 holds at most 32767 voxels per axis and frames, the " +
                             "volume has " + std::to_string(d));
    for (const Volume& v : frames)
        if (v.dims() != first.dims() || v.type() != first.type())
            throw UsageError(path.string() +
                             ": the frames or channels of a NIfTI must share dims and voxel type");
    const NiftiMetadata m =
        options.nifti ? niftiMetadataOnGrid(*options.nifti, first) : niftiMetadataForVolume(first);
    // NIfTI-1 stores geometry as float32: a spacing that rounds to 0 or overflows to inf, or an origin
    // that overflows, would give a file that no reader (volcl included) accepts.
    for (int a = 0; a < 3; ++a)
        if (!std::isfinite(m.pixdim[a]) || !(m.pixdim[a] > 0))
            throw UsageError(path.string() + ": spacing " + io::formatDouble(first.spacing[a]) +
                             " is not representable in NIfTI-1 (a positive finite float32)");
    for (int row = 0; row < 3; ++row) {
        bool finite = std::isfinite(m.qoffset[row]);
        for (int col = 0; col < 4; ++col)
            finite = finite && std::isfinite(m.srow[row][col]);
        if (!finite)
            throw UsageError(path.string() + ": origin " + io::formatDouble(first.origin[row]) +
                             " or spacing is not representable in NIfTI-1 (float32)");
    }

    // Values are data units, unless the caller holds the stored integers of a scaled source. A float
    // volume from a scaled integer file goes back to its stored integers with the same scl_slope/scl_inter
    // when that is exact for every frame; otherwise the floats are written unscaled.
    std::span<const Volume> data = frames;
    std::vector<Volume> stored;
    float slope = m.scales() ? 1.0f : m.sclSlope, inter = m.scales() ? 0.0f : m.sclInter;
    const auto intType = integerTypeOfCode(m.datatype);
    if (m.scales() && options.niftiStoredValues && intType && first.type() == *intType) {
        slope = m.sclSlope;
        inter = m.sclInter;
    } else if (m.scales() && first.type() == ScalarType::Float32 && intType) {
        for (const Volume& v : frames) {
            std::optional<Volume> u = unscaled(v, *intType, m.sclSlope, m.sclInter);
            if (!u) break;
            stored.push_back(std::move(*u));
        }
        if (stored.size() == frames.size()) {
            data = stored;
            slope = m.sclSlope;
            inter = m.sclInter;
        }
    } else if (options.niftiStoredValues && m.scales()) {
        throw UsageError(path.string() + ": stored " + std::string(scalarTypeName(first.type())) +
                         " values do not match the NIfTI datatype " + std::to_string(m.datatype));
    }
    const ScalarType type = data.front().type();
    const auto [timeStep, xyztUnits] = timeStepOf(m, times, frames.size());

    std::vector<std::byte> file(kDataOffset, std::byte{0});
    put<std::int32_t>(file, 0, static_cast<std::int32_t>(kHeaderSize));
    file[38] = std::byte{'r'};
    const bool series = frames.size() > 1 && !asChannels;
    const auto count = static_cast<std::int16_t>(frames.size());
    const std::int16_t dim[8] = {static_cast<std::int16_t>(asChannels ? 5
                                                           : series   ? 4
                                                                      : 3),
                                 static_cast<std::int16_t>(first.dims().x),
                                 static_cast<std::int16_t>(first.dims().y),
                                 static_cast<std::int16_t>(first.dims().z),
                                 asChannels ? std::int16_t{1} : count,
                                 asChannels ? count : std::int16_t{1},
                                 1,
                                 1};
    for (int i = 0; i < 8; ++i)
        put(file, 40 + 2 * i, dim[i]);
    for (int i = 0; i < 3; ++i)
        put(file, 56 + 4 * i, m.intentP[i]);
    constexpr std::int16_t kIntentVector = 1007; // NIFTI_INTENT_VECTOR: dim[5] holds a voxel's components
    put(file, 68, asChannels ? kIntentVector : m.intentCode);
    put(file, 70, niftiCode(type));
    put<std::int16_t>(file, 72, static_cast<std::int16_t>(8 * scalarSize(type)));
    const float pixdim[8] = {m.qfac, m.pixdim[0], m.pixdim[1], m.pixdim[2], timeStep, 0, 0, 0};
    for (int i = 0; i < 8; ++i)
        put(file, 76 + 4 * i, pixdim[i]);
    put(file, 108, static_cast<float>(kDataOffset));
    put(file, 112, slope);
    put(file, 116, inter);
    file[123] = std::byte{xyztUnits};
    put(file, 124, m.calMax);
    put(file, 128, m.calMin);
    put(file, 136, m.toffset);
    putText(file, 148, 80, m.descrip);
    put(file, 252, m.qformCode);
    put(file, 254, m.sformCode);
    put(file, 256, m.quaternB);
    put(file, 260, m.quaternC);
    put(file, 264, m.quaternD);
    for (int i = 0; i < 3; ++i) {
        put(file, 268 + 4 * i, m.qoffset[i]);
        for (int j = 0; j < 4; ++j)
            put(file, 280 + 16 * i + 4 * j, m.srow[i][j]);
    }
    putText(file, 328, 16, m.intentName);
    std::memcpy(file.data() + 344, "n+1\0", 4);
    if (endsWithI(path.filename().string(), ".gz")) {
        for (const Volume& v : data) {
            const std::vector<std::byte> voxels = bytesInOrder(v, Endian::Little);
            file.insert(file.end(), voxels.begin(), voxels.end());
        }
        writeFileAtomically(path, file);
        return;
    }
    AtomicFile out(path);
    out.write(file);
    for (const Volume& v : data)
        writeVoxelsInOrder(out, v, Endian::Little);
    out.commit();
}

} // namespace

void writeNiftiSeries(std::span<const Volume> frames, const std::vector<double>& times, const fs::path& path,
                      const WriteOptions& options) {
    writeNiftiVolumes(frames, times, path, options, false);
}

void writeNiftiChannels(const ChannelVolume& channels, const fs::path& path, const WriteOptions& options) {
    for (const Volume& c : channels.channels)
        if (c.type() != channels.channels.front().type())
            throw UsageError(path.string() + ": channels of different types cannot share one NIfTI file");
    writeNiftiVolumes(channels.channels, {}, path, options, true);
}

void writeNifti(const Volume& volume, const fs::path& path, const WriteOptions& options) {
    writeNiftiSeries(std::span<const Volume>(&volume, 1), {}, path, options);
}

} // namespace volcl::io
