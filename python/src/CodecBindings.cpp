// The wavelet codec for Python: encode arrays to .vcz bytes, and random access to .vcz bytes (regions,
// levels, frames, single bricks).
#include "python/src/Bindings.hpp"

#include "core/AtomicFile.hpp"
#include "core/Error.hpp"
#include "host/io/NiftiMetadata.hpp"
#include "wavelet/Codec.hpp"
#include "wavelet/container/LodStatistics.hpp"

#include <nanobind/stl/array.h>
#include <nanobind/stl/map.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/tuple.h>
#include <nanobind/stl/vector.h>

#include <memory>

namespace volcl::python {
namespace {

using ByteArray = nb::ndarray<const std::uint8_t, nb::ndim<1>, nb::c_contig, nb::device::cpu>;

RateMode parseRate(const std::string& rate) {
    if (rate == "lossless") return RateMode::Lossless;
    if (rate == "max_error") return RateMode::MaxError;
    if (rate == "psnr") return RateMode::Psnr;
    if (rate == "bpv") return RateMode::Bpv;
    if (rate == "rel_error") return RateMode::RelError;
    if (rate == "pw_rel_error") return RateMode::PwRelError;
    throw UsageError("rate '" + rate + "' must be lossless, max_error, rel_error, pw_rel_error, psnr or bpv");
}

nb::dict reportDict(const EncodeReport& r) {
    nb::dict d;
    d["bytes"] = r.bytes;
    d["bits_per_voxel"] = r.bitsPerVoxel;
    d["psnr"] = r.psnr;
    d["max_error"] = r.maxError;
    d["corrections"] = r.corrections;
    d["step"] = r.step;
    d["milliseconds"] = r.profile.total;
    return d;
}

// .vcz bytes and what the encoder measured (single volumes only: a series reports its size alone).
std::tuple<nb::bytes, nb::dict>
encode(Context& context, const std::vector<InputArray>& frames, const std::array<double, 3>& spacing,
       const std::array<double, 3>& origin, const std::string& rate, double target,
       std::optional<double> step, std::optional<std::string> wavelet, int levels,
       const std::array<std::size_t, 3>& brick, const std::string& entropy, unsigned threads,
       const std::map<std::string, std::string>& metadata, const std::string& motion, std::size_t gop,
       std::size_t bFrames, bool globalShift, bool lodStats) {
    if (frames.empty()) throw UsageError("encode: no frames given");
    CodecOptions o;
    o.rate = parseRate(rate);
    o.target = target;
    if (step) {
        if (o.rate == RateMode::Lossless)
            throw UsageError("--step needs a lossy mode (--max-error, --psnr or --bpv)");
        o.step = step;
    }
    if (wavelet) o.wavelet = parseWavelet(*wavelet);
    o.levels = levels;
    o.brick = {brick[0], brick[1], brick[2]};
    o.entropy = parseEntropy(entropy);
    o.threads = std::max(1u, threads);
    o.metadata = metadata;
    if (motion == "block")
        o.motion = MotionMode::Block;
    else if (motion == "none")
        o.motion = MotionMode::None;
    else
        throw UsageError("motion '" + motion + "' must be block or none");
    if (gop == 0) throw UsageError("gop must be at least 1");
    o.gop = gop;
    o.bFrames = bFrames;
    o.globalShift = globalShift;
    TimeSeries series;
    for (const InputArray& a : frames)
        series.frames.push_back(arrayToVolume(a, spacing, origin));
    std::vector<std::byte> bytes;
    EncodeReport report;
    {
        nb::gil_scoped_release released;
        series.validate();
        std::lock_guard lock(context.mutex);
        // What `volcl encode` adds by default; with it the bytes equal the command line's for the same input.
        if (lodStats && o.rate == RateMode::Bpv)
            bytes = encodeWithLodStatistics(context.cc, series, o, "<array>", &report);
        else if (series.frames.size() == 1)
            bytes = encodeVolume(context.cc, series.frames[0], o, &report);
        else
            bytes = encodeSeries(context.cc, series, o);
        if (lodStats && o.rate != RateMode::Bpv)
            bytes = addLodStatistics(context.cc, std::move(bytes), series.frames, "<array>");
        report.bytes = bytes.size();
    }
    return {nb::bytes(bytes.data(), bytes.size()), reportDict(report)};
}

// A metadata value as Python sees it: text stays str; a value that is not UTF-8 (the codec's own binary
// entries, such as the level-of-detail statistics `volcl encode` stores) comes back as bytes, unchanged.
nb::object metadataValue(const std::string& value) {
    PyObject* text = PyUnicode_DecodeUTF8(value.data(), static_cast<Py_ssize_t>(value.size()), "strict");
    if (text != nullptr) return nb::steal(text);
    PyErr_Clear();
    return nb::bytes(value.data(), value.size());
}

nb::dict metadataDict(const std::map<std::string, std::string>& metadata) {
    nb::dict d;
    for (const auto& [key, value] : metadata)
        d[metadataValue(key)] = metadataValue(value);
    return d;
}

nb::dict headerDict(const VczHeader& h) {
    nb::dict d;
    d["shape"] = std::array<std::size_t, 3>{h.dims.z, h.dims.y, h.dims.x};
    d["dtype"] = numpyTypeName(h.voxelType());
    d["spacing"] = h.spacing;
    d["origin"] = h.origin;
    d["wavelet"] = std::string(waveletName(h.wavelet));
    d["levels"] = h.levels;
    d["brick"] = std::array<std::size_t, 3>{h.brick.z, h.brick.y, h.brick.x};
    d["brick_grid"] = std::array<std::size_t, 3>{h.brickGrid().z, h.brickGrid().y, h.brickGrid().x};
    d["entropy"] = std::string(entropyName(h.entropy));
    const char* rates[] = {"lossless", "max_error", "psnr", "bpv", "rel_error", "pw_rel_error"};
    d["rate"] = rates[static_cast<int>(h.rate)];
    d["rate_target"] = h.rateTarget;
    d["value_range"] = std::array<double, 2>{h.valueMin, h.valueMax};
    std::vector<double> times;
    std::vector<std::string> types;
    for (const VczFrame& f : h.frames) {
        times.push_back(f.time);
        types.push_back(f.type == FrameType::I ? "I" : f.type == FrameType::P ? "P" : "B");
    }
    d["times"] = times;
    d["frame_types"] = types;
    d["metadata"] = metadataDict(h.metadata);
    return d;
}

// A decoded volume with the grid it sits on (a level decode has a coarser spacing and a moved origin).
using Decoded = std::tuple<nb::object, std::array<double, 3>, std::array<double, 3>>;

Decoded decoded(Volume v) {
    const auto spacing = v.spacing, origin = v.origin;
    return {volumeToArray(std::move(v)), spacing, origin};
}

/// A .vcz held in memory; bricks and frames are decoded only when asked for.
class Vcz {
public:
    Vcz(const ByteArray& data, const std::string& name)
        : Vcz(std::vector<std::byte>(reinterpret_cast<const std::byte*>(data.data()),
                                     reinterpret_cast<const std::byte*>(data.data()) + data.size()),
              name) {}
    Vcz(std::vector<std::byte> bytes, const std::string& name) : reader_(std::move(bytes), name) {
        if (auto n = niftiFromVczMetadata(reader_.header().metadata, name); n && n->storedValues)
            storedScale_ = std::move(n->meta);
    }
    /// Reads the file with the library's reader (the command line's messages for a missing file).
    static Vcz open(const std::string& path) {
        std::vector<std::byte> bytes;
        {
            nb::gil_scoped_release released;
            bytes = readFileBytes(path);
        }
        return Vcz(std::move(bytes), path);
    }

    nb::dict header() const { return headerDict(reader_.header()); }
    /// (scl_slope, scl_inter) when the voxels are a NIfTI source's stored integers, else None.
    std::optional<std::array<double, 2>> storedScale() const {
        if (!storedScale_) return std::nullopt;
        return std::array<double, 2>{storedScale_->sclSlope, storedScale_->sclInter};
    }
    std::size_t fileSize() const { return reader_.fileSize(); }

    Decoded decode(Context& context, std::optional<std::array<std::size_t, 3>> lo,
                   std::optional<std::array<std::size_t, 3>> hi, int level, std::size_t frame,
                   unsigned threads, bool stored) const {
        DecodeOptions o;
        if (lo || hi) {
            if (!lo || !hi) throw UsageError("region needs both corners (lo and hi)");
            o.region = Region{{(*lo)[0], (*lo)[1], (*lo)[2]}, {(*hi)[0], (*hi)[1], (*hi)[2]}};
        }
        o.level = level;
        o.frame = frame;
        o.threads = std::max(1u, threads);
        Volume v;
        {
            nb::gil_scoped_release released;
            std::lock_guard lock(context.mutex);
            v = reader_.decode(context.cc, o);
        }
        return decoded(inUnits(std::move(v), stored));
    }

    Decoded decodeBrick(Context& context, std::size_t frame, std::size_t brick, int level,
                        bool stored) const {
        Volume v;
        {
            nb::gil_scoped_release released;
            std::lock_guard lock(context.mutex);
            v = reader_.decodeBrick(context.cc, frame, brick, level);
        }
        return decoded(inUnits(std::move(v), stored));
    }

    // Voxel index box of brick `i` at full resolution, as (z, y, x) corners [lo, hi).
    std::tuple<std::array<std::size_t, 3>, std::array<std::size_t, 3>> brickBox(std::size_t i) const {
        const VczHeader& h = reader_.header();
        if (i >= h.brickCount())
            throw UsageError("brick " + std::to_string(i) + " out of range (the file has " +
                             std::to_string(h.brickCount()) + " bricks)");
        const Dims o = h.brickOrigin(i), d = h.brickDims(i);
        return {{o.z, o.y, o.x}, {o.z + d.z, o.y + d.y, o.x + d.x}};
    }

private:
    // Data units, as the command line's outputs other than NIfTI and volcl.read of the .nii give them, unless
    // the stored integers are asked for.
    Volume inUnits(Volume v, bool stored) const {
        return storedScale_ && !stored ? niftiDataUnits(v, *storedScale_) : v;
    }

    VczReader reader_;
    std::optional<NiftiMetadata> storedScale_;
};

} // namespace

void bindCodec(nb::module_& m) {
    m.def("encode", &encode, nb::arg("context"), nb::arg("frames"), nb::arg("spacing"), nb::arg("origin"),
          nb::arg("rate"), nb::arg("target"), nb::arg("step").none(), nb::arg("wavelet").none(),
          nb::arg("levels"), nb::arg("brick"), nb::arg("entropy"), nb::arg("threads"), nb::arg("metadata"),
          nb::arg("motion"), nb::arg("gop"), nb::arg("b_frames"), nb::arg("global_shift"),
          nb::arg("lod_stats"),
          "Encodes one volume or a series into .vcz bytes, as `volcl encode` does; returns (bytes, report).");
    nb::class_<Vcz>(m, "Vcz", "A .vcz in memory: header parsed and checked, bricks decoded on demand.")
        .def(nb::init<const ByteArray&, const std::string&>(), nb::arg("data"), nb::arg("name"))
        .def_static("open", &Vcz::open, nb::arg("path"))
        .def_prop_ro("header", &Vcz::header)
        .def_prop_ro("file_size", &Vcz::fileSize)
        .def("decode", &Vcz::decode, nb::arg("context"), nb::arg("lo").none(), nb::arg("hi").none(),
             nb::arg("level"), nb::arg("frame"), nb::arg("threads"), nb::arg("stored"))
        .def_prop_ro("stored_scale", &Vcz::storedScale)
        .def("decode_brick", &Vcz::decodeBrick, nb::arg("context"), nb::arg("frame"), nb::arg("brick"),
             nb::arg("level"), nb::arg("stored"))
        .def("brick_box", &Vcz::brickBox, nb::arg("brick"));
}

} // namespace volcl::python
