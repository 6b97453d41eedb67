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
constexpr std::pair<ScalarType, std::int16_t> kTypeCodes[] = {
    {ScalarType::UInt8, 2}, {ScalarType::Int16, 4}, {ScalarType::UInt16, 512}, {ScalarType::Float32, 16}};

std::int16_t niftiCode(ScalarType t) {
    for (const auto& [type, code] : kTypeCodes)
        if (type == t) return code;
    return 0;
}

std::optional<ScalarType> integerTypeOfCode(std::int16_t c) {
    for (const auto& [type, code] : kTypeCodes)
        if (code == c && type != ScalarType::Float32) return type;
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
        break;
    }
    return std::nullopt;
}

} // namespace

void writeNifti(const Volume& volume, const fs::path& path, const WriteOptions& options) {
    for (std::size_t d : {volume.dims().x, volume.dims().y, volume.dims().z})
        if (d > static_cast<std::size_t>(std::numeric_limits<std::int16_t>::max()))
            throw UsageError(path.string() +
                             ": NIfTI-1 holds at most 32767 voxels per axis, the volume has " +
                             std::to_string(d));
    const NiftiMetadata m =
        options.nifti ? niftiMetadataOnGrid(*options.nifti, volume) : niftiMetadataForVolume(volume);

    // Values are data units. A float volume from a scaled integer file goes back to its stored integers
    // with the same scl_slope/scl_inter when that is exact; otherwise the floats are written unscaled.
    const Volume* data = &volume;
    std::optional<Volume> stored;
    float slope = m.scales() ? 1.0f : m.sclSlope, inter = m.scales() ? 0.0f : m.sclInter;
    if (m.scales() && volume.type() == ScalarType::Float32)
        if (const auto t = integerTypeOfCode(m.datatype))
            if ((stored = unscaled(volume, *t, m.sclSlope, m.sclInter))) {
                data = &*stored;
                slope = m.sclSlope;
                inter = m.sclInter;
            }

    std::vector<std::byte> file(kDataOffset, std::byte{0});
    put<std::int32_t>(file, 0, static_cast<std::int32_t>(kHeaderSize));
    file[38] = std::byte{'r'};
    const std::int16_t dim[8] = {3,
                                 static_cast<std::int16_t>(volume.dims().x),
                                 static_cast<std::int16_t>(volume.dims().y),
                                 static_cast<std::int16_t>(volume.dims().z),
                                 1,
                                 1,
                                 1,
                                 1};
    for (int i = 0; i < 8; ++i)
        put(file, 40 + 2 * i, dim[i]);
    for (int i = 0; i < 3; ++i)
        put(file, 56 + 4 * i, m.intentP[i]);
    put(file, 68, m.intentCode);
    put(file, 70, niftiCode(data->type()));
    put<std::int16_t>(file, 72, static_cast<std::int16_t>(8 * scalarSize(data->type())));
    const float pixdim[8] = {m.qfac, m.pixdim[0], m.pixdim[1], m.pixdim[2], m.timeStep, 0, 0, 0};
    for (int i = 0; i < 8; ++i)
        put(file, 76 + 4 * i, pixdim[i]);
    put(file, 108, static_cast<float>(kDataOffset));
    put(file, 112, slope);
    put(file, 116, inter);
    file[123] = std::byte{m.xyztUnits};
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
        const std::vector<std::byte> voxels = bytesInOrder(*data, Endian::Little);
        file.insert(file.end(), voxels.begin(), voxels.end());
        writeFileAtomically(path, file);
        return;
    }
    AtomicFile out(path);
    out.write(file);
    writeVoxelsInOrder(out, *data, Endian::Little);
    out.commit();
}

} // namespace volcl::io
