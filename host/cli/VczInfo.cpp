// The .vcz header and frame table as `volcl info` prints them.
#include "host/cli/VczInfo.hpp"

#include "host/io/AtomicFile.hpp"
#include "wavelet/Codec.hpp"

#include <nlohmann/json.hpp>

#include <iomanip>

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
    }
    return "?";
}

} // namespace

void printVczInfo(std::ostream& out, const std::string& path, bool json) {
    const std::vector<std::byte> bytes = readFileBytes(path);
    const VczHeader h = readVczHeader(bytes, path);
    const double voxels = double(h.dims.count());
    nlohmann::json frames = nlohmann::json::array();
    for (std::size_t f = 0; f < h.frames.size(); ++f) {
        const VczFrame& e = h.frames[f];
        std::uint64_t size = e.auxSize;
        for (const VczBrickEntry& b : h.bricks[f])
            size += b.size;
        nlohmann::json refs = nlohmann::json::array();
        for (std::int32_t r : {e.reference0, e.reference1})
            if (r >= 0) refs.push_back(r);
        frames.push_back({{"frame", f},
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
                     {"type", std::string(scalarTypeName(h.type))},
                     {"spacing", h.spacing},
                     {"origin", h.origin},
                     {"range", {h.valueMin, h.valueMax}},
                     {"wavelet", std::string(waveletName(h.wavelet))},
                     {"levels", h.levels},
                     {"brick", {h.brick.x, h.brick.y, h.brick.z}},
                     {"rate", rateName(h.rate)},
                     {"rate_target", h.rateTarget},
                     {"bytes", bytes.size()},
                     {"bits_per_voxel", double(bytes.size()) * 8 / (voxels * double(h.frames.size()))},
                     {"frames", frames}};
    if (json) {
        out << j.dump(2) << '\n';
        return;
    }
    out << path << '\n'
        << "  format   vcz (" << rateName(h.rate) << ", " << waveletName(h.wavelet) << ", " << h.levels
        << " levels, bricks " << h.brick.x << "x" << h.brick.y << "x" << h.brick.z << ")\n"
        << "  dims     " << h.dims.x << " x " << h.dims.y << " x " << h.dims.z << "  (" << h.frames.size()
        << " frames)\n"
        << "  type     " << scalarTypeName(h.type) << '\n'
        << std::setprecision(6) << "  range    " << h.valueMin << " .. " << h.valueMax << '\n'
        << "  size     " << bytes.size() << " bytes, " << std::fixed << std::setprecision(4)
        << j["bits_per_voxel"].get<double>() << " bits/voxel\n"
        << "  frame  type  refs       bytes  motion  bits/voxel\n";
    for (const auto& f : frames) {
        std::string refs;
        for (const auto& r : f["references"])
            refs += (refs.empty() ? "" : ",") + std::to_string(r.get<int>());
        out << "  " << std::setw(5) << f["frame"].get<std::size_t>() << "  " << std::setw(4)
            << f["type"].get<std::string>() << "  " << std::setw(5) << (refs.empty() ? "-" : refs) << "  "
            << std::setw(10) << f["bytes"].get<std::uint64_t>() << "  " << std::setw(6)
            << f["motion_bytes"].get<std::uint64_t>() << "  " << std::setw(10) << std::setprecision(4)
            << f["bits_per_voxel"].get<double>() << '\n';
    }
}

} // namespace volcl::cli
