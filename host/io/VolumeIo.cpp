// Volume file dispatch: format detection from extension and magic bytes, raw file-name parsing.
#include "host/io/VolumeIo.hpp"

#include "core/AtomicFile.hpp"
#include "core/Error.hpp"
#include "host/io/IoDetail.hpp"
#include "host/io/Series.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <fstream>

namespace volcl {

namespace fs = std::filesystem;
using io::endsWithI;

std::string_view volumeFormatName(VolumeFormat f) noexcept {
    switch (f) {
    case VolumeFormat::Raw:
        return "raw";
    case VolumeFormat::Nrrd:
        return "NRRD";
    case VolumeFormat::MetaImage:
        return "MetaImage";
    case VolumeFormat::Nifti:
        return "NIfTI-1";
    case VolumeFormat::VtkXmlImage:
        return "VTK XML ImageData";
    case VolumeFormat::VtkLegacy:
        return "legacy VTK";
    case VolumeFormat::Slc:
        return "VolVis SLC";
    case VolumeFormat::Vdb:
        return "OpenVDB";
    case VolumeFormat::InviwoDat:
        return "Inviwo dat";
    case VolumeFormat::VoreenVvd:
        return "Voreen vvd";
    case VolumeFormat::Npy:
        return "numpy npy";
    case VolumeFormat::Dicom:
        return "DICOM";
    }
    return "unknown";
}

namespace {

std::optional<VolumeFormat> formatFromExtension(std::string_view name) {
    struct Ext {
        std::string_view suffix;
        VolumeFormat format;
    };
    // Longer suffixes first so ".nii.gz" wins over ".gz".
    static constexpr Ext table[] = {
        {".nii.gz", VolumeFormat::Nifti},    {".raw.gz", VolumeFormat::Raw},
        {".bin-gz", VolumeFormat::Raw},      {".raw", VolumeFormat::Raw},
        {".bin", VolumeFormat::Raw},         {".nrrd", VolumeFormat::Nrrd},
        {".nhdr", VolumeFormat::Nrrd},       {".mhd", VolumeFormat::MetaImage},
        {".mha", VolumeFormat::MetaImage},   {".nii", VolumeFormat::Nifti},
        {".vti", VolumeFormat::VtkXmlImage}, {".vtk", VolumeFormat::VtkLegacy},
        {".slc", VolumeFormat::Slc},         {".vdb", VolumeFormat::Vdb},
        {".dat", VolumeFormat::InviwoDat},   {".vvd", VolumeFormat::VoreenVvd},
        {".npy", VolumeFormat::Npy},         {".dcm", VolumeFormat::Dicom},
        {".dicom", VolumeFormat::Dicom},
    };
    for (const Ext& e : table)
        if (endsWithI(name, e.suffix)) return e.format;
    return std::nullopt;
}

std::optional<VolumeFormat> formatFromMagic(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) return std::nullopt;
    char head[512] = {};
    in.read(head, sizeof(head));
    const std::size_t n = static_cast<std::size_t>(in.gcount());
    const std::string_view h(head, n);
    if (h.starts_with("NRRD000")) return VolumeFormat::Nrrd;
    if (h.starts_with("# vtk DataFile")) return VolumeFormat::VtkLegacy;
    if (h.find("<VTKFile") != std::string_view::npos) return VolumeFormat::VtkXmlImage;
    if (h.find("<VoreenData") != std::string_view::npos) return VolumeFormat::VoreenVvd;
    if (h.starts_with("ObjectFileName")) return VolumeFormat::InviwoDat;
    if (h.starts_with("ObjectType") || h.starts_with("NDims")) return VolumeFormat::MetaImage;
    if (n >= 4 && std::memcmp(head, "\x20\x42\x44\x56", 4) == 0) return VolumeFormat::Vdb;
    if (h.starts_with("11111")) return VolumeFormat::Slc;
    if (h.starts_with("\x93NUMPY")) return VolumeFormat::Npy;
    if (n >= 132 && h.substr(128, 4) == "DICM") return VolumeFormat::Dicom;
    if (n >= 348) {
        std::int32_t sz = 0;
        std::memcpy(&sz, head, 4);
        const std::int32_t swapped =
            static_cast<std::int32_t>(__builtin_bswap32(static_cast<std::uint32_t>(sz)));
        if ((sz == 348 || swapped == 348) && (h.substr(344, 3) == "n+1" || h.substr(344, 3) == "ni1"))
            return VolumeFormat::Nifti;
    }
    return std::nullopt;
}

} // namespace

VolumeFormat detectVolumeFormat(const fs::path& path) {
    std::error_code ec;
    // A folder, or a pattern naming files, is a DICOM series (no other format spans several files so).
    if (fs::is_directory(path, ec) || (!fs::exists(path, ec) && hasGlobPattern(path.string())))
        return VolumeFormat::Dicom;
    const std::string name = path.filename().string();
    if (auto f = formatFromExtension(name)) return *f;
    if (fs::is_regular_file(path, ec)) {
        if (auto f = formatFromMagic(path)) return *f;
        if (parseRawFileName(name)) return VolumeFormat::Raw;
    } else if (!fs::exists(path, ec)) {
        if (parseRawFileName(name)) return VolumeFormat::Raw;
        throw IoError(path.string() + ": file does not exist");
    }
    throw IoError(
        path.string() +
        ": unknown volume format (supported: .raw .raw.gz .nrrd .nhdr .mhd .mha .nii .nii.gz .vti .vtk "
        ".slc .vdb .dat .vvd .npy, DICOM files or folders)");
}

namespace {

// What a read found besides its frames: the file's components per voxel and whether they are colour.
struct ChannelsFound {
    std::size_t count = 1;
    bool color = false;
};

TimeSeries readFrames(const fs::path& path, const ReadOptions& options, std::vector<fs::path>& filesRead,
                      ChannelsFound& found) {
    // A series a killed volcl left half moved is completed first: a reader never sees it mixed.
    completeInterruptedCommit(path);
    const VolumeFormat format = detectVolumeFormat(path);
    // Before any format probe opens it: a FIFO would block the first read, a device never end. (A DICOM
    // input may be a folder or a pattern; each of its files is checked as it is listed.)
    std::error_code ec;
    if (format != VolumeFormat::Dicom || (fs::exists(path, ec) && !fs::is_directory(path, ec)))
        requireRegularFile(path);
    io::ReadContext ctx(path, options);
    std::vector<fs::path> dicomFiles;
    TimeSeries series;
    switch (format) {
    case VolumeFormat::Raw:
        series = io::readRaw(ctx);
        break;
    case VolumeFormat::Nrrd:
        series = io::readNrrd(ctx);
        break;
    case VolumeFormat::MetaImage:
        series = io::readMetaImage(ctx);
        break;
    case VolumeFormat::Nifti:
        series = io::readNifti(ctx);
        break;
    case VolumeFormat::VtkXmlImage:
        series = io::readVtkXmlImage(ctx);
        break;
    case VolumeFormat::VtkLegacy:
        series = io::readVtkLegacy(ctx);
        break;
    case VolumeFormat::Slc:
        series = io::readSlc(ctx);
        break;
    case VolumeFormat::Vdb:
        series = io::readVdb(ctx);
        break;
    case VolumeFormat::InviwoDat:
        series = io::readInviwoDat(ctx);
        break;
    case VolumeFormat::VoreenVvd:
        series = io::readVoreenVvd(ctx);
        break;
    case VolumeFormat::Npy:
        series = io::readNpy(ctx);
        break;
    case VolumeFormat::Dicom:
        series = io::readDicom(path, options, dicomFiles);
        break;
    }
    if (series.frames.empty()) throw IoError(path.string() + ": contains no volume");
    found = {ctx.channels(), ctx.colorChannels()};
    if (options.channel && *options.channel > 0 && found.count == 1)
        throw UsageError(path.string() + ": --channel " + std::to_string(*options.channel) +
                         " of a file with one channel (only channel 0)");
    // Every format's geometry passes one check: a NaN spacing or origin would poison every position.
    for (const Volume& v : series.frames)
        for (int a = 0; a < 3; ++a) {
            if (!std::isfinite(v.spacing[a]) || !(v.spacing[a] > 0))
                io::fail(path, "voxel spacing " + io::formatDouble(v.spacing[a]) +
                                   " is not a positive finite number");
            if (!std::isfinite(v.origin[a]))
                io::fail(path, "origin " + io::formatDouble(v.origin[a]) + " is not finite");
        }
    series.validate();
    filesRead = format == VolumeFormat::Dicom ? std::move(dicomFiles) : ctx.files();
    return series;
}

} // namespace

TimeSeries readVolumeFile(const fs::path& path, const ReadOptions& options,
                          std::vector<fs::path>& filesRead) {
    ChannelsFound found;
    return readFrames(path, options, filesRead, found);
}

TimeSeries readVolumeFile(const fs::path& path, const ReadOptions& options, std::size_t& channels) {
    std::vector<fs::path> filesRead;
    ChannelsFound found;
    TimeSeries series = readFrames(path, options, filesRead, found);
    channels = found.count;
    return series;
}

TimeSeries readVolumeFile(const fs::path& path, const ReadOptions& options) {
    std::vector<fs::path> filesRead;
    return readVolumeFile(path, options, filesRead);
}

ChannelVolume readVolumeChannels(const fs::path& path, ReadOptions options) {
    options.allChannels = true;
    options.channel.reset();
    std::vector<fs::path> filesRead;
    ChannelsFound found;
    TimeSeries series = readFrames(path, options, filesRead, found);
    if (found.count == 1 && series.frames.size() > 1)
        throw DataError(path.string() + ": " + std::to_string(series.frames.size()) +
                        " time frames, not channels: choose a frame");
    ChannelVolume out;
    out.channels = std::move(series.frames);
    out.color = found.color;
    out.validate();
    return out;
}

Volume readVolume(const fs::path& path, const ReadOptions& options) {
    TimeSeries series = readVolumeFile(path, options);
    return std::move(series.frames.front());
}

namespace {

bool isNiftiName(const std::string& name) {
    return io::endsWithI(name, ".nii") || io::endsWithI(name, ".nii.gz");
}

bool isNrrdName(const std::string& name) {
    return io::endsWithI(name, ".nrrd") || io::endsWithI(name, ".nhdr");
}

bool isNpyName(const std::string& name) {
    return io::endsWithI(name, ".npy");
}

} // namespace

void writeVolumeFile(const Volume& volume, const fs::path& path, const WriteOptions& options) {
    if (volume.empty()) throw UsageError(path.string() + ": cannot write an empty volume");
    const std::string name = path.filename().string();
    // Stored integers of a scaled NIfTI source: only a NIfTI output keeps the scale beside them, every
    // other format gets the data units a reader of the source sees.
    if (options.niftiStoredValues && options.nifti && options.nifti->scales() && !isNiftiName(name)) {
        WriteOptions plain = options;
        plain.niftiStoredValues = false;
        writeVolumeFile(niftiDataUnits(volume, *options.nifti), path, plain);
        return;
    }
    if (endsWithI(name, ".raw") || endsWithI(name, ".raw.gz") || endsWithI(name, ".bin"))
        io::writeRaw(volume, path, options);
    else if (endsWithI(name, ".nrrd") || endsWithI(name, ".nhdr"))
        io::writeNrrd(volume, path, options);
    else if (endsWithI(name, ".nii") || endsWithI(name, ".nii.gz"))
        io::writeNifti(volume, path, options);
    else if (endsWithI(name, ".vti"))
        io::writeVtkXmlImage(volume, path, options);
    else if (endsWithI(name, ".vdb"))
        io::writeVdb(volume, path, options);
    else if (isNpyName(name))
        io::writeNpy(std::span<const Volume>(&volume, 1), path, options);
    else
        throw UsageError(path.string() + ": cannot write this format (writers: .raw, .raw.gz, .nrrd, .nhdr, "
                                         ".nii, .nii.gz, .vti, .vdb, .npy)");
}

bool formatHoldsSeries(const fs::path& path) {
    const std::string name = path.filename().string();
    return isNiftiName(name) || isNrrdName(name) || isNpyName(name);
}

void writeSeriesFile(const TimeSeries& series, const fs::path& path, const WriteOptions& options) {
    if (series.frames.empty()) throw UsageError(path.string() + ": cannot write a series without frames");
    if (series.frames.size() == 1) {
        writeVolumeFile(series.frames.front(), path, options);
        return;
    }
    if (!formatHoldsSeries(path))
        throw UsageError(
            path.string() + ": this format holds one volume and the series has " +
            std::to_string(series.frames.size()) +
            " frames (.nii, .nii.gz, .nrrd, .nhdr and .npy hold them all, or write one file per frame)");
    for (const Volume& v : series.frames)
        if (v.empty()) throw UsageError(path.string() + ": cannot write an empty volume");
    if (isNiftiName(path.filename().string())) {
        io::writeNiftiSeries(series.frames, series.times, path, options);
    } else if (options.niftiStoredValues && options.nifti && options.nifti->scales() &&
               isNpyName(path.filename().string())) {
        std::vector<Volume> units;
        for (const Volume& v : series.frames)
            units.push_back(niftiDataUnits(v, *options.nifti));
        io::writeNpy(units, path, options);
    } else if (isNpyName(path.filename().string())) {
        io::writeNpy(series.frames, path, options);
    } else if (options.niftiStoredValues && options.nifti && options.nifti->scales()) {
        // As writeVolumeFile: only a NIfTI output keeps a scaled source's stored integers.
        std::vector<Volume> units;
        for (const Volume& v : series.frames)
            units.push_back(niftiDataUnits(v, *options.nifti));
        io::writeNrrdSeries(units, path, options);
    } else {
        io::writeNrrdSeries(series.frames, path, options);
    }
}

void writeChannelsFile(const ChannelVolume& channels, const fs::path& path, const WriteOptions& options) {
    channels.validate();
    if (channels.count() == 1) return writeVolumeFile(channels.channels.front(), path, options);
    const std::string name = path.filename().string();
    if (isNrrdName(name)) return io::writeNrrdChannels(channels, path, options);
    if (isNiftiName(name)) return io::writeNiftiChannels(channels, path, options);
    if (io::endsWithI(name, ".vti")) return io::writeVtkXmlChannels(channels, path, options);
    throw UsageError(path.string() + ": " + std::to_string(channels.count()) +
                     " channels need a NRRD, NIfTI or VTI output (or --channel K for one)");
}

std::vector<fs::path> volumeFilesWritten(const fs::path& path) {
    std::vector<fs::path> files{path};
    // A .nhdr's new data file has a name no file holds yet; the one its present header names goes.
    if (endsWithI(path.filename().string(), ".nhdr"))
        if (auto replaced = io::nhdrOwnedDataFile(path)) files.push_back(std::move(*replaced));
    return files;
}

std::optional<std::pair<Dims, ScalarType>> parseRawFileName(std::string_view fileName) {
    // Finds `<X>x<Y>x<Z>_<type>` anywhere, e.g. "head_256x256x113_uint16.raw" or
    // "t1_..._180x216x180_uint8_1x1.bin-gz"; the type must end at a non-alphanumeric character.
    auto isDigit = [](char c) { return std::isdigit(static_cast<unsigned char>(c)) != 0; };
    auto isAlnum = [](char c) { return std::isalnum(static_cast<unsigned char>(c)) != 0; };
    static const std::pair<std::string_view, ScalarType> types[] = {
        {"uint8", ScalarType::UInt8},     {"u8", ScalarType::UInt8},      {"uchar", ScalarType::UInt8},
        {"uint16", ScalarType::UInt16},   {"u16", ScalarType::UInt16},    {"ushort", ScalarType::UInt16},
        {"int16", ScalarType::Int16},     {"i16", ScalarType::Int16},     {"short", ScalarType::Int16},
        {"float32", ScalarType::Float32}, {"float", ScalarType::Float32}, {"f32", ScalarType::Float32},
    };
    const std::string name = io::lower(fileName);
    for (std::size_t start = 0; start < name.size(); ++start) {
        if (!isDigit(name[start]) || (start > 0 && isAlnum(name[start - 1]))) continue;
        std::size_t pos = start;
        std::size_t d[3] = {0, 0, 0};
        bool ok = true;
        for (int axis = 0; axis < 3 && ok; ++axis) {
            const std::size_t begin = pos;
            while (pos < name.size() && isDigit(name[pos]) && pos - begin < 12)
                d[axis] = d[axis] * 10 + (name[pos++] - '0');
            ok = pos > begin && d[axis] > 0 && (pos >= name.size() || !isDigit(name[pos]));
            if (ok && axis < 2) ok = pos < name.size() && name[pos++] == 'x';
        }
        if (!ok || pos >= name.size() || name[pos] != '_') continue;
        ++pos;
        std::size_t end = pos;
        while (end < name.size() && isAlnum(name[end]))
            ++end;
        const std::string_view typeName = std::string_view(name).substr(pos, end - pos);
        for (const auto& [tn, t] : types)
            if (typeName == tn) return std::make_pair(Dims{d[0], d[1], d[2]}, t);
    }
    return std::nullopt;
}

} // namespace volcl
