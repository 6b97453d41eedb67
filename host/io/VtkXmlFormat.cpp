// VTK XML ImageData (.vti): inline ascii/base64 and appended raw/base64 arrays, zlib blocks, TimeStep.
#include "core/AtomicFile.hpp"
#include "core/Channels.hpp"
#include "host/io/IoDetail.hpp"
#include "host/io/VtkXmlArrays.hpp"
#include "host/io/XmlDocument.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>

namespace volcl::io {

namespace fs = std::filesystem;

namespace {

template <class T> double loadAsDouble(std::span<const std::byte> b, bool swap) {
    std::byte tmp[sizeof(T)];
    std::memcpy(tmp, b.data(), sizeof(T));
    if (swap) std::reverse(tmp, tmp + sizeof(T));
    T v;
    std::memcpy(&v, tmp, sizeof(T));
    return static_cast<double>(v);
}

// First value of a decoded array at full precision (TimeStep is usually Float64).
double firstValue(std::span<const std::byte> b, SampleType t, bool swap) {
    switch (t) {
    case SampleType::Int8:
        return loadAsDouble<std::int8_t>(b, swap);
    case SampleType::UInt8:
        return loadAsDouble<std::uint8_t>(b, swap);
    case SampleType::Int16:
        return loadAsDouble<std::int16_t>(b, swap);
    case SampleType::UInt16:
        return loadAsDouble<std::uint16_t>(b, swap);
    case SampleType::Int32:
        return loadAsDouble<std::int32_t>(b, swap);
    case SampleType::UInt32:
        return loadAsDouble<std::uint32_t>(b, swap);
    case SampleType::Int64:
        return loadAsDouble<std::int64_t>(b, swap);
    case SampleType::UInt64:
        return loadAsDouble<std::uint64_t>(b, swap);
    case SampleType::Float32:
        return loadAsDouble<float>(b, swap);
    case SampleType::Float64:
        return loadAsDouble<double>(b, swap);
    }
    return 0;
}

} // namespace

TimeSeries readVtkXmlImage(ReadContext& ctx) {
    const fs::path& path = ctx.file();
    const std::vector<std::byte> bytes = readFileBytes(path);
    VtkXmlDocument doc;
    parseVtkXml(doc, asText(bytes), path);
    const pugi::xml_node root = doc.root();
    if (root.name() != std::string_view("VTKFile"))
        fail(path, "not a VTK XML file (root element is <" + std::string(root.name()) + ">)");
    const std::string fileType = attr(root, "type").value_or("");
    if (fileType != "ImageData") unsupported(path, "VTK XML type '" + fileType + "' is not ImageData");

    const VtkXmlLayout L = vtkXmlLayout(root, path);

    const auto images = childrenNamed(root, "ImageData");
    if (images.size() != 1) fail(path, "expected one <ImageData> element");
    const pugi::xml_node image = images[0];
    const std::string extentText = attr(image, "WholeExtent").value_or("");
    const auto extentWords = splitWords(extentText);
    if (extentWords.size() != 6) fail(path, "ImageData WholeExtent needs 6 values");
    long long ext[6];
    for (int i = 0; i < 6; ++i)
        ext[i] = requireInt(extentWords[static_cast<std::size_t>(i)], path, "WholeExtent");
    std::size_t n[3];
    for (int a = 0; a < 3; ++a) {
        if (ext[2 * a + 1] < ext[2 * a]) fail(path, "WholeExtent is empty along axis " + std::to_string(a));
        n[a] = static_cast<std::size_t>(ext[2 * a + 1] - ext[2 * a]) + 1;
    }
    const Dims dims{n[0], n[1], n[2]};
    // The sample type is only known per array; the largest (8 bytes, converted to float32) bounds it.
    const std::size_t voxels = ctx.voxelCount(dims, 1, SampleType::Float64);
    std::array<double, 3> spacing{1, 1, 1}, origin{0, 0, 0};
    if (auto sp = attr(image, "Spacing")) spacing = requireTriple(splitWords(*sp), 0, path, "Spacing", true);
    if (auto o = attr(image, "Origin")) origin = requireTriple(splitWords(*o), 0, path, "Origin", false);
    // VTK 9 Direction (row-major, column c = index axis c): world = Origin + Direction * (ijk * Spacing).
    Direction3 direction = kIdentityDirection;
    if (auto d = attr(image, "Direction")) {
        const auto w = splitWords(*d);
        if (w.size() != 9) fail(path, "Direction has " + std::to_string(w.size()) + " values, not 9");
        for (std::size_t i = 0; i < 9; ++i) {
            direction[i] = requireDouble(w[i], path, "Direction");
            if (!std::isfinite(direction[i]))
                fail(path, "Direction: value " + std::string(w[i]) + " is not finite");
        }
        try {
            direction = orthonormalDirection(direction);
        } catch (const DataError& e) {
            fail(path, std::string("Direction: ") + e.what());
        }
    }
    for (std::size_t row = 0; row < 3; ++row) // extent may not start at 0
        for (std::size_t a = 0; a < 3; ++a)
            origin[row] += direction[3 * row + a] * static_cast<double>(ext[2 * a]) * spacing[a];

    const auto pieces = childrenNamed(image, "Piece");
    if (pieces.size() != 1)
        unsupported(path, std::to_string(pieces.size()) + " pieces: only single-piece files are supported");
    const pugi::xml_node piece = pieces[0];
    if (const auto pe = attr(piece, "Extent"); pe && splitWords(*pe) != extentWords)
        unsupported(path, "Piece Extent differs from WholeExtent");

    const VtkXmlPayload payload(doc, bytes, L);
    auto decodeArray = [&](pugi::xml_node da, std::size_t expectedBytes) {
        return payload.decode(da, expectedBytes);
    };
    auto arrayValues = [&](pugi::xml_node da) -> std::size_t {
        const std::size_t comps = static_cast<std::size_t>(std::max<long long>(
            1, requireInt(attr(da, "NumberOfComponents").value_or("1"), path, "NumberOfComponents")));
        return comps;
    };

    // The scalar array: PointData's active Scalars, else its first one-component array.
    const auto pointData = childrenNamed(piece, "PointData");
    if (pointData.empty()) unsupported(path, "no point data (cell data is not supported)");
    const std::string active = attr(pointData[0], "Scalars").value_or("");
    pugi::xml_node chosen;
    for (pugi::xml_node da : childrenNamed(pointData[0], "DataArray")) {
        if (!active.empty() ? attr(da, "Name").value_or("") == active : arrayValues(da) == 1) {
            chosen = da;
            break;
        }
    }
    // Without an active or one-component array, the first array with components gives the channels.
    if (!chosen && active.empty()) {
        const auto arrays = childrenNamed(pointData[0], "DataArray");
        if (!arrays.empty()) chosen = arrays.front();
    }
    if (!chosen)
        unsupported(path, "no scalar point-data array" +
                              (active.empty() ? std::string() : " named '" + active + "'"));
    const std::size_t components = arrayValues(chosen);
    if (components > 4096) fail(path, "NumberOfComponents " + std::to_string(components) + " is implausible");
    requireChannelsWanted(ctx, components, "NumberOfComponents");
    const std::string typeName = attr(chosen, "type").value_or("");
    const auto st = vtkXmlType(typeName);
    if (!st) unsupported(path, "array type '" + typeName + "' is not supported");

    // The payload is validated against the extent before the volume is allocated.
    // Components are interleaved per point: they decode as one volume {components, nx * ny, nz}.
    const std::size_t samplesTotal = components == 1 ? voxels : checkedVoxelCount(dims, components, path);
    ctx.claimMemory(checkedByteCount(samplesTotal, 2 * sizeof(float), path), "the point data");
    const Dims packed = components > 1 ? Dims{components, dims.x * dims.y, dims.z} : dims;
    Volume v;
    if (attr(chosen, "format").value_or("ascii") == "ascii") {
        const std::string samples = elementText(chosen);
        requireAsciiCapacity(samples, samplesTotal, path);
        v = Volume(packed, volumeTypeFor(*st));
        decodeAsciiSamples(samples, *st, v, 0, samplesTotal, path);
    } else {
        const std::vector<std::byte> data =
            decodeArray(chosen, checkedByteCount(samplesTotal, sampleSize(*st), path));
        v = Volume(packed, volumeTypeFor(*st));
        decodeSamples(data, *st, L.endian, v);
    }
    Volume grid(dims, ScalarType::UInt8);
    for (Volume* g : {&v, &grid}) {
        g->spacing = spacing;
        g->origin = origin;
        g->direction = direction;
    }
    if (components > 1) {
        const bool color =
            attr(chosen, "Name").value_or("") == "RGBA" || attr(chosen, "Name").value_or("") == "RGB";
        return channelsAsRequested(splitInterleaved(v, components, grid), ctx, "NumberOfComponents", color);
    }

    TimeSeries series;
    series.frames.push_back(std::move(v));
    // FieldData TimeStep (ParaView/TTK convention) gives the frame's time.
    for (pugi::xml_node fd : childrenNamed(image, "FieldData")) {
        for (pugi::xml_node da : childrenNamed(fd, "DataArray")) {
            if (attr(da, "Name").value_or("") != "TimeStep") continue;
            const auto tt = vtkXmlType(attr(da, "type").value_or(""));
            if (!tt) fail(path, "TimeStep array has an unknown type");
            if (attr(da, "format").value_or("ascii") == "ascii") {
                const std::string text = elementText(da);
                const auto words = splitWords(text);
                if (words.empty()) fail(path, "TimeStep array is empty");
                series.times.push_back(requireDouble(words[0], path, "TimeStep"));
            } else {
                const long long tuples =
                    requireInt(attr(da, "NumberOfTuples").value_or("1"), path, "NumberOfTuples");
                if (tuples < 1 || tuples > 1'000'000) fail(path, "TimeStep NumberOfTuples is invalid");
                const std::vector<std::byte> data =
                    decodeArray(da, static_cast<std::size_t>(tuples) * sampleSize(*tt));
                series.times.push_back(firstValue(data, *tt, L.swap));
            }
        }
    }
    return series;
}

} // namespace volcl::io
