// Time-series input: file lists, glob expansion with natural sort, ParaView .pvd parsing, grid checks.
#include "host/io/Series.hpp"

#include "core/AtomicFile.hpp"
#include "core/Error.hpp"
#include "core/MemoryBudget.hpp"
#include "host/io/IoDetail.hpp"

#include <glob.h>
#include <pugixml.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <sstream>

namespace volcl {

namespace fs = std::filesystem;

namespace {

bool isDigit(char c) noexcept {
    return std::isdigit(static_cast<unsigned char>(c)) != 0;
}

bool isPvd(const fs::path& p) {
    std::string ext = p.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    return ext == ".pvd";
}

std::string gridText(const Volume& v) {
    std::ostringstream s;
    s << v.dims().x << "x" << v.dims().y << "x" << v.dims().z << " " << scalarTypeName(v.type())
      << ", spacing " << v.spacing[0] << "," << v.spacing[1] << "," << v.spacing[2] << ", origin "
      << v.origin[0] << "," << v.origin[1] << "," << v.origin[2];
    return s.str();
}

// What differs between two grids, in words ("dims 64x64x32 against 64x64x64").
std::string gridDifference(const Volume& v, const Volume& first) {
    std::ostringstream s;
    if (v.dims() != first.dims())
        s << "dims " << v.dims().x << "x" << v.dims().y << "x" << v.dims().z << " against " << first.dims().x
          << "x" << first.dims().y << "x" << first.dims().z;
    else if (v.type() != first.type())
        s << "type " << scalarTypeName(v.type()) << " against " << scalarTypeName(first.type());
    else if (v.spacing != first.spacing)
        s << "spacing " << v.spacing[0] << "," << v.spacing[1] << "," << v.spacing[2] << " against "
          << first.spacing[0] << "," << first.spacing[1] << "," << first.spacing[2];
    else
        s << "origin " << v.origin[0] << "," << v.origin[1] << "," << v.origin[2] << " against "
          << first.origin[0] << "," << first.origin[1] << "," << first.origin[2];
    return s.str();
}

// One input argument as (file, time or NaN) pairs.
void expandOne(const std::string& input, const ReadOptions& options, std::vector<PvdEntry>& out) {
    std::error_code ec;
    const fs::path p(input);
    if (!fs::exists(p, ec) && hasGlobPattern(input)) {
        std::vector<fs::path> files = expandGlob(input);
        // A pattern of DICOM slices names one volume (a series), not one frame per file.
        if (io::isDicomFile(files.front())) {
            out.push_back({p, NAN});
            return;
        }
        for (fs::path& f : files)
            out.push_back({std::move(f), NAN});
        return;
    }
    if (isPvd(p)) {
        for (PvdEntry& e : readPvd(p, options))
            out.push_back(std::move(e));
        return;
    }
    out.push_back({p, NAN});
}

std::vector<PvdEntry> expandAll(std::span<const std::string> inputs, const ReadOptions& options) {
    if (inputs.empty()) throw UsageError("no input volume given");
    std::vector<PvdEntry> files;
    for (const std::string& in : inputs)
        expandOne(in, options, files);
    return files;
}

} // namespace

bool naturalLess(std::string_view a, std::string_view b) noexcept {
    std::size_t i = 0, j = 0;
    int zerosTieBreak = 0; // first difference in leading zeros among equal numbers
    while (i < a.size() && j < b.size()) {
        if (isDigit(a[i]) && isDigit(b[j])) {
            std::size_t za = i, zb = j;
            while (za < a.size() && a[za] == '0')
                ++za;
            while (zb < b.size() && b[zb] == '0')
                ++zb;
            std::size_t ea = za, eb = zb;
            while (ea < a.size() && isDigit(a[ea]))
                ++ea;
            while (eb < b.size() && isDigit(b[eb]))
                ++eb;
            // Significant digits: a longer run is a larger number; equal lengths compare digit by digit.
            if (ea - za != eb - zb) return ea - za < eb - zb;
            const int c = a.substr(za, ea - za).compare(b.substr(zb, eb - zb));
            if (c != 0) return c < 0;
            if (zerosTieBreak == 0 && (za - i) != (zb - j)) zerosTieBreak = (za - i) > (zb - j) ? -1 : 1;
            i = ea;
            j = eb;
            continue;
        }
        if (a[i] != b[j]) return static_cast<unsigned char>(a[i]) < static_cast<unsigned char>(b[j]);
        ++i;
        ++j;
    }
    if (i < a.size() || j < b.size()) return a.size() - i < b.size() - j;
    return zerosTieBreak < 0;
}

bool hasGlobPattern(std::string_view text) noexcept {
    return text.find_first_of("*?[") != std::string_view::npos;
}

std::vector<fs::path> expandGlob(std::string_view pattern) {
    const std::string pat(pattern);
    // A series a killed volcl left half moved is completed before its frames are listed.
    const fs::path dir = fs::path(pat).parent_path();
    if (!hasGlobPattern(dir.string())) completeInterruptedCommitsIn(dir);
    glob_t g{};
    const int rc = ::glob(pat.c_str(), GLOB_NOSORT, nullptr, &g);
    std::vector<std::string> names;
    if (rc == 0)
        for (std::size_t i = 0; i < g.gl_pathc; ++i)
            names.emplace_back(g.gl_pathv[i]);
    globfree(&g);
    if (rc == GLOB_NOSPACE) throw IoError("pattern '" + pat + "': out of memory while expanding");
    if (rc == GLOB_ABORTED) throw IoError("pattern '" + pat + "': a folder could not be read");
    std::vector<fs::path> files;
    std::error_code ec;
    for (const std::string& n : names)
        if (fs::is_regular_file(n, ec)) files.emplace_back(n);
    if (files.empty()) throw IoError("pattern '" + pat + "' matches no file");
    std::sort(files.begin(), files.end(),
              [](const fs::path& a, const fs::path& b) { return naturalLess(a.string(), b.string()); });
    return files;
}

std::vector<PvdEntry> readPvd(const fs::path& path, const ReadOptions& options) {
    requireRegularFile(path); // pugixml would block on a FIFO
    // A DataSet is a data file the .pvd names: the same containment rule and regular-file check as the
    // data files of other headers.
    io::ReadContext members(path, options);
    pugi::xml_document doc;
    const pugi::xml_parse_result parsed = doc.load_file(path.c_str());
    if (!parsed)
        throw IoError(path.string() + ": not a valid .pvd file (" + parsed.description() + " at byte " +
                      std::to_string(parsed.offset) + ")");
    const pugi::xml_node root = doc.child("VTKFile");
    if (!root || std::string_view(root.attribute("type").as_string()) != "Collection")
        throw IoError(path.string() + ": not a ParaView collection (no <VTKFile type=\"Collection\">)");
    const pugi::xml_node collection = root.child("Collection");
    if (!collection) throw IoError(path.string() + ": no <Collection> element");
    struct Item {
        PvdEntry entry;
        std::string part;
    };
    std::vector<Item> items;
    for (const pugi::xml_node ds : collection.children("DataSet")) {
        const pugi::xml_attribute file = ds.attribute("file");
        if (!file || std::string_view(file.as_string()).empty())
            throw IoError(path.string() + ": DataSet " + std::to_string(items.size()) +
                          " has no file attribute");
        const fs::path f(file.as_string());
        const double t = ds.attribute("timestep").as_double(double(items.size()));
        if (!std::isfinite(t))
            throw IoError(path.string() + ": DataSet " + std::to_string(items.size()) +
                          " has a non-finite timestep");
        if (items.size() >= kMaxCollectionMembers)
            throw IoError(path.string() + ": more than " + std::to_string(kMaxCollectionMembers) +
                          " DataSets (the budget of a collection's members)");
        items.push_back({{members.dataFile(file.as_string()), t}, ds.attribute("part").as_string("0")});
    }
    if (items.empty()) throw IoError(path.string() + ": the collection lists no DataSet");
    // Before any member is read, each file once: a 90 KB .pvd naming one 846 KB .vti 2,000 times took 68 s
    // and 6.2 GB, and its encode wrote 1.38 GB, all within the memory budget. (The series' voxels are
    // checked against the budget frame by frame, before each file is read: readSeriesInputs.)
    std::vector<const fs::path*> byName;
    byName.reserve(items.size());
    for (const Item& it : items)
        byName.push_back(&it.entry.file);
    std::sort(byName.begin(), byName.end(), [](const fs::path* a, const fs::path* b) { return *a < *b; });
    for (std::size_t i = 1; i < byName.size(); ++i)
        if (*byName[i] == *byName[i - 1])
            throw IoError(path.string() + ": DataSet file '" + byName[i]->filename().string() +
                          "' is listed more than once (each time step needs its own file)");
    std::stable_sort(items.begin(), items.end(),
                     [](const Item& a, const Item& b) { return a.entry.time < b.entry.time; });
    for (std::size_t i = 1; i < items.size(); ++i)
        if (items[i].entry.time == items[i - 1].entry.time)
            throw DataError(path.string() + ": time " + std::to_string(items[i].entry.time) +
                            " has several data sets (parts '" + items[i - 1].part + "' and '" +
                            items[i].part + "'): multi-part collections are not one volume per time step");
    std::vector<PvdEntry> out;
    out.reserve(items.size());
    for (Item& it : items)
        out.push_back(std::move(it.entry));
    return out;
}

std::string SeriesFrameSource::describe(std::size_t frame) const {
    std::string s = "frame " + std::to_string(frame) + " (" + file.string();
    if (indexInFile > 0) s += ", volume " + std::to_string(indexInFile);
    return s + ")";
}

std::vector<fs::path> expandSeriesInputs(std::span<const std::string> inputs, const ReadOptions& options) {
    std::vector<fs::path> out;
    for (PvdEntry& e : expandAll(inputs, options))
        out.push_back(std::move(e.file));
    return out;
}

SeriesInput readSeriesInputs(std::span<const std::string> inputs, const ReadOptions& options,
                             std::vector<fs::path>* filesRead) {
    const std::vector<PvdEntry> files = expandAll(inputs, options);
    SeriesInput in;
    bool allTimed = true;
    std::vector<double> times;
    // The memory budget covers the whole series, not each file: a .pvd naming one large file a thousand
    // times must be refused before the frames exhaust memory. Every frame has frame 0's grid, so a file
    // that cannot add one more frame is refused before it is read; each file's own claims (a reader may
    // need more than the frames while it decodes) are checked against what is left.
    const std::size_t budget = effectiveMemoryBudget(options.memoryBudget);
    std::size_t used = 0;
    for (const PvdEntry& f : files) {
        const std::size_t frameBytes = in.series.frames.empty() ? 0 : in.series.frames[0].byteSize();
        if (frameBytes > 0 && frameBytes > budget - used)
            throw IoError(f.file.string() + ": frame " + std::to_string(in.series.frames.size()) +
                          " would bring the series to " + std::to_string(used + frameBytes) +
                          " bytes of voxels, more than the memory budget of " + std::to_string(budget) +
                          " bytes");
        ReadOptions fileOptions = options;
        fileOptions.memoryBudget = budget - used;
        std::vector<fs::path> partFiles;
        TimeSeries part = readVolumeFile(f.file, fileOptions, partFiles);
        for (const Volume& v : part.frames)
            used += v.byteSize();
        if (filesRead) filesRead->insert(filesRead->end(), partFiles.begin(), partFiles.end());
        const bool fileTimed = std::isfinite(f.time) || part.times.size() == part.frames.size();
        allTimed = allTimed && fileTimed;
        for (std::size_t k = 0; k < part.frames.size(); ++k) {
            const std::size_t frame = in.series.frames.size();
            SeriesFrameSource src{f.file, k};
            if (frame > 0 && !part.frames[k].sameGrid(in.series.frames[0]))
                throw DataError(src.describe(frame) + ": " +
                                gridDifference(part.frames[k], in.series.frames[0]) + " of " +
                                in.sources[0].describe(0) + "; every frame needs frame 0's grid (" +
                                gridText(in.series.frames[0]) + ")");
            if (allTimed) times.push_back(std::isfinite(f.time) ? f.time : part.times[k]);
            in.series.frames.push_back(std::move(part.frames[k]));
            in.sources.push_back(std::move(src));
        }
    }
    // Times only when every frame has one (a .pvd, or 4D files with a time step) and they increase.
    if (allTimed && times.size() == in.series.frames.size() && std::is_sorted(times.begin(), times.end()))
        in.series.times = std::move(times);
    in.series.validate();
    return in;
}

} // namespace volcl
