// DICOM series input through GDCM: file gathering, series choice, slice geometry checks, rescale.
#include "core/Error.hpp"
#include "core/MemoryBudget.hpp"
#include "host/io/IoDetail.hpp"
#include "host/io/Series.hpp"

#include <gdcmImageReader.h>
#include <gdcmReader.h>
#include <gdcmStringFilter.h>
#include <gdcmTrace.h>
#include <gdcmTransferSyntax.h>

#include <csignal>
#include <fcntl.h>
#include <poll.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>

namespace volcl::io {

namespace fs = std::filesystem;

namespace {

// Relative tolerance of the slice geometry: gaps may differ from the median gap, positions drift across
// the normal, and orientation cosines and pixel spacings differ between files by this much (DS values
// carry 16 characters, so real series agree to ~1e-6; a missing slice or a tilted stack is far beyond).
constexpr double kGeometryTolerance = 1e-3;

using Vec3d = std::array<double, 3>;

Vec3d crossProduct(const Vec3d& a, const Vec3d& b) {
    return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

double dotProduct(const Vec3d& a, const Vec3d& b) {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

// The header fields of one slice file (read up to the pixel data).
struct SliceHeader {
    fs::path file;
    std::string seriesUid, description;
    std::size_t rows = 0, columns = 0, frames = 1, samplesPerPixel = 1;
    std::vector<double> orientation, position, pixelSpacing; // as stated (empty when absent)
    double slope = 1, intercept = 0, thickness = 0, spacingBetween = 0;
    double along = 0; // position projected on the slice normal
};

std::string stripValue(std::string s) {
    while (!s.empty() && (s.back() == ' ' || s.back() == '\0'))
        s.pop_back();
    std::size_t b = 0;
    while (b < s.size() && s[b] == ' ')
        ++b;
    return s.substr(b);
}

// The numbers of a backslash-separated DS/IS value; empty when the element is absent or empty.
std::vector<double> numbersOf(const std::string& text, const fs::path& file, std::string_view what) {
    std::vector<double> out;
    std::string spaced = text;
    std::replace(spaced.begin(), spaced.end(), '\\', ' ');
    for (std::string_view w : splitWords(spaced)) {
        const double v = requireDouble(w, file, what);
        if (!std::isfinite(v)) fail(file, std::string(what) + " holds a non-finite value");
        out.push_back(v);
    }
    return out;
}

double numberOr(const std::string& text, double fallback, const fs::path& file, std::string_view what) {
    const std::vector<double> v = numbersOf(text, file, what);
    return v.empty() ? fallback : v.front();
}

std::size_t countOf(const std::string& text, std::size_t fallback, const fs::path& file,
                    std::string_view what) {
    const double v = numberOr(text, static_cast<double>(fallback), file, what);
    if (v < 0 || v != std::floor(v) || v > 1e9) fail(file, std::string(what) + " is not a count");
    return static_cast<std::size_t>(v);
}

void silenceGdcm() {
    // GDCM prints its warnings on stderr; every problem that matters reaches the caller as an exception.
    gdcm::Trace::WarningOff();
    gdcm::Trace::ErrorOff();
    gdcm::Trace::DebugOff();
}

// The reading child's reply pipe: each file is named before GDCM opens it, so a file that makes GDCM abort
// (Debian builds it with assertions) is the one the parent reports.
struct ReplyPipe {
    int fd = -1;
    bool writeAll(const void* data, std::size_t n) const { return io::writeAll(fd, data, n); }
    bool record(char kind, std::string_view text) const {
        const std::uint64_t n = text.size();
        return writeAll(&kind, 1) && writeAll(&n, 8) && writeAll(text.data(), text.size());
    }
    void entering(const fs::path& file) const { record('F', file.string()); }
};

// A slice's header, or nothing when the file is no DICOM image (no series UID or no Rows).
std::optional<SliceHeader> readSliceHeader(const fs::path& file, const ReplyPipe& pipe) {
    pipe.entering(file);
    gdcm::Reader reader;
    reader.SetFileName(file.c_str());
    bool ok = false;
    try {
        ok = reader.ReadUpToTag(gdcm::Tag(0x7fe0, 0x0010));
    } catch (const std::exception& e) {
        fail(file, std::string("not a readable DICOM file (") + e.what() + ")");
    }
    if (!ok) fail(file, "not a readable DICOM file");
    gdcm::StringFilter sf;
    sf.SetFile(reader.GetFile());
    auto value = [&](std::uint16_t group, std::uint16_t element) {
        return stripValue(sf.ToString(gdcm::Tag(group, element)));
    };
    SliceHeader h;
    h.file = file;
    h.seriesUid = value(0x0020, 0x000e);
    h.rows = countOf(value(0x0028, 0x0010), 0, file, "Rows");
    h.columns = countOf(value(0x0028, 0x0011), 0, file, "Columns");
    if (h.seriesUid.empty() || h.rows == 0 || h.columns == 0) return std::nullopt;
    h.description = value(0x0008, 0x103e);
    h.frames = countOf(value(0x0028, 0x0008), 1, file, "Number of Frames");
    h.samplesPerPixel = countOf(value(0x0028, 0x0002), 1, file, "Samples per Pixel");
    h.orientation = numbersOf(value(0x0020, 0x0037), file, "Image Orientation (Patient)");
    h.position = numbersOf(value(0x0020, 0x0032), file, "Image Position (Patient)");
    h.pixelSpacing = numbersOf(value(0x0028, 0x0030), file, "Pixel Spacing");
    h.slope = numberOr(value(0x0028, 0x1053), 1.0, file, "Rescale Slope");
    h.intercept = numberOr(value(0x0028, 0x1052), 0.0, file, "Rescale Intercept");
    h.thickness = numberOr(value(0x0018, 0x0050), 0.0, file, "Slice Thickness");
    h.spacingBetween = numberOr(value(0x0018, 0x0088), 0.0, file, "Spacing Between Slices");
    return h;
}

// Every file the input names: a folder's regular files (not its subfolders), a pattern's matches, or a
// slice and the other files of its folder. `named` is the one file whose series is wanted, if any.
std::vector<fs::path> candidateFiles(const fs::path& input, std::optional<fs::path>& named) {
    std::error_code ec;
    if (!fs::exists(input, ec) && hasGlobPattern(input.string())) return expandGlob(input.string());
    const fs::path folder = fs::is_directory(input, ec) ? input : input.parent_path();
    if (!fs::is_directory(input, ec)) named = input;
    std::vector<fs::path> files;
    for (const fs::directory_entry& e : fs::directory_iterator(folder.empty() ? fs::path(".") : folder, ec))
        if (e.is_regular_file(ec)) files.push_back(folder.empty() ? e.path().filename() : e.path());
    if (ec) fail(folder, "cannot list the folder (" + ec.message() + ")");
    std::sort(files.begin(), files.end(),
              [](const fs::path& a, const fs::path& b) { return naturalLess(a.string(), b.string()); });
    return files;
}

// The slices of the series the input and options choose, in file order.
std::vector<SliceHeader> chooseSeries(const fs::path& input, const ReadOptions& options,
                                      const ReplyPipe& pipe) {
    std::optional<fs::path> named;
    std::map<std::string, std::vector<SliceHeader>> bySeries;
    std::string namedUid;
    for (const fs::path& f : candidateFiles(input, named)) {
        const bool isNamed = named && f == *named;
        // A folder or pattern may hold other files (a DICOMDIR, notes, thumbnails): they are skipped.
        if (!isNamed && !isDicomFile(f)) continue;
        std::optional<SliceHeader> h = readSliceHeader(f, pipe);
        if (!h) {
            if (isNamed) unsupported(f, "is a DICOM file without an image (no Series Instance UID or Rows)");
            continue;
        }
        if (isNamed) namedUid = h->seriesUid;
        bySeries[h->seriesUid].push_back(std::move(*h));
    }
    if (bySeries.empty()) fail(input, "holds no DICOM image file (DICOM Part 10: 'DICM' after 128 bytes)");
    std::string uid = options.dicomSeries.value_or(namedUid);
    if (uid.empty() && bySeries.size() == 1) uid = bySeries.begin()->first;
    if (!bySeries.contains(uid)) {
        std::string list;
        for (const auto& [u, slices] : bySeries) {
            list += (list.empty() ? "" : "; ") + u + " (" + std::to_string(slices.size()) + " files";
            list += slices.front().description.empty() ? ")" : ", '" + slices.front().description + "')";
        }
        if (uid.empty())
            unsupported(input, "holds " + std::to_string(bySeries.size()) +
                                   " DICOM series; choose one with --series UID: " + list);
        unsupported(input, "has no DICOM series " + uid + " (series: " + list + ")");
    }
    return std::move(bySeries[uid]);
}

struct SeriesGeometry {
    Vec3d row{}, column{}, normal{};
    std::array<double, 3> spacing{};
    Vec3d origin{}; // LPS, of the first slice after sorting
};

// Checks that every slice shares the first one's grid and sorts them along the slice normal.
SeriesGeometry sortSlices(std::vector<SliceHeader>& slices) {
    const SliceHeader& first = slices.front();
    for (const SliceHeader& s : slices) {
        if (s.frames != 1)
            unsupported(s.file, "holds " + std::to_string(s.frames) +
                                    " frames (multi-frame DICOM is not read; one slice per file)");
        if (s.samplesPerPixel != 1)
            unsupported(s.file, "has " + std::to_string(s.samplesPerPixel) +
                                    " samples per pixel (colour DICOM is not a scalar volume)");
        if (s.orientation.size() != 6) fail(s.file, "has no Image Orientation (Patient) of six numbers");
        if (s.position.size() != 3) fail(s.file, "has no Image Position (Patient) of three numbers");
        if (s.pixelSpacing.size() != 2 || !(s.pixelSpacing[0] > 0) || !(s.pixelSpacing[1] > 0))
            fail(s.file, "has no Pixel Spacing of two positive numbers");
        if (s.rows != first.rows || s.columns != first.columns)
            unsupported(s.file, "is " + std::to_string(s.columns) + "x" + std::to_string(s.rows) +
                                    " pixels, the series' first file " + first.file.filename().string() +
                                    " is " + std::to_string(first.columns) + "x" +
                                    std::to_string(first.rows));
        for (int i = 0; i < 6; ++i)
            if (std::abs(s.orientation[i] - first.orientation[i]) > kGeometryTolerance)
                unsupported(s.file, "has another Image Orientation (Patient) than " +
                                        first.file.filename().string() + " (mixed orientations)");
        for (int i = 0; i < 2; ++i)
            if (std::abs(s.pixelSpacing[i] - first.pixelSpacing[i]) >
                kGeometryTolerance * first.pixelSpacing[i])
                unsupported(s.file, "has another Pixel Spacing than " + first.file.filename().string());
    }
    SeriesGeometry g;
    auto unit = [&](Vec3d v, std::string_view what) {
        const double n = std::sqrt(dotProduct(v, v));
        if (!(n > 0.5 && n < 2))
            fail(first.file,
                 "Image Orientation (Patient): the " + std::string(what) + " cosines are not a unit vector");
        return Vec3d{v[0] / n, v[1] / n, v[2] / n};
    };
    g.row = unit({first.orientation[0], first.orientation[1], first.orientation[2]}, "row");
    g.column = unit({first.orientation[3], first.orientation[4], first.orientation[5]}, "column");
    if (std::abs(dotProduct(g.row, g.column)) > kGeometryTolerance)
        unsupported(first.file, "Image Orientation (Patient): rows and columns are not perpendicular");
    g.normal = unit(crossProduct(g.row, g.column), "normal");
    for (SliceHeader& s : slices)
        s.along = dotProduct({s.position[0], s.position[1], s.position[2]}, g.normal);
    std::stable_sort(slices.begin(), slices.end(),
                     [](const SliceHeader& a, const SliceHeader& b) { return a.along < b.along; });
    // Pixel Spacing is (between rows, between columns): y first.
    g.spacing = {first.pixelSpacing[1], first.pixelSpacing[0], 0};
    const SliceHeader& lowest = slices.front();
    g.origin = {lowest.position[0], lowest.position[1], lowest.position[2]};
    if (slices.size() == 1) {
        // One slice states no gap: the stated spacing between slices, else the thickness, else 1.
        g.spacing[2] = lowest.spacingBetween > 0 ? lowest.spacingBetween
                       : lowest.thickness > 0    ? lowest.thickness
                                                 : 1.0;
        return g;
    }
    std::vector<double> gaps;
    for (std::size_t i = 1; i < slices.size(); ++i)
        gaps.push_back(slices[i].along - slices[i - 1].along);
    std::vector<double> sorted = gaps;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    const double median = sorted[sorted.size() / 2];
    const double tolerance = kGeometryTolerance * std::max(median, 0.0);
    for (std::size_t i = 1; i < slices.size(); ++i) {
        const double gap = gaps[i - 1];
        if (gap <= tolerance)
            unsupported(slices[i].file, "has the same slice position as " +
                                            slices[i - 1].file.filename().string() +
                                            " (duplicated position " + formatDouble(slices[i].along) +
                                            " mm along the normal)");
        if (std::abs(gap - median) > tolerance)
            unsupported(slices[i].file, "lies " + formatDouble(gap) + " mm from the previous slice " +
                                            slices[i - 1].file.filename().string() +
                                            ", the series' other gaps are " + formatDouble(median) +
                                            " mm (gaps or non-uniform spacing; tolerance " +
                                            formatDouble(kGeometryTolerance * 100) + " %)");
        // The positions must move along the normal: a tilted gantry or a sheared stack is no grid.
        Vec3d d{};
        for (int a = 0; a < 3; ++a)
            d[a] = slices[i].position[a] - lowest.position[a];
        const double alongNormal = dotProduct(d, g.normal);
        Vec3d across{};
        for (int a = 0; a < 3; ++a)
            across[a] = d[a] - alongNormal * g.normal[a];
        if (std::sqrt(dotProduct(across, across)) > tolerance * static_cast<double>(i))
            unsupported(slices[i].file, "is shifted within the slice plane against " +
                                            lowest.file.filename().string() +
                                            " (tilted or sheared stack: positions do not follow the normal)");
    }
    g.spacing[2] = (slices.back().along - lowest.along) / static_cast<double>(slices.size() - 1);
    return g;
}

std::optional<SampleType> sampleTypeOf(const gdcm::PixelFormat& pf) {
    switch (pf.GetScalarType()) {
    case gdcm::PixelFormat::UINT8:
        return SampleType::UInt8;
    case gdcm::PixelFormat::INT8:
        return SampleType::Int8;
    case gdcm::PixelFormat::UINT12:
    case gdcm::PixelFormat::UINT16:
        return SampleType::UInt16;
    case gdcm::PixelFormat::INT12:
    case gdcm::PixelFormat::INT16:
        return SampleType::Int16;
    case gdcm::PixelFormat::UINT32:
        return SampleType::UInt32;
    case gdcm::PixelFormat::INT32:
        return SampleType::Int32;
    case gdcm::PixelFormat::UINT64:
        return SampleType::UInt64;
    case gdcm::PixelFormat::INT64:
        return SampleType::Int64;
    case gdcm::PixelFormat::FLOAT32:
        return SampleType::Float32;
    case gdcm::PixelFormat::FLOAT64:
        return SampleType::Float64;
    default:
        return std::nullopt;
    }
}

// One slice's stored samples, decoded by GDCM (host byte order).
std::vector<std::byte> readSlicePixels(const SliceHeader& s, std::optional<SampleType>& type,
                                       const ReplyPipe& pipe) {
    pipe.entering(s.file);
    gdcm::ImageReader reader;
    reader.SetFileName(s.file.c_str());
    bool ok = false;
    try {
        ok = reader.Read();
    } catch (const std::exception& e) {
        fail(s.file, std::string("GDCM cannot read the image (") + e.what() + ")");
    }
    if (!reader.GetFile().GetDataSet().FindDataElement(gdcm::Tag(0x7fe0, 0x0010)))
        fail(s.file, "has no pixel data (7FE0,0010)");
    if (!ok) fail(s.file, "GDCM cannot read the image");
    const gdcm::Image& image = reader.GetImage();
    const std::optional<SampleType> st = sampleTypeOf(image.GetPixelFormat());
    if (!st || image.GetPixelFormat().GetSamplesPerPixel() != 1)
        unsupported(s.file, std::string("pixel format ") + image.GetPixelFormat().GetScalarTypeAsString() +
                                " is not a scalar sample type");
    if (type && *type != *st)
        unsupported(s.file, std::string("stores ") + std::string(sampleTypeName(*st)) +
                                " samples, the series' other files " + std::string(sampleTypeName(*type)));
    type = st;
    const std::size_t expected = s.rows * s.columns * sampleSize(*st);
    if (image.GetBufferLength() != expected)
        fail(s.file, "pixel data holds " + std::to_string(image.GetBufferLength()) + " bytes, " +
                         std::to_string(s.columns) + "x" + std::to_string(s.rows) + " pixels need " +
                         std::to_string(expected));
    std::vector<std::byte> bytes(expected);
    if (!image.GetBuffer(reinterpret_cast<char*>(bytes.data()))) {
        const gdcm::TransferSyntax& ts = reader.GetFile().GetHeader().GetDataSetTransferSyntax();
        unsupported(s.file, std::string("GDCM cannot decode its pixel data (transfer syntax ") +
                                (ts.GetString() ? ts.GetString() : "unknown") + ")");
    }
    return bytes;
}

// The smallest model type that holds every rescaled value exactly: the stored type, int16 or uint16 when
// every value is an integer in range, else float32.
ScalarType rescaledType(SampleType stored, bool integral, double lo, double hi) {
    if (!integral) return ScalarType::Float32;
    auto holds = [&](ScalarType t) {
        switch (t) {
        case ScalarType::UInt8:
            return lo >= 0 && hi <= 255;
        case ScalarType::Int16:
            return lo >= -32768 && hi <= 32767;
        case ScalarType::UInt16:
            return lo >= 0 && hi <= 65535;
        case ScalarType::Float32:
        case ScalarType::Float64:
            return true;
        }
        return false;
    };
    const ScalarType storedModel = volumeTypeFor(stored);
    if (storedModel != ScalarType::Float32 && holds(storedModel)) return storedModel;
    for (ScalarType t : {ScalarType::Int16, ScalarType::UInt16})
        if (holds(t)) return t;
    return ScalarType::Float32;
}

// The whole read, in the child: the volume and its files, or throws.
TimeSeries readSeriesHere(const fs::path& input, const ReadOptions& options, std::vector<fs::path>& filesRead,
                          const ReplyPipe& pipe) {
    silenceGdcm();
    std::vector<SliceHeader> slices = chooseSeries(input, options, pipe);
    const SeriesGeometry g = sortSlices(slices);
    const Dims dims{slices.front().columns, slices.front().rows, slices.size()};
    const std::size_t voxels = checkedVoxelCount(dims, 1, input);
    const std::size_t sliceVoxels = dims.x * dims.y;
    // Stored samples (up to 8 bytes) and the volume (up to 4) are in memory together.
    checkMemoryBudget(voxels * 12, options.memoryBudget, input, "the DICOM series");
    std::optional<SampleType> stored;
    std::vector<std::vector<std::byte>> pixels;
    pixels.reserve(slices.size());
    bool integral = true;
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const SliceHeader& s : slices) {
        pixels.push_back(readSlicePixels(s, stored, pipe));
        const bool integerScale = s.slope == std::floor(s.slope) && s.intercept == std::floor(s.intercept);
        const bool integerSamples = *stored != SampleType::Float32 && *stored != SampleType::Float64;
        integral = integral && integerScale && integerSamples;
        for (double v : decodeToDouble(pixels.back(), *stored, hostEndian())) {
            const double r = v * s.slope + s.intercept;
            lo = std::min(lo, r);
            hi = std::max(hi, r);
        }
    }
    // The model type depends on every slice's rescaled range, so each slice's stored samples are converted to
    // double twice (range above, store below) rather than kept as doubles: that would be 8 bytes per voxel
    // beside the volume, and the conversion costs far less than GDCM's decode.
    Volume v(dims, rescaledType(*stored, integral, lo, hi));
    for (std::size_t k = 0; k < slices.size(); ++k) {
        const std::vector<double> values = decodeToDouble(pixels[k], *stored, hostEndian());
        std::vector<std::byte>().swap(pixels[k]);
        auto store = [&]<class T>(std::span<T> out) {
            // Computed in double and rounded once; integral values are exact in the chosen type.
            for (std::size_t i = 0; i < sliceVoxels; ++i)
                out[k * sliceVoxels + i] = static_cast<T>(values[i] * slices[k].slope + slices[k].intercept);
        };
        switch (v.type()) {
        case ScalarType::UInt8:
            store(v.values<std::uint8_t>());
            break;
        case ScalarType::UInt16:
            store(v.values<std::uint16_t>());
            break;
        case ScalarType::Int16:
            store(v.values<std::int16_t>());
            break;
        case ScalarType::Float32:
            store(v.values<float>());
            break;
        case ScalarType::Float64:
            store(v.values<double>());
            break;
        }
    }
    // DICOM's patient axes are LPS; the model's are RAS (x and y negated), as the MetaImage reader does.
    Direction3 d{};
    const std::array<Vec3d, 3> axes{g.row, g.column, g.normal};
    const std::array<double, 3> lpsToRas{-1, -1, 1};
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
            d[3 * r + c] = lpsToRas[r] * axes[c][r];
    v.direction = orthonormalDirection(d);
    v.anatomical = true;
    v.spacing = g.spacing;
    for (int a = 0; a < 3; ++a)
        v.origin[a] = lpsToRas[a] * g.origin[a];
    filesRead.clear();
    for (const SliceHeader& s : slices)
        filesRead.push_back(s.file);
    TimeSeries series;
    series.frames.push_back(std::move(v));
    return series;
}

// Child side: reads and sends 'O' (the volume) or 'E' (the error kind and message), then ends.
[[noreturn]] void readInChild(const fs::path& input, const ReadOptions& options, const ReplyPipe& pipe) {
    try {
        std::vector<fs::path> files;
        const TimeSeries s = readSeriesHere(input, options, files, pipe);
        const Volume& v = s.frames.front();
        const std::uint64_t head[5] = {v.dims().x, v.dims().y, v.dims().z,
                                       static_cast<std::uint64_t>(v.type()), files.size()};
        const std::uint8_t anatomical = v.anatomical ? 1 : 0;
        bool ok = pipe.writeAll("O", 1) && pipe.writeAll(head, sizeof(head)) &&
                  pipe.writeAll(v.spacing.data(), 24) && pipe.writeAll(v.origin.data(), 24) &&
                  pipe.writeAll(v.direction.data(), 72) && pipe.writeAll(&anatomical, 1);
        for (const fs::path& f : files)
            ok = ok && pipe.record('F', f.string());
        ok = ok && pipe.writeAll(v.bytes().data(), v.byteSize());
        ::_exit(ok ? 0 : 1);
    } catch (const DataError& e) {
        pipe.record('D', e.what());
    } catch (const UsageError& e) {
        pipe.record('U', e.what());
    } catch (const std::bad_alloc&) {
        pipe.record('I', input.string() + ": not enough memory to read the DICOM series");
    } catch (const std::exception& e) {
        pipe.record('I', e.what());
    }
    ::_exit(0);
}

// Longest time the child may go without sending anything: GDCM loops forever on some malformed files, and
// one slice, even a large compressed one, decodes in well under a second.
constexpr int kDicomStallMilliseconds = 5000;

// Reads exactly n bytes; false at the end of the stream or when the child stalls (it is then killed).
bool readAll(int fd, void* data, std::size_t n, pid_t child) {
    auto* p = static_cast<char*>(data);
    while (n > 0) {
        pollfd pfd{fd, POLLIN, 0};
        const int ready = ::poll(&pfd, 1, kDicomStallMilliseconds);
        if (ready < 0 && errno == EINTR) continue;
        if (ready == 0) {
            ::kill(child, SIGKILL);
            return false;
        }
        const ssize_t r = ::read(fd, p, n);
        if (r < 0 && errno == EINTR) continue;
        if (r <= 0) return false;
        p += r;
        n -= static_cast<std::size_t>(r);
    }
    return true;
}

std::optional<std::string> readRecordText(int fd, pid_t child) {
    std::uint64_t n = 0;
    if (!readAll(fd, &n, 8, child) || n > (1u << 20)) return std::nullopt;
    std::string text(n, '\0');
    if (!readAll(fd, text.data(), n, child)) return std::nullopt;
    return text;
}

} // namespace

bool isDicomFile(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    char head[132] = {};
    return in.read(head, sizeof(head)) && std::string_view(head + 128, 4) == "DICM";
}

TimeSeries readDicom(const fs::path& input, const ReadOptions& options, std::vector<fs::path>& filesRead) {
    // GDCM trusts malformed files to the point of failed assertions (abort) in Debian's build: the series is
    // read in a forked child, and a child that dies becomes an error naming the file it was reading.
    int fds[2];
    if (::pipe2(fds, O_CLOEXEC) != 0) fail(input, "cannot create a pipe for the DICOM reader");
    const pid_t pid = ::fork();
    if (pid < 0) {
        ::close(fds[0]);
        ::close(fds[1]);
        fail(input, "cannot start the DICOM reader (fork failed)");
    }
    if (pid == 0) {
        ::close(fds[0]);
        // GDCM's failed assertions print to stderr; the parent words the error.
        const int devNull = ::open("/dev/null", O_WRONLY);
        if (devNull >= 0) ::dup2(devNull, STDERR_FILENO);
        // A forged element length must fail its allocation, not touch gigabytes (the stored samples and the
        // volume, 12 bytes a voxel at most, are checked against the budget before they are read).
        capAddressSpace(effectiveMemoryBudget(options.memoryBudget));
        readInChild(input, options, ReplyPipe{fds[1]});
    }
    ::close(fds[1]);
    // Closes the read end and reaps the child on every way out (a child still writing gets EPIPE).
    class ChildEnd {
    public:
        ChildEnd(int fd, pid_t pid) : fd_(fd), pid_(pid) {}
        ChildEnd(const ChildEnd&) = delete;
        ChildEnd& operator=(const ChildEnd&) = delete;
        ~ChildEnd() {
            ::close(fd_);
            int status = 0;
            while (::waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
            }
        }

    private:
        int fd_;
        pid_t pid_;
    };
    std::optional<ChildEnd> child;
    child.emplace(fds[0], pid);
    fs::path current = input;
    for (;;) {
        char kind = 0;
        if (!readAll(fds[0], &kind, 1, pid)) break;
        if (kind == 'F') {
            if (const auto text = readRecordText(fds[0], pid)) current = *text;
            continue;
        }
        if (kind == 'O') {
            std::uint64_t head[5];
            Volume v;
            std::uint8_t anatomical = 0;
            bool ok = readAll(fds[0], head, sizeof(head), pid) &&
                      head[3] <= static_cast<std::uint64_t>(ScalarType::Float32);
            std::array<double, 3> spacing{}, origin{};
            Direction3 direction{};
            ok = ok && readAll(fds[0], spacing.data(), 24, pid) && readAll(fds[0], origin.data(), 24, pid) &&
                 readAll(fds[0], direction.data(), 72, pid) && readAll(fds[0], &anatomical, 1, pid);
            std::vector<fs::path> files;
            for (std::uint64_t i = 0; ok && i < head[4]; ++i) {
                char f = 0;
                const auto text =
                    readAll(fds[0], &f, 1, pid) && f == 'F' ? readRecordText(fds[0], pid) : std::nullopt;
                ok = text.has_value();
                if (ok) files.emplace_back(*text);
            }
            if (ok) {
                v = Volume(Dims{head[0], head[1], head[2]}, static_cast<ScalarType>(head[3]));
                ok = readAll(fds[0], v.bytes().data(), v.byteSize(), pid);
            }
            if (!ok) fail(input, "the DICOM reader ended before it sent the whole volume");
            v.spacing = spacing;
            v.origin = origin;
            v.direction = direction;
            v.anatomical = anatomical != 0;
            filesRead = std::move(files);
            TimeSeries series;
            series.frames.push_back(std::move(v));
            return series;
        }
        const auto message = readRecordText(fds[0], pid);
        if (!message) break;
        if (kind == 'D') throw DataError(*message);
        if (kind == 'U') throw UsageError(*message);
        throw IoError(*message);
    }
    child.reset(); // waits for the child
    fail(current, "not a readable DICOM file (GDCM failed or stalled while reading it)");
}

} // namespace volcl::io
