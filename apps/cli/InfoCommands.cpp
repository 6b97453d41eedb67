// `volcl info`, `volcl devices` and `volcl convert`.
#include "apps/cli/CliParsing.hpp"
#include "apps/cli/Commands.hpp"
#include "apps/cli/MeshCodecCommands.hpp"
#include "apps/cli/MeshInfo.hpp"
#include "apps/cli/Progress.hpp"
#include "apps/cli/VczInfo.hpp"
#include "core/AtomicFile.hpp"
#include "core/Error.hpp"
#include "core/runtime/ClRuntime.hpp"
#include "host/image/ImageIo.hpp"
#include "host/io/IoDetail.hpp"
#include "host/io/VolumeIo.hpp"
#include "wavelet/Codec.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <limits>
#include <memory>
#include <optional>
#include <sstream>
#include <type_traits>

namespace volcl::cli {

namespace {

constexpr std::size_t kHistogramBins = 16;
/// Bins per axis of `info --histogram2d`.
constexpr int kHistogram2dBins = 256;

/// `info --histogram2d`: the value x gradient-magnitude histogram of frame 0, the map to pick 2D transfer
/// function widgets on (docs/transfer-functions.md). Gradients by central differences (one-sided at the faces)
/// in data value per world unit. Image x: value bins over the finite value range; y: gradient bins from 0
/// (bottom row) to the 99.5th percentile of the magnitudes (the rest clamp into the top row); grey level
/// log(1 + count) / log(1 + largest count). Prints the axes.
void writeHistogram2d(std::ostream& out, const Volume& v, const std::filesystem::path& path) {
    const Dims d = v.dims();
    const std::vector<float> f = v.toFloat();
    std::vector<float> gm(f.size(), std::numeric_limits<float>::quiet_NaN());
    auto diff = [&](std::size_t i, std::size_t n, std::size_t stride, std::size_t at, double h) {
        const std::size_t lo = i > 0 ? at - stride : at, hi = i + 1 < n ? at + stride : at;
        const double span = double((i + 1 < n ? 1 : 0) + (i > 0 ? 1 : 0)) * h;
        return span > 0.0 ? (double(f[hi]) - double(f[lo])) / span : 0.0;
    };
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    std::vector<float> finiteGm;
    for (std::size_t k = 0; k < d.z; ++k)
        for (std::size_t j = 0; j < d.y; ++j)
            for (std::size_t i = 0; i < d.x; ++i) {
                const std::size_t at = v.index(i, j, k);
                const double gx = diff(i, d.x, 1, at, v.spacing[0]), gy = diff(j, d.y, d.x, at, v.spacing[1]),
                             gz = diff(k, d.z, d.x * d.y, at, v.spacing[2]);
                const double g = std::sqrt(gx * gx + gy * gy + gz * gz);
                if (!std::isfinite(f[at]) || !std::isfinite(g)) continue;
                gm[at] = float(g);
                finiteGm.push_back(float(g));
                lo = std::min(lo, double(f[at]));
                hi = std::max(hi, double(f[at]));
            }
    if (finiteGm.empty()) throw DataError(path.string() + ": no finite voxel to histogram");
    const std::size_t q = std::min(finiteGm.size() - 1, std::size_t(0.995 * double(finiteGm.size())));
    std::nth_element(finiteGm.begin(), finiteGm.begin() + std::ptrdiff_t(q), finiteGm.end());
    double gmax = finiteGm[q];
    if (!(gmax > 0.0)) gmax = 1.0;
    if (!(hi > lo)) hi = lo + 1.0;
    const int n = kHistogram2dBins;
    std::vector<double> counts(std::size_t(n) * std::size_t(n), 0.0);
    for (std::size_t at = 0; at < f.size(); ++at) {
        if (std::isnan(gm[at])) continue;
        const int x = std::clamp(int((double(f[at]) - lo) / (hi - lo) * n), 0, n - 1);
        const int y = std::clamp(int(double(gm[at]) / gmax * n), 0, n - 1);
        counts[std::size_t(y) * std::size_t(n) + std::size_t(x)] += 1.0;
    }
    const double top = std::log1p(*std::max_element(counts.begin(), counts.end()));
    ImageBuffer img(n, n, {"R", "G", "B"});
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
            const float g = float(std::log1p(counts[std::size_t(y) * std::size_t(n) + std::size_t(x)]) / top);
            for (int c = 0; c < 3; ++c)
                img.at(x, n - 1 - y, c) = g;
        }
    writeImage(img, path);
    out << "histogram2d: " << n << "x" << n << " -> " << path.string() << "; x: value " << lo << " .. " << hi
        << ", y (bottom to top): gradient magnitude 0 .. " << gmax << " per world unit (99.5th percentile)\n";
}

// Statistics over every frame of a series, so a 4D file reports its whole range.
VolumeStats seriesStats(const TimeSeries& ts, bool quiet) {
    if (ts.frames.size() == 1) return ts.frames[0].stats(kHistogramBins);
    // Two passes over every frame (range, then histogram): long for big series, so show progress.
    Progress progress("statistics", 2 * ts.frames.size(), quiet);
    VolumeStats all;
    double lo = INFINITY, hi = -INFINITY, sum = 0, sum2 = 0;
    std::size_t n = 0;
    for (const Volume& v : ts.frames) {
        VolumeStats s = v.stats(1);
        progress.advance();
        all.nanCount += s.nanCount;
        all.infCount += s.infCount;
        std::size_t finite = v.voxelCount() - s.nanCount - s.infCount;
        if (finite == 0) continue;
        lo = std::min(lo, s.min);
        hi = std::max(hi, s.max);
        sum += s.mean * double(finite);
        sum2 += (s.stddev * s.stddev + s.mean * s.mean) * double(finite);
        n += finite;
    }
    if (n == 0) return all;
    all.min = lo;
    all.max = hi;
    all.mean = sum / double(n);
    all.stddev = std::sqrt(std::max(0.0, sum2 / double(n) - all.mean * all.mean));
    all.histogram.assign(kHistogramBins, 0);
    double width = hi > lo ? (hi - lo) / double(kHistogramBins) : 1.0;
    for (const Volume& v : ts.frames) {
        for (std::size_t i = 0; i < v.voxelCount(); ++i) {
            double x = v.valueAt(i);
            if (std::isfinite(x))
                ++all.histogram[std::min<std::size_t>(std::size_t((x - lo) / width), kHistogramBins - 1)];
        }
        progress.advance();
    }
    return all;
}

nlohmann::json infoJson(const std::string& path, VolumeFormat format, const TimeSeries& ts,
                        const VolumeStats& st) {
    const Volume& v = ts.frames.front();
    nlohmann::json j;
    j["file"] = path;
    j["format"] = std::string(volumeFormatName(format));
    j["dims"] = {v.dims().x, v.dims().y, v.dims().z};
    j["type"] = std::string(scalarTypeName(v.type()));
    j["spacing"] = v.spacing;
    j["origin"] = v.origin;
    j["frames"] = ts.frames.size();
    if (!ts.times.empty()) j["times"] = ts.times;
    j["range"] = {st.min, st.max};
    j["mean"] = st.mean;
    j["stddev"] = st.stddev;
    j["nan_count"] = st.nanCount;
    j["inf_count"] = st.infCount;
    j["histogram"] = st.histogram;
    return j;
}

void printInfoText(std::ostream& out, const nlohmann::json& j) {
    out << j["file"].get<std::string>() << '\n';
    out << "  format   " << j["format"].get<std::string>() << '\n';
    out << "  dims     " << j["dims"][0] << " x " << j["dims"][1] << " x " << j["dims"][2];
    if (j["frames"].get<std::size_t>() > 1) out << "  (" << j["frames"] << " frames)";
    out << '\n';
    out << "  type     " << j["type"].get<std::string>() << '\n';
    out << std::setprecision(6);
    out << "  spacing  " << j["spacing"][0].get<double>() << ' ' << j["spacing"][1].get<double>() << ' '
        << j["spacing"][2].get<double>() << '\n';
    out << "  origin   " << j["origin"][0].get<double>() << ' ' << j["origin"][1].get<double>() << ' '
        << j["origin"][2].get<double>() << '\n';
    out << "  range    " << j["range"][0].get<double>() << " .. " << j["range"][1].get<double>() << '\n';
    out << "  mean     " << j["mean"].get<double>() << "  (stddev " << j["stddev"].get<double>() << ")\n";
    if (j["nan_count"].get<std::size_t>() || j["inf_count"].get<std::size_t>())
        out << "  non-finite  " << j["nan_count"] << " NaN, " << j["inf_count"] << " Inf\n";
    // Histogram summary: per-bin share as a bar of eighths, easy to eyeball in a terminal.
    const auto& h = j["histogram"];
    std::uint64_t total = 0;
    for (const auto& b : h)
        total += b.get<std::uint64_t>();
    out << "  histogram ";
    static const char* kBars[] = {" ",      "\u2581", "\u2582", "\u2583", "\u2584",
                                  "\u2585", "\u2586", "\u2587", "\u2588"};
    std::uint64_t peak = 1;
    for (const auto& b : h)
        peak = std::max(peak, b.get<std::uint64_t>());
    for (const auto& b : h) {
        double f = std::sqrt(double(b.get<std::uint64_t>()) / double(peak)); // sqrt: small bins stay visible
        out << kBars[std::min(8, int(std::ceil(f * 8)))];
    }
    out << "  (" << h.size() << " bins over the range, " << total << " finite voxels)\n";
}

} // namespace

void printVolumeInfo(std::ostream& out, const std::string& path, const TimeSeries& ts, bool json,
                     bool quiet) {
    ts.validate();
    nlohmann::json j = infoJson(path, detectVolumeFormat(path), ts, seriesStats(ts, quiet));
    if (json)
        out << j.dump(2) << '\n';
    else
        printInfoText(out, j);
}

namespace {

// A multi-channel file: each channel as a volume of its own (text: one block per channel; JSON: "channels").
void printChannelsInfo(std::ostream& out, const std::string& path, const TimeSeries& channels, bool json,
                       bool quiet) {
    nlohmann::json all;
    all["file"] = path;
    all["channels"] = nlohmann::json::array();
    for (std::size_t c = 0; c < channels.frames.size(); ++c) {
        TimeSeries one;
        one.frames.push_back(channels.frames[c]);
        nlohmann::json j = infoJson(path, detectVolumeFormat(path), one, seriesStats(one, quiet));
        j["channel"] = c;
        all["channels"].push_back(j);
    }
    if (json) {
        out << all.dump(2) << '\n';
        return;
    }
    out << path << ": " << channels.frames.size() << " channels (--channel K reads one)\n";
    for (const auto& j : all["channels"]) {
        out << "channel " << j["channel"] << ":\n";
        printInfoText(out, j);
    }
}

// `volcl info`: a volume's dims, type, spacing and statistics; a mesh's or a .vcz's summary.
void addInfo(CLI::App& app, GlobalOptions& global) {
    auto* cmd = app.add_subcommand(
        "info", "Print dims, type, spacing, value range, mean and histogram (of a .vcz: its frame table)");
    auto file = std::make_shared<std::string>();
    auto json = std::make_shared<bool>(false);
    auto bricks = std::make_shared<bool>(false);
    auto histogram2d = std::make_shared<std::string>();
    auto raw = std::make_shared<RawReadFlags>();
    auto meshFlags = std::make_shared<MeshReadFlags>();
    cmd->add_option("file", *file, "Volume or mesh file")->required();
    cmd->add_option(
        "--histogram2d", *histogram2d,
        "Also write the value x gradient-magnitude histogram of frame 0 as an image (PNG or EXR), "
        "to pick 2D transfer-function widgets");
    cmd->add_flag("--json", *json, "Print JSON instead of text");
    cmd->add_flag("--bricks", *bricks,
                  "A .vcz: list every brick (origin, dims, bytes, range) of every frame");
    raw->add(*cmd);
    meshFlags->add(*cmd);
    cmd->callback([file, json, bricks, histogram2d, raw, meshFlags, &global] {
        if (!histogram2d->empty() && (meshcodec::isVcmFile(*file) || mesh::detectMeshFormat(*file) ||
                                      std::filesystem::path(*file).extension() == ".vcz"))
            throw UsageError("--histogram2d takes a volume file (decode a .vcz first), not " + *file);
        if (meshcodec::isVcmFile(*file)) {
            printVcmInfo(std::cout, *file, *meshFlags, *json);
            return;
        }
        if (mesh::detectMeshFormat(*file)) {
            printMeshInfo(std::cout, *file, mesh::readMesh(*file, meshFlags->toReadOptions()), *json);
            return;
        }
        if (std::filesystem::path(*file).extension() == ".vcz") {
            printVczInfo(std::cout, *file, *json, *bricks);
            return;
        }
        ReadOptions options = raw->toReadOptions();
        options.allChannels = !options.channel; // without --channel, a multi-channel file shows every channel
        std::size_t channels = 1;
        TimeSeries ts = readVolumeFile(*file, options, channels);
        if (channels > 1 && options.allChannels) {
            printChannelsInfo(std::cout, *file, ts, *json, global.quiet);
            return;
        }
        printVolumeInfo(std::cout, *file, ts, *json, global.quiet);
        if (!histogram2d->empty())
            writeHistogram2d(*json ? std::cerr : std::cout, ts.frames.at(0), *histogram2d);
    });
}

// `volcl devices`: the OpenCL devices, the selected one marked.
void addDevices(CLI::App& app, GlobalOptions& global) {
    auto* cmd =
        app.add_subcommand("devices", "List OpenCL devices (index, platform, name, memory, features)");
    auto json = std::make_shared<bool>(false);
    cmd->add_flag("--json", *json, "Print JSON instead of text");
    cmd->callback([json, &global] {
        auto devices = listDevices();
        nlohmann::json list = nlohmann::json::array();
        for (const DeviceInfo& d : devices)
            list.push_back({{"index", d.index},
                            {"platform", d.platform},
                            {"name", d.name},
                            {"version", d.version},
                            {"driver", d.driver},
                            {"type", d.isGpu   ? "gpu"
                                     : d.isCpu ? "cpu"
                                               : "other"},
                            {"compute_units", d.computeUnits},
                            {"global_mem_bytes", d.globalMemBytes},
                            {"max_alloc_bytes", d.maxAllocBytes},
                            {"fp64", d.fp64},
                            {"gl_sharing", d.hasExtension("cl_khr_gl_sharing")}});
        if (*json) {
            std::cout << list.dump(2) << '\n';
            return;
        }
        if (devices.empty())
            throw Error("no OpenCL device found (is an ICD such as pocl-opencl-icd installed?)");
        std::string selected;
        try {
            selected = ComputeContext(global.device).device().name;
        } catch (const Error&) {
            // The list is still useful when the selection is invalid; say so instead of failing.
            selected.clear();
        }
        for (const DeviceInfo& d : devices) {
            std::cout << (d.name == selected ? "* " : "  ") << d.index << ": " << d.name << " (" << d.platform
                      << ", " << d.version << ")\n      "
                      << (d.isGpu   ? "GPU"
                          : d.isCpu ? "CPU"
                                    : "other")
                      << ", " << d.computeUnits << " compute units, " << (d.globalMemBytes >> 20)
                      << " MiB global, max alloc " << (d.maxAllocBytes >> 20) << " MiB, fp64 "
                      << (d.fp64 ? "yes" : "no") << ", cl_khr_gl_sharing "
                      << (d.hasExtension("cl_khr_gl_sharing") ? "yes" : "no") << '\n';
        }
    });
}

// `volcl convert`: a volume to another format (or type, crop, frame), a mesh to .vtu.
void addConvert(CLI::App& app, GlobalOptions& global) {
    auto* cmd =
        app.add_subcommand("convert", "Convert between volume formats (raw, NRRD, NIfTI, VTI, VDB out)");
    struct Args {
        std::string in, out, type, crop;
        std::size_t frame = 0;
        bool bigEndianOut = false;
        std::optional<double> replaceNan;
        RawReadFlags raw;
        MeshReadFlags mesh;
        VtuWriteFlags vtu;
    };
    auto a = std::make_shared<Args>();
    cmd->add_option("input", a->in, "Input volume (any supported format)")->required();
    cmd->add_option("-o,--output", a->out,
                    "Output file: .raw, .nrrd, .nhdr, .nii, .nii.gz (3D or 4D), .vti or .vdb")
        ->required();
    cmd->add_option("--to-type", a->type,
                    "Convert voxels to uint8, uint16, int16, float32 or float64 (clamped)");
    cmd->add_option("--crop", a->crop, "Keep the voxel box x0,y0,z0:x1,y1,z1 (half-open)");
    cmd->add_option("--frame", a->frame,
                    "Frame K of a time series (default: every frame, into a 4D .nii/.nii.gz or a printf "
                    "pattern such as frames_%03d.nrrd)");
    cmd->add_option("--replace-nan", a->replaceNan,
                    "Replace NaN voxels (float32) by this value, e.g. 0, so the volume can be rendered");
    cmd->add_flag("--big-endian", a->bigEndianOut, "Write raw/NRRD output big-endian");
    a->raw.add(*cmd);
    a->mesh.add(*cmd);
    a->vtu.add(*cmd);
    cmd->callback([a, cmd, &global] {
        checkNotSameFile(a->in, a->out);
        if (meshcodec::isMeshFile(a->in)) { // a mesh converts to .vtu only
            if (!a->out.ends_with(".vtu")) throw UsageError("-o " + a->out + ": a mesh converts to .vtu");
            const mesh::VtuWriteOptions wo = a->vtu.toWriteOptions();
            const mesh::TetMesh m = meshcodec::readAnyMesh(a->in, a->mesh.toReadOptions());
            mesh::writeVtu(m, a->out, wo);
            if (!global.quiet)
                std::cerr << "volcl: wrote " << a->out << " (" << m.pointCount() << " points, "
                          << m.tetCount() << " tets)\n";
            return;
        }
        std::vector<std::filesystem::path> inputs;
        TimeSeries ts;
        WriteOptions wo;
        const bool frameGiven = cmd->count("--frame") > 0, pattern = a->out.find('%') != std::string::npos;
        // Every frame of a series goes out (a 4D NIfTI or one file per frame of a printf pattern) unless
        // --frame picks one; a format that holds one volume refuses a series instead of keeping frame 0.
        auto checkSeriesTarget = [&](std::size_t frames) {
            if (frameGiven) {
                if (a->frame >= frames)
                    throw UsageError("--frame " + std::to_string(a->frame) + " out of range: " + a->in +
                                     " has " + std::to_string(frames) + " frame(s)");
            } else if (frames > 1 && !pattern && !formatHoldsSeries(a->out)) {
                throw UsageError(a->out + ": " + a->in + " holds " + std::to_string(frames) +
                                 " frames and this format one volume: write .nii, .nii.gz, .nrrd or .nhdr "
                                 "(all frames), give "
                                 "--frame K, or a printf pattern (frames_%03d.vti)");
            }
        };
        if (std::filesystem::path(a->in).extension() == ".vcz") { // frames decoded whole
            const VczReader r{std::filesystem::path(a->in)}; // mapped: the frame is budgeted when decoded
            checkNotSameFile({std::filesystem::path(a->in)}, volumeFilesWritten(a->out));
            checkSeriesTarget(r.header().frames.size());
            // The .vcz's NIfTI header (and its stored integers' scale) goes into the output as decode does.
            wo = vczWriteOptions(r.header(), a->in);
            ComputeContext cc(global.device);
            if (frameGiven || r.header().frames.size() == 1)
                ts.frames.push_back(r.decodeFrame(cc, a->frame));
            else
                ts = decodeAllFrames(r, cc);
        } else {
            ts = readVolumeFile(a->in, a->raw.toReadOptions(), inputs);
            // A header's data files are inputs too: converting x.nhdr to its own x.raw would destroy it.
            checkNotSameFile(inputs, volumeFilesWritten(a->out));
            checkSeriesTarget(ts.frames.size());
            if (frameGiven) {
                ts.frames = {std::move(ts.frames[a->frame])};
                ts.times.clear();
            }
            // A NIfTI source's header is kept by NIfTI and VTI outputs.
            wo.nifti = readNiftiMetadataIfNifti(a->in);
        }
        wo.endian = a->bigEndianOut ? Endian::Big : Endian::Little;
        // A new type or replaced values are data units, not a scaled source's stored integers.
        if (wo.niftiStoredValues && (!a->type.empty() || a->replaceNan)) {
            for (Volume& v : ts.frames)
                v = niftiDataUnits(v, *wo.nifti);
            wo.niftiStoredValues = false;
        }
        // --to-type is the type written: the NIfTI writer must not turn data units back into the source's
        // scaled integers.
        if (!a->type.empty() && wo.nifti) wo.nifti->sclSlope = wo.nifti->sclInter = 0;
        if (a->replaceNan) {
            if (!std::isfinite(*a->replaceNan)) throw UsageError("--replace-nan: the value must be finite");
            std::size_t replaced = 0;
            auto replace = [&](auto values) {
                for (auto& x : values)
                    if (std::isnan(x)) {
                        x = static_cast<std::remove_reference_t<decltype(x)>>(*a->replaceNan);
                        ++replaced;
                    }
            };
            for (Volume& v : ts.frames) {
                if (v.type() == ScalarType::Float32) replace(v.values<float>());
                if (v.type() == ScalarType::Float64) replace(v.values<double>());
            }
            if (!global.quiet)
                std::cerr << "volcl: replaced " << replaced << " NaN voxel(s) by " << *a->replaceNan << '\n';
        }
        for (Volume& v : ts.frames) {
            if (!a->crop.empty()) {
                auto [lo, hi] = parseBox(a->crop, "--crop");
                v = v.cropped(lo, hi);
            }
            if (!a->type.empty()) v = v.convertedTo(parseScalarType(a->type));
        }
        const Volume& v = ts.frames.front();
        if (pattern && ts.frames.size() > 1) {
            const std::size_t n = ts.frames.size();
            const std::vector<std::string> names =
                io::expandFilePattern(a->out, 0, static_cast<long long>(n) - 1, 1, a->out, n);
            for (const std::string& name : names)
                checkNotSameFile(inputs.empty() ? std::vector<std::filesystem::path>{a->in} : inputs,
                                 volumeFilesWritten(name));
            AtomicCommitGroup frameFiles; // every frame or none
            for (std::size_t f = 0; f < n; ++f)
                writeVolumeFile(ts.frames[f], names[f], wo);
            frameFiles.commit();
        } else {
            writeSeriesFile(ts, a->out, wo);
        }
        if (!global.quiet)
            std::cerr << "volcl: wrote " << a->out << " (" << v.dims().x << "x" << v.dims().y << "x"
                      << v.dims().z << " " << scalarTypeName(v.type())
                      << (ts.frames.size() > 1 ? ", " + std::to_string(ts.frames.size()) + " frames" : "")
                      << ")\n";
    });
}

} // namespace

void addInfoCommands(CLI::App& app, GlobalOptions& global) {
    addInfo(app, global);
    addDevices(app, global);
    addConvert(app, global);
}

} // namespace volcl::cli
