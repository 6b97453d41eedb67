// The .vcz header and frame table as `volcl info` prints them.
#include "apps/cli/VczInfo.hpp"

#include "core/MappedFile.hpp"
#include "host/io/NiftiMetadata.hpp"
#include "wavelet/Codec.hpp"
#include "wavelet/container/LodStatistics.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <iomanip>
#include <optional>
#include <sstream>

namespace volcl::cli {

namespace {

const char* frameTypeName(FrameType t) {
    switch (t) {
    case FrameType::I:
        return "I";
    case FrameType::P:
        return "P";
    case FrameType::B:
        return "B";
    }
    return "?";
}

const char* rateName(RateMode r) {
    switch (r) {
    case RateMode::Lossless:
        return "lossless";
    case RateMode::MaxError:
        return "max-error";
    case RateMode::Psnr:
        return "psnr";
    case RateMode::Bpv:
        return "bpv";
    case RateMode::RelError:
        return "rel-error";
    case RateMode::PwRelError:
        return "pw-rel-error";
    }
    return "?";
}

} // namespace

void printVczInfo(std::ostream& out, const std::string& path, bool json, bool listBricks) {
    // Mapped, not read: the header and index are parsed from the mapping, and each payload's pages go back
    // after its checksum, so memory holds the header and index whatever the file's size.
    const MappedFile file(path);
    const std::span<const std::byte> bytes = file.bytes();
    const VczHeader h = readVczHeader(bytes, path, 0, VczHeaderUse::Bricks); // never decodes a frame
    // Every payload's checksum (XXH3, cheap next to reading the file): a corrupt brick is exit 1, not a
    // listing. Payloads are not decoded; `volcl decode` finds a checksummed payload that does not decode.
    for (std::size_t f = 0; f < h.frames.size(); ++f) {
        vczFrameAux(bytes, h, f, path);
        file.release(h.frames[f].auxOffset, h.frames[f].auxSize);
        for (std::size_t b = 0; b < h.bricks[f].size(); ++b) {
            vczBrickPayload(bytes, h, f, b, path);
            file.release(h.bricks[f][b].offset, h.bricks[f][b].size);
        }
    }
    const double voxels = double(h.dims.count());
    const std::optional<LodStatistics> lod = LodStatistics::fromHeader(h, path);
    nlohmann::json frames = nlohmann::json::array();
    for (std::size_t f = 0; f < h.frames.size(); ++f) {
        const VczFrame& e = h.frames[f];
        std::uint64_t size = e.auxSize;
        for (const VczBrickEntry& b : h.bricks[f])
            size += b.size;
        nlohmann::json refs = nlohmann::json::array();
        for (std::int32_t r : {e.reference0, e.reference1})
            if (r >= 0) refs.push_back(r);
        nlohmann::json bricks = nlohmann::json::array();
        for (std::size_t b = 0; b < h.brickCount(); ++b) {
            const Dims o = h.brickOrigin(b), d = h.brickDims(b);
            nlohmann::json e{{"brick", b},
                             {"origin", {o.x, o.y, o.z}},
                             {"dims", {d.x, d.y, d.z}},
                             {"bytes", h.bricks[f][b].size},
                             {"range", {h.bricks[f][b].min, h.bricks[f][b].max}}};
            if (lod && lod->has(f)) {
                nlohmann::json levels = nlohmann::json::array();
                for (int l = 0; l <= h.levels; ++l) {
                    const BrickLevelStats& st = lod->at(f, b, l);
                    levels.push_back({{"level", l}, {"range", {st.min, st.max}}, {"max_error", st.error}});
                }
                e["levels"] = levels;
            }
            bricks.push_back(e);
        }
        frames.push_back({{"frame", f},
                          {"bricks", bricks},
                          {"type", frameTypeName(e.type)},
                          {"references", refs},
                          {"bytes", size},
                          {"motion_bytes", e.auxSize},
                          {"bits_per_voxel", double(size) * 8 / voxels},
                          {"time", e.time}});
    }
    nlohmann::json j{{"file", path},
                     {"format", "vcz"},
                     {"dims", {h.dims.x, h.dims.y, h.dims.z}},
                     {"type", std::string(scalarTypeName(h.voxelType()))},
                     {"spacing", h.spacing},
                     {"origin", h.origin},
                     {"range", {h.valueMin, h.valueMax}},
                     {"wavelet", std::string(waveletName(h.wavelet))},
                     {"levels", h.levels},
                     {"brick", {h.brick.x, h.brick.y, h.brick.z}},
                     {"brick_grid", {h.brickGrid().x, h.brickGrid().y, h.brickGrid().z}},
                     {"lod_statistics", lod.has_value()},
                     {"rate", rateName(h.rate)},
                     {"rate_target", h.rateTarget},
                     {"bytes", bytes.size()},
                     {"bits_per_voxel", double(bytes.size()) * 8 / (voxels * double(h.frames.size()))},
                     {"frames", frames}};
    // Stored integers of a scaled NIfTI source: the range above is in stored units; say how to get data units.
    const WriteOptions wo = vczWriteOptions(h, path);
    if (wo.niftiStoredValues)
        j["nifti_scale"] = {{"scl_slope", wo.nifti->sclSlope}, {"scl_inter", wo.nifti->sclInter}};
    if (json) {
        out << j.dump(2) << '\n';
        return;
    }
    out << path << '\n'
        << "  format   vcz (" << rateName(h.rate) << ", " << waveletName(h.wavelet) << ", " << h.levels
        << " levels, bricks " << h.brick.x << "x" << h.brick.y << "x" << h.brick.z << ")\n"
        << "  dims     " << h.dims.x << " x " << h.dims.y << " x " << h.dims.z << "  (" << h.frames.size()
        << " frames)\n"
        << "  type     " << scalarTypeName(h.voxelType())
        << (h.float64 ? " (bricks and renderers: its float32 layer)" : "") << '\n'
        << std::setprecision(6) << "  spacing  " << h.spacing[0] << " x " << h.spacing[1] << " x "
        << h.spacing[2] << '\n'
        << "  origin   " << h.origin[0] << ", " << h.origin[1] << ", " << h.origin[2] << '\n'
        << "  range    " << h.valueMin << " .. " << h.valueMax << '\n';
    const double lo = h.valueMin * wo.nifti.value_or(NiftiMetadata{}).sclSlope +
                      wo.nifti.value_or(NiftiMetadata{}).sclInter;
    const double hi = h.valueMax * wo.nifti.value_or(NiftiMetadata{}).sclSlope +
                      wo.nifti.value_or(NiftiMetadata{}).sclInter;
    if (wo.niftiStoredValues)
        out << "  scale    stored NIfTI integers: value = stored * " << wo.nifti->sclSlope << " + "
            << wo.nifti->sclInter << " (data units " << std::min(lo, hi) << " .. " << std::max(lo, hi)
            << ")\n";
    out << "  size     " << bytes.size() << " bytes, " << std::fixed << std::setprecision(4)
        << j["bits_per_voxel"].get<double>() << " bits/voxel\n"
        << "  frame  type  refs       bytes  motion  bits/voxel\n";
    for (const auto& f : frames) {
        std::string refs;
        for (const auto& r : f["references"]) {
            if (!refs.empty()) refs += ',';
            refs += std::to_string(r.get<int>());
        }
        out << "  " << std::setw(5) << f["frame"].get<std::size_t>() << "  " << std::setw(4)
            << f["type"].get<std::string>() << "  " << std::setw(5) << (refs.empty() ? "-" : refs) << "  "
            << std::setw(10) << f["bytes"].get<std::uint64_t>() << "  " << std::setw(6)
            << f["motion_bytes"].get<std::uint64_t>() << "  " << std::setw(10) << std::setprecision(4)
            << f["bits_per_voxel"].get<double>() << '\n';
    }
    const Dims g = h.brickGrid();
    out << "  bricks   " << h.brickCount() << " (" << g.x << " x " << g.y << " x " << g.z
        << "), level-of-detail statistics " << (lod ? "stored" : "absent")
        << (listBricks ? "" : "; --bricks lists them") << '\n';
    for (std::size_t f = 0; listBricks && f < h.frames.size(); ++f) {
        out << "  frame " << f << ": brick  origin          dims         bytes        min        max";
        if (lod && lod->has(f)) out << "  max error per level 0.." << h.levels;
        out << '\n';
        for (std::size_t b = 0; b < h.brickCount(); ++b) {
            const Dims o = h.brickOrigin(b), d = h.brickDims(b);
            const VczBrickEntry& e = h.bricks[f][b];
            std::ostringstream pos, dim;
            pos << o.x << "," << o.y << "," << o.z;
            dim << d.x << "x" << d.y << "x" << d.z;
            out << "  " << std::setw(13) << b << "  " << std::left << std::setw(14) << pos.str() << "  "
                << std::setw(11) << dim.str() << std::right << "  " << std::setw(10) << e.size << "  "
                << std::defaultfloat << std::setprecision(6) << std::setw(9) << e.min << "  " << std::setw(9)
                << e.max;
            if (lod && lod->has(f))
                for (int l = 0; l <= h.levels; ++l)
                    out << "  " << lod->at(f, b, l).error;
            out << '\n';
        }
    }
}

WriteOptions vczWriteOptions(const VczHeader& h, const std::string& name) {
    WriteOptions wo;
    if (auto n = niftiFromVczMetadata(h.metadata, name)) {
        wo.nifti = std::move(n->meta);
        wo.niftiStoredValues = n->storedValues;
    }
    return wo;
}

} // namespace volcl::cli
