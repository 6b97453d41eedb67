// Parsing helpers shared by subcommands.
#include "apps/cli/CliParsing.hpp"

#include "core/Error.hpp"

#include <charconv>
#include <vector>

namespace volcl::cli {

void setExamples(CLI::App& app, const std::string& examples) {
    app.footer("\nExamples:\n" + examples + "\n");
}

namespace {
std::vector<std::size_t> parseNumbers(const std::string& text, const std::string& what, std::size_t count) {
    std::vector<std::size_t> out;
    const char* p = text.data();
    const char* end = p + text.size();
    while (p < end) {
        std::size_t v = 0;
        auto [next, ec] = std::from_chars(p, end, v);
        if (ec != std::errc()) break;
        out.push_back(v);
        p = next;
        if (p < end && (*p == ',' || *p == 'x' || *p == 'X'))
            ++p;
        else
            break;
    }
    if (out.size() != count || p != end)
        throw UsageError(what + " '" + text + "' must be " + std::to_string(count) +
                         " non-negative integers");
    return out;
}
} // namespace

Dims parseDims(const std::string& text, const std::string& what) {
    auto v = parseNumbers(text, what, 3);
    if (v[0] == 0 || v[1] == 0 || v[2] == 0) throw UsageError(what + " '" + text + "' must be positive");
    return {v[0], v[1], v[2]};
}

std::pair<Dims, Dims> parseBox(const std::string& text, const std::string& what) {
    auto colon = text.find(':');
    if (colon == std::string::npos)
        throw UsageError(what + " '" + text + "' must look like x0,y0,z0:x1,y1,z1");
    auto lo = parseNumbers(text.substr(0, colon), what, 3);
    auto hi = parseNumbers(text.substr(colon + 1), what, 3);
    return {{lo[0], lo[1], lo[2]}, {hi[0], hi[1], hi[2]}};
}

std::string shellQuote(const std::string& s) {
    std::string out = "'";
    for (char c : s)
        out += c == '\'' ? std::string("'\\''") : std::string(1, c);
    return out + "'";
}

void RawReadFlags::add(CLI::App& cmd) {
    cmd.add_option("--dims", dims, "Raw input dimensions X,Y,Z (overrides the file name)");
    cmd.add_option("--type", type, "Raw input type: uint8, uint16, int16, float32");
    cmd.add_option("--endian", endian, "Raw input byte order")->check(CLI::IsMember({"little", "big"}));
    cmd.add_option("--header-bytes", headerBytes, "Raw input: bytes to skip before the voxels");
    cmd.add_option("--grid", vdbGrid, "OpenVDB input: grid name (default: the first scalar grid)");
    cmd.add_option("--series", dicomSeries,
                   "DICOM input: Series Instance UID to read when a folder holds several series");
    cmd.add_flag("--allow-external-data", allowExternalData,
                 "Let a header name data files outside its own directory (absolute paths, ../)");
    cmd.add_option("--channel", channel,
                   "Multi-channel input (vector/RGB NRRD, NIfTI dim[5] or RGB, .vti components, MetaImage "
                   "channels): read channel K (0-based) as the scalar volume")
        ->check(CLI::NonNegativeNumber);
}

ReadOptions RawReadFlags::toReadOptions() const {
    ReadOptions o;
    if (!dims.empty()) o.dims = parseDims(dims, "--dims");
    if (!type.empty()) o.type = parseScalarType(type);
    o.endian = endian == "big" ? Endian::Big : Endian::Little;
    o.headerBytes = headerBytes;
    if (!vdbGrid.empty()) o.vdbGrid = vdbGrid;
    if (!dicomSeries.empty()) o.dicomSeries = dicomSeries;
    o.allowExternalData = allowExternalData;
    if (channel >= 0) o.channel = static_cast<std::size_t>(channel);
    return o;
}

} // namespace volcl::cli
