// Cross-feature render matrix: every render input kind, opened as `volcl render` opens it, x every mode, shading
// and pre-integration (and the grid's preview tiers), against the plain grid renderer on the same decoded data
// (docs/reliability.md).
#include "TestUtil.hpp"

#include "apps/cli/SceneFlags.hpp"
#include "host/phantoms/Phantoms.hpp"
#include "render/Reference.hpp"
#include "render/RenderInput.hpp"
#include "render/grid/ChannelRenderer.hpp"
#include "render/grid/GridRenderer.hpp"
#include "render/grid/PreviewRenderer.hpp"
#include "wavelet/Codec.hpp"
#include "wavelet/container/VczFormat.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

namespace volcl {
namespace {

using test::computeContext;

constexpr Dims kDims{40, 34, 28}; // no axis a multiple of 16: every brick size leaves partial bricks
constexpr std::array<double, 3> kSpacing{0.8, 1.1, 1.5};
constexpr std::array<double, 3> kOrigin{-12.5, 4.0, 30.0};
constexpr std::size_t kFrames = 3, kFrame = 1; // series inputs render their middle frame

/// Frame f of the series: the Marschner-Lobb signal tilted by ramps in x and y (no mirror symmetry, so a
/// flipped or transposed axis shows), drifting with f, as uint8 in [20, 255] (no zero voxel: VDB keeps
/// every voxel active).
Volume phantomFrame(std::size_t f) {
    const Volume ml = marschnerLobbReference(kDims);
    Volume v(kDims, ScalarType::UInt8);
    const std::span<const float> m = ml.values<float>();
    std::span<std::uint8_t> out = v.values<std::uint8_t>();
    for (std::size_t k = 0; k < kDims.z; ++k)
        for (std::size_t j = 0; j < kDims.y; ++j)
            for (std::size_t i = 0; i < kDims.x; ++i) {
                const std::size_t n = v.index(i, j, k);
                const double x = double(i) / double(kDims.x - 1), y = double(j) / double(kDims.y - 1);
                const double s =
                    20 + 170 * m[n] + 45 * x + 20 * y * y + 8.0 * double(f) * std::sin(6 * x + 2 * y);
                out[n] = std::uint8_t(std::clamp(std::round(s), 20.0, 255.0));
            }
    v.spacing = kSpacing;
    v.origin = kOrigin;
    return v;
}

/// A 4D NIfTI-1 file (.nii, uint8, sform = spacing and origin) written field by field from the standard,
/// independently of volcl's writer (which writes 3D volumes only).
void writeNifti4d(const std::filesystem::path& p, const std::vector<Volume>& frames) {
    std::vector<char> h(352, 0);
    auto put = [&](std::size_t at, auto value) { std::memcpy(h.data() + at, &value, sizeof(value)); };
    put(0, std::int32_t(348));
    const std::int16_t dim[8] = {4,
                                 std::int16_t(kDims.x),
                                 std::int16_t(kDims.y),
                                 std::int16_t(kDims.z),
                                 std::int16_t(frames.size()),
                                 1,
                                 1,
                                 1};
    std::memcpy(h.data() + 40, dim, sizeof(dim));
    put(70, std::int16_t(2)); // DT_UNSIGNED_CHAR
    put(72, std::int16_t(8));
    const float pixdim[8] = {1.0f, float(kSpacing[0]), float(kSpacing[1]), float(kSpacing[2]), 1.0f, 1, 1, 1};
    std::memcpy(h.data() + 76, pixdim, sizeof(pixdim));
    put(108, 352.0f);             // vox_offset
    put(112, 1.0f);               // scl_slope
    h[123] = 2 | 8;               // mm, s
    put(254, std::int16_t(1));    // sform_code: scanner
    for (int r = 0; r < 3; ++r) { // srow_x, srow_y, srow_z: diagonal spacing, origin
        float row[4] = {0, 0, 0, float(kOrigin[std::size_t(r)])};
        row[r] = float(kSpacing[std::size_t(r)]);
        std::memcpy(h.data() + 280 + 16 * r, row, sizeof(row));
    }
    std::memcpy(h.data() + 344, "n+1\0", 4);
    std::ofstream out(p, std::ios::binary | std::ios::trunc);
    out.write(h.data(), std::streamsize(h.size()));
    for (const Volume& v : frames)
        out.write(reinterpret_cast<const char*>(v.values<std::uint8_t>().data()),
                  std::streamsize(v.voxelCount()));
    ASSERT_TRUE(out.good()) << p;
}

/// A semi-transparent colour TF over the phantom's values, extinction per world unit.
TransferFunction matrixTf() {
    TransferFunction tf;
    tf.domain = {0, 255};
    tf.color = {{0, {0.1, 0.2, 0.9}}, {110, {0.9, 0.5, 0.2}}, {255, {1.0, 1.0, 0.9}}};
    tf.extinction = {{0, 0.0}, {60, 0.0}, {110, 0.05}, {170, 0.3}, {255, 0.7}};
    return tf;
}

enum class Input {
    Raw,             ///< .raw named <name>_<X>x<Y>x<Z>_uint8.raw (no geometry: unit spacing, zero origin)
    Nrrd,            ///< .nrrd, gzip
    Nifti,           ///< .nii.gz written by volcl
    Nifti4dFrame,    ///< frame 1 of a 4D .nii (--frame 1)
    Vdb,             ///< OpenVDB float grid
    DicomFolder,     ///< a folder of DICOM slices (explicit VR little endian, written here byte by byte)
    Vcz16,           ///< lossless .vcz, 16^3 bricks, drawn from the bricks
    Vcz32,           ///< ... 32^3 bricks
    Vcz64,           ///< ... 64^3 bricks (one partial brick)
    VczSeriesFrame,  ///< frame 1 of a lossless 3-frame .vcz with motion (a P frame: decoded whole)
    VczLossyLodFull, ///< lossy .vcz (max error 2), render.lod full
    VczLowRate       ///< low-rate lossy .vcz (max error 8), one 128-voxel brick of 4 levels
};

std::string inputName(Input in) {
    switch (in) {
    case Input::Raw:
        return "raw";
    case Input::Nrrd:
        return "nrrd";
    case Input::Nifti:
        return "nifti";
    case Input::Nifti4dFrame:
        return "nifti4d_frame";
    case Input::Vdb:
        return "vdb";
    case Input::DicomFolder:
        return "dicom_folder";
    case Input::Vcz16:
        return "vcz_lossless_b16";
    case Input::Vcz32:
        return "vcz_lossless_b32";
    case Input::Vcz64:
        return "vcz_lossless_b64";
    case Input::VczSeriesFrame:
        return "vcz_series_frame";
    case Input::VczLossyLodFull:
        return "vcz_lossy_lod_full";
    case Input::VczLowRate:
        return "vcz_low_rate";
    }
    return "?";
}

void writeVcz(const std::filesystem::path& p, const std::vector<std::byte>& bytes) {
    test::writeFile(p, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
}

/// One explicit-VR little-endian DICOM data element, its value padded to an even length.
std::string dicomElement(std::uint16_t group, std::uint16_t element, const char vr[3], std::string value) {
    if (value.size() % 2) value += std::string_view(vr) == "UI" || std::string_view(vr) == "OB" ? '\0' : ' ';
    std::string e(4, '\0');
    std::memcpy(e.data(), &group, 2);
    std::memcpy(e.data() + 2, &element, 2);
    e += std::string(vr, 2);
    const bool longForm = std::string_view(vr) == "OB" || std::string_view(vr) == "OW";
    if (longForm) {
        const std::uint32_t n = static_cast<std::uint32_t>(value.size());
        e += std::string(2, '\0') + std::string(reinterpret_cast<const char*>(&n), 4);
    } else {
        const std::uint16_t n = static_cast<std::uint16_t>(value.size());
        e += std::string(reinterpret_cast<const char*>(&n), 2);
    }
    return e + value;
}

std::string dicomUs(std::uint16_t v) {
    return std::string(reinterpret_cast<const char*>(&v), 2);
}

/// The volume (identity direction) as DICOM Part 10 MR slices, one file per z, in LPS as DICOM states it:
/// rows and columns along -x and -y of RAS, so row x column = +z and the slices stack along z.
void writeDicomFolder(const Volume& v, const std::filesystem::path& dir) {
    std::filesystem::create_directories(dir);
    auto ds = [](double x) {
        std::ostringstream os;
        os.precision(12);
        os << x;
        return os.str();
    };
    const Dims d = v.dims();
    for (std::size_t k = 0; k < d.z; ++k) {
        std::string meta = dicomElement(0x0002, 0x0001, "OB", std::string("\0\1", 2)) +
                           dicomElement(0x0002, 0x0002, "UI", "1.2.840.10008.5.1.4.1.1.4") +
                           dicomElement(0x0002, 0x0003, "UI", "1.2.3." + std::to_string(k + 1)) +
                           dicomElement(0x0002, 0x0010, "UI", "1.2.840.10008.1.2.1");
        const std::uint32_t metaBytes = static_cast<std::uint32_t>(meta.size());
        meta = dicomElement(0x0002, 0x0000, "UL", std::string(reinterpret_cast<const char*>(&metaBytes), 4)) +
               meta;
        const auto voxels = v.values<std::uint8_t>().subspan(k * d.x * d.y, d.x * d.y);
        const std::string body =
            dicomElement(0x0008, 0x0016, "UI", "1.2.840.10008.5.1.4.1.1.4") +
            dicomElement(0x0008, 0x0018, "UI", "1.2.3." + std::to_string(k + 1)) +
            dicomElement(0x0020, 0x000e, "UI", "1.2.3.99") +
            dicomElement(0x0020, 0x0032, "DS",
                         ds(-v.origin[0]) + "\\" + ds(-v.origin[1]) + "\\" +
                             ds(v.origin[2] + static_cast<double>(k) * v.spacing[2])) +
            dicomElement(0x0020, 0x0037, "DS", "-1\\0\\0\\0\\-1\\0") +
            dicomElement(0x0028, 0x0002, "US", dicomUs(1)) +
            dicomElement(0x0028, 0x0004, "CS", "MONOCHROME2") +
            dicomElement(0x0028, 0x0010, "US", dicomUs(static_cast<std::uint16_t>(d.y))) +
            dicomElement(0x0028, 0x0011, "US", dicomUs(static_cast<std::uint16_t>(d.x))) +
            dicomElement(0x0028, 0x0030, "DS", ds(v.spacing[1]) + "\\" + ds(v.spacing[0])) +
            dicomElement(0x0028, 0x0100, "US", dicomUs(8)) + dicomElement(0x0028, 0x0101, "US", dicomUs(8)) +
            dicomElement(0x0028, 0x0102, "US", dicomUs(7)) + dicomElement(0x0028, 0x0103, "US", dicomUs(0)) +
            dicomElement(0x7fe0, 0x0010, "OB",
                         std::string(reinterpret_cast<const char*>(voxels.data()), voxels.size()));
        // Named against the slice order: the reader sorts by position.
        test::writeFile(dir / ("s" + std::to_string(d.z - k)), std::string(128, '\0') + "DICM" + meta + body);
    }
}

/// Writes the input file of kind `in` under `dir`; returns its path and, in `decoded`, the data it holds
/// as a decoder gives it back (the oracle's grid): the phantom itself for lossless kinds (checked against
/// the decoder), the decoder's output for the lossy file, unit geometry for raw.
std::filesystem::path writeInput(Input in, const std::filesystem::path& dir, Volume& decoded) {
    ComputeContext& cc = computeContext();
    const Volume v = phantomFrame(0);
    decoded = v;
    CodecOptions o;
    o.levels = 2;
    switch (in) {
    case Input::Raw: {
        const auto p = dir / "phantom_40x34x28_uint8.raw";
        decoded.spacing = {1, 1, 1};
        decoded.origin = {0, 0, 0};
        writeVolumeFile(decoded, p);
        return p;
    }
    case Input::Nrrd:
        writeVolumeFile(v, dir / "phantom.nrrd");
        return dir / "phantom.nrrd";
    case Input::Nifti:
        writeVolumeFile(v, dir / "phantom.nii.gz");
        return dir / "phantom.nii.gz";
    case Input::Vdb:
        writeVolumeFile(v, dir / "phantom.vdb");
        return dir / "phantom.vdb";
    case Input::DicomFolder:
        writeDicomFolder(v, dir / "dicom");
        return dir / "dicom";
    case Input::Nifti4dFrame: {
        std::vector<Volume> frames;
        for (std::size_t f = 0; f < kFrames; ++f)
            frames.push_back(phantomFrame(f));
        writeNifti4d(dir / "series.nii", frames);
        decoded = frames[kFrame];
        return dir / "series.nii";
    }
    case Input::Vcz16:
    case Input::Vcz32:
    case Input::Vcz64: {
        const std::size_t b = in == Input::Vcz16 ? 16 : in == Input::Vcz32 ? 32 : 64;
        o.brick = {b, b, b};
        const auto p = dir / ("phantom_b" + std::to_string(b) + ".vcz");
        writeVcz(p, encodeVolume(cc, v, o));
        return p;
    }
    case Input::VczSeriesFrame: {
        TimeSeries ts;
        for (std::size_t f = 0; f < kFrames; ++f)
            ts.frames.push_back(phantomFrame(f));
        o.brick = {32, 32, 32};
        o.motion = MotionMode::Block;
        std::vector<FrameReport> reports;
        writeVcz(dir / "series.vcz", encodeSeries(cc, ts, o, &reports));
        EXPECT_NE(reports.at(kFrame).type, FrameType::I) << "the series frame should be predicted";
        decoded = ts.frames[kFrame];
        return dir / "series.vcz";
    }
    case Input::VczLossyLodFull: {
        o.rate = RateMode::MaxError;
        o.target = 2.0;
        o.brick = {16, 16, 16};
        const auto p = dir / "phantom_lossy.vcz";
        const std::vector<std::byte> bytes = encodeVolume(cc, v, o);
        writeVcz(p, bytes);
        decoded = decodeVolume(cc, bytes);
        return p;
    }
    case Input::VczLowRate: {
        // The larger transform extent the encoder chooses for small smooth volumes (codec.md, "Transform
        // extent by content"): one 128-voxel brick of 4 levels at a low rate. (This phantom's detail is too
        // dense for set-partitioned sections; files with them decode to the same coefficients as dense-only
        // files, tests/test_speck.cpp.)
        o.rate = RateMode::MaxError;
        o.target = 8.0;
        o.brick = {128, 128, 128};
        o.levels = 4;
        const auto p = dir / "phantom_low_rate.vcz";
        const std::vector<std::byte> bytes = encodeVolume(cc, v, o);
        EXPECT_EQ(readVczHeader(bytes, "low rate").brickCount(), 1u);
        writeVcz(p, bytes);
        decoded = decodeVolume(cc, bytes);
        return p;
    }
    }
    return {};
}

/// The input as `volcl render --volume PATH [--frame K]` opens it: a .vcz from its bricks (RenderInput::openVcz,
/// as apps/cli/RenderCommands.cpp does), anything else through the CLI's own reader (SceneFlags::readSceneInput).
RenderInput openLikeCli(const std::filesystem::path& path, std::optional<std::size_t> frame) {
    if (path.extension() == ".vcz") return RenderInput::openVcz(path, frame.value_or(0));
    cli::SceneFlags flags;
    flags.frame = frame;
    Scene s;
    s.volume = path;
    std::vector<std::string> notes;
    return flags.readSceneInput(s, notes);
}

/// matrixTf() with a gradient opacity and two widgets (a box on the boundary band, a Gaussian): values and
/// gradients (data value per world unit) in the phantom's ranges.
TransferFunction matrixGradientTf() {
    TransferFunction tf = matrixTf();
    tf.gradientOpacity = {{0.0, 0.2}, {20.0, 1.0}};
    TfWidget box;
    box.valueRange = {60.0, 140.0};
    box.gradientRange = {8.0, 40.0};
    box.rgb = {0.2, 0.9, 0.3};
    box.tau = 0.4;
    TfWidget gauss;
    gauss.shape = TfWidgetShape::Gaussian;
    gauss.center = {180.0, 15.0};
    gauss.sigma = {20.0, 10.0};
    gauss.rgb = {0.9, 0.2, 0.6};
    gauss.tau = 0.3;
    tf.widgets = {box, gauss};
    return tf;
}

struct Combo {
    std::string name;
    Scene scene;
    bool gradientCache = false; ///< shaded from the gradient cache (grids and compressed bricks have one)
};

/// Every mode x shading x pre-integration the mode uses. MIP and x-ray neither shade nor pre-integrate,
/// iso mode composites surfaces only (no pre-integration): those axes are not varied there.
std::vector<Combo> combos(const WorldBox& box) {
    Scene base;
    Camera c = defaultCamera(box);
    const double dz = c.target[2] - c.eye[2];
    c.eye = {c.eye[0] + 0.6 * dz, c.eye[1] - 0.3 * dz, c.eye[2]}; // oblique: all three axes show
    c.height *= 1.3;
    base.camera = c;
    base.width = 48;
    base.height = 40;
    base.step = 0.6;
    base.tableSize = 64;
    base.tableLengths = 4;
    base.lod = LodMode::Full;
    const std::vector<IsoLayer> layers = {{90.0, {0.9, 0.6, 0.3, 0.5}}, {160.0, {0.3, 0.8, 0.9, 1.0}}};
    std::vector<Combo> out;
    auto add = [&](std::string name, RenderMode mode, bool shading, Preintegration pre, bool isoLayers,
                   GradientKind gradient = GradientKind::Central) {
        Scene s = base;
        s.mode = mode;
        s.preintegration = pre;
        s.effects.shading = shading;
        s.effects.shadingGiven = true;
        // Every renderer takes central differences; the gradient cache has combos of its own.
        s.effects.gradient = gradient;
        if (isoLayers) s.effects.isosurfaces = layers;
        applyLightingDefaults(s);
        out.push_back({std::move(name), std::move(s), gradient == GradientKind::Cache});
    };
    for (bool shading : {false, true}) {
        const std::string sh = shading ? " shaded" : "";
        for (Preintegration pre : {Preintegration::None, Preintegration::Table2d, Preintegration::Table3d}) {
            const std::string pn = " preint " + std::string(preintegrationName(pre));
            add("dvr" + sh + pn, RenderMode::Dvr, shading, pre, false);
            add("dvr+iso" + sh + pn, RenderMode::Dvr, shading, pre, true);
        }
        add("iso" + sh, RenderMode::Iso, shading, Preintegration::None, true);
    }
    // Shadows where they meet iso layers and 2D pre-integration: by secondary rays and from light volumes (every
    // input; a .vcz's light volume of one-voxel cells reads every brick at level 0, the decoded data).
    for (ShadowMethod m : {ShadowMethod::Rays, ShadowMethod::Volume}) {
        add(std::string("dvr+iso shaded shadows ") + (m == ShadowMethod::Rays ? "rays" : "volume"),
            RenderMode::Dvr, true, Preintegration::Table2d, true);
        out.back().scene.effects.shadows = true;
        out.back().scene.effects.shadowMethod = m;
        out.back().scene.effects.shadowStep = 0.6;
    }
    for (Preintegration pre : {Preintegration::None, Preintegration::Table2d, Preintegration::Table3d})
        add("dvr shaded, gradient cache, preint " + std::string(preintegrationName(pre)), RenderMode::Dvr,
            true, pre, false, GradientKind::Cache);
    // The MIP window is given: its default is the data's value range, which a lossy .vcz takes from its
    // index, i.e. from the data before coding (up to the error bound away from the decoded range).
    add("mip", RenderMode::Mip, false, Preintegration::None, false);
    out.back().scene.window = std::array<double, 2>{150.0, 140.0};
    add("xray", RenderMode::Xray, false, Preintegration::None, false);
    add("emission", RenderMode::Emission, false, Preintegration::None, false);
    // A crop box (world units, the middle of the box) with two more clip planes: the full eight planes, on
    // shaded 2D pre-integrated dvr with iso layers, and on emission.
    const Vec3 lo = box.origin, ext = box.extent;
    const CropBox crop{{lo[0] + 0.15 * ext[0], lo[1] + 0.2 * ext[1], lo[2] + 0.1 * ext[2]},
                       {lo[0] + 0.8 * ext[0], lo[1] + 0.85 * ext[1], lo[2] + 0.7 * ext[2]}};
    const Vec3 centre{lo[0] + 0.5 * ext[0], lo[1] + 0.5 * ext[1], lo[2] + 0.5 * ext[2]};
    const std::vector<ClipPlane> twoPlanes = {{{1, 1, 0}, -(centre[0] + centre[1]) + 0.3 * ext[0]},
                                              {{0, -1, 1}, centre[1] - centre[2] + 0.4 * ext[1]}};
    add("dvr+iso shaded preint 2d, crop box + 2 clip planes", RenderMode::Dvr, true, Preintegration::Table2d,
        true);
    out.back().scene.effects.cropBox = crop;
    out.back().scene.effects.clipPlanes = twoPlanes;
    add("emission, crop box + 2 clip planes", RenderMode::Emission, false, Preintegration::None, false);
    out.back().scene.effects.cropBox = crop;
    out.back().scene.effects.clipPlanes = twoPlanes;
    return out;
}

/// Largest difference per channel: equal values (infinite depths included) differ by 0, NaN by infinity.
std::vector<double> channelDiff(const ImageBuffer& a, const ImageBuffer& b) {
    std::vector<double> worst(a.channels.size(), 0.0);
    for (std::size_t i = 0; i < a.pixels.size() && i < b.pixels.size(); ++i) {
        const float x = a.pixels[i], y = b.pixels[i];
        const double d = x == y ? 0.0 : std::isnan(x) || std::isnan(y) ? INFINITY : double(std::abs(x - y));
        worst[i % worst.size()] = std::max(worst[i % worst.size()], d);
    }
    return worst;
}

double colourMax(const ImageBuffer& a) {
    double m = 0;
    for (std::size_t i = 0; i < a.pixels.size(); ++i)
        if (a.channels[i % a.channels.size()] != "Z") m = std::max(m, double(a.pixels[i]));
    return m;
}

class RenderMatrix : public ::testing::TestWithParam<Input> {};

// Float noise: every input renders the same float data through the same kernel source, so images agree to
// the last bit or close; 1e-6 in every channel (RGBA and the iso depth Z) is the bound.
/// What gradient TFs and labels draw in: point-sampled dvr without iso layers or shadows (the combos have no
/// scattering).
bool pointSampledDvr(const Scene& s) {
    return s.mode == RenderMode::Dvr && s.preintegration == Preintegration::None &&
           s.effects.isosurfaces.empty() && !s.effects.shadows;
}

/// Renders `scene` from `input` and with the grid renderer on `decoded` (never skipping); expects a scene that
/// shows something and the same image within 1e-6 per channel. Returns the input renderer's plan.
EffectPlan expectEqualsGridOracle(ComputeContext& cc, const RenderInput& input, const Volume& decoded,
                                  const TransferFunction& tf, const Scene& scene) {
    Scene oracle = scene;
    oracle.skipping = SkipMode::Off;
    const ImageBuffer want = GridRenderer(cc, decoded, tf, oracle).render();
    const std::unique_ptr<VolumeRenderer> r = input.makeRenderer(cc, tf, scene);
    const ImageBuffer got = r->render();
    EXPECT_GT(colourMax(want), 0.05) << "the scene shows something";
    const std::vector<double> d = channelDiff(want, got);
    for (std::size_t ch = 0; ch < d.size(); ++ch)
        EXPECT_LE(d[ch], 1e-6) << "channel " << want.channels[ch];
    return r->plan();
}

TEST_P(RenderMatrix, EqualsTheGridRenderOfTheDecodedData) {
    const Input in = GetParam();
    ComputeContext& cc = computeContext();
    const auto dir = test::tempDir("render_matrix_" + inputName(in));
    Volume decoded;
    const std::filesystem::path path = writeInput(in, dir, decoded);
    const bool series = in == Input::Nifti4dFrame || in == Input::VczSeriesFrame;
    const RenderInput input = openLikeCli(path, series ? std::optional<std::size_t>(kFrame) : std::nullopt);
    EXPECT_EQ(input.kind(), path.extension() == ".vcz" ? RenderInput::Kind::Bricks : RenderInput::Kind::Grid);
    // The opened data is the decoded data: same grid, voxels and geometry. The geometry is compared to
    // 1e-6 and then taken from the file: NIfTI stores spacing and origin as float32, and the oracle draws
    // the grid the file describes.
    std::array<double, 3> spacing{}, origin{};
    if (const Volume* g = input.grid()) {
        EXPECT_EQ(g->dims(), decoded.dims());
        EXPECT_EQ(g->toFloat(), decoded.toFloat()) << "voxels";
        spacing = g->spacing;
        origin = g->origin;
    } else {
        const Volume whole = input.bricks()->decodeFrame(cc, input.frame());
        EXPECT_EQ(whole.dims(), decoded.dims());
        EXPECT_EQ(whole.toFloat(), decoded.toFloat()) << "the decoder's voxels";
        spacing = input.bricks()->header().spacing;
        origin = input.bricks()->header().origin;
    }
    for (std::size_t a = 0; a < 3; ++a) {
        EXPECT_NEAR(spacing[a], decoded.spacing[a], 1e-6) << "spacing, axis " << a;
        EXPECT_NEAR(origin[a], decoded.origin[a], 1e-6) << "origin, axis " << a;
    }
    decoded.spacing = spacing;
    decoded.origin = origin;
    const WorldBox box = input.bounds();
    const TransferFunction tf = matrixTf();
    // The oracle of cached shading on bricks (below); a renderer borrows its volume, so it lives here.
    const Volume decodedAsFloat = test::asFloat32(decoded);
    for (const Combo& c : combos(box)) {
        SCOPED_TRACE(inputName(in) + ", " + c.name);
        // The oracle never skips; the inputs skip as the default says (grids: auto, measured per TF; bricks:
        // on), so skipping meets every mode, effect and input here.
        Scene oracle = c.scene;
        oracle.skipping = SkipMode::Off;
        // A brick pool holds float samples, whose gradient cache is octahedral: so is the oracle's for bricks
        // (a grid input of integers spanning at most 511 takes the exact form, as its oracle does).
        GridRenderer grid(cc, c.gradientCache && input.bricks() ? decodedAsFloat : decoded, tf, oracle);
        const ImageBuffer want = grid.render();
        const std::unique_ptr<VolumeRenderer> r = input.makeRenderer(cc, tf, c.scene);
        const ImageBuffer got = r->render();
        EXPECT_GT(colourMax(want), 0.05) << "the scene shows something";
        ASSERT_EQ(got.channels, want.channels);
        if (c.gradientCache) EXPECT_NE(r->plan().gradientCache, 0) << r->plan().explain();
        if (c.gradientCache && (in == Input::VczLossyLodFull || in == Input::VczLowRate)) {
            // A lossy .vcz scales its cache words by the value ranges in its index (the data before coding), the
            // grid by the decoded voxels': the words differ by their quantisation, and the coding noise's tiny
            // gradients fall below the smallest code (unlit) on one side and not the other in a few pixels.
            const double e = imageRmse(want, got);
            std::cout << c.name << ": RMSE " << e << " against the grid cache of the decoded data\n";
            EXPECT_LT(e, 5e-3);
            continue;
        }
        const std::vector<double> d = channelDiff(want, got);
        for (std::size_t ch = 0; ch < d.size(); ++ch)
            EXPECT_LE(d[ch], 1e-6) << "channel " << want.channels[ch];
    }
    // A gradient TF (widgets and gradient opacity) on every input: grids and bricks draw it with central
    // differences of the same samples; the combinations it refuses are refused by every input.
    const TransferFunction tf2d = matrixGradientTf();
    for (const Combo& c : combos(box)) {
        SCOPED_TRACE(inputName(in) + ", gradient TF, " + c.name);
        if (!pointSampledDvr(c.scene)) {
            EXPECT_THROW(input.makeRenderer(cc, tf2d, c.scene), UsageError);
            continue;
        }
        EXPECT_EQ(expectEqualsGridOracle(cc, input, decoded, tf2d, c.scene).gradientCache, 0);
    }
    // A label map (a threshold of the data: 1 above 100, 2 above 170, on the data's grid) in replace mode: grids
    // draw it as the grid renderer draws the decoded data, in dvr with point sampling, shaded or not, cropped
    // and clipped; what labels refuse (other modes, pre-integration, iso layers, shadows) and compressed bricks
    // (no label kernel) are refused in one line.
    Volume labelVolume(decoded.dims(), ScalarType::UInt8);
    labelVolume.spacing = decoded.spacing;
    labelVolume.origin = decoded.origin;
    labelVolume.direction = decoded.direction;
    {
        const std::vector<float> values = decoded.toFloat();
        auto l = labelVolume.values<std::uint8_t>();
        for (std::size_t i = 0; i < values.size(); ++i)
            l[i] = values[i] > 170.0f ? 2 : values[i] > 100.0f ? 1 : 0;
    }
    LabelLayer layer;
    layer.file = dir / "labels.nrrd";
    writeVolumeFile(labelVolume, layer.file);
    std::vector<Combo> labelCombos = combos(box);
    labelCombos.push_back(labelCombos.front());
    labelCombos.back().name = "dvr, crop box + 2 clip planes";
    labelCombos.back().scene.effects.cropBox = labelCombos[labelCombos.size() - 2].scene.effects.cropBox;
    labelCombos.back().scene.effects.clipPlanes =
        labelCombos[labelCombos.size() - 2].scene.effects.clipPlanes;
    for (Combo c : labelCombos) {
        SCOPED_TRACE(inputName(in) + ", labels, " + c.name);
        c.scene.labels = layer;
        if (!pointSampledDvr(c.scene) || input.kind() != RenderInput::Kind::Grid) {
            EXPECT_THROW(input.makeRenderer(cc, tf, c.scene), UsageError);
            continue;
        }
        EXPECT_TRUE(expectEqualsGridOracle(cc, input, decoded, tf, c.scene).labels);
    }
    // The preview tiers (render.method) on every input kind: grids draw as the tier draws the decoded data;
    // compressed bricks refuse them with one line (decode first).
    for (GridMethod m : {GridMethod::ShearWarp, GridMethod::Drc}) {
        SCOPED_TRACE(inputName(in) + ", " + std::string(gridMethodName(m)));
        Scene s = combos(box).front().scene; // unshaded point-sampled dvr, oblique camera
        s.gridMethod = m;
        if (input.kind() != RenderInput::Kind::Grid) {
            EXPECT_THROW(input.makeRenderer(cc, tf, s), UsageError);
            continue;
        }
        const ImageBuffer want = GridPreviewRenderer(cc, decoded, tf, s).render();
        const ImageBuffer got = input.makeRenderer(cc, tf, s)->render();
        EXPECT_GT(colourMax(want), 0.05) << "the scene shows something";
        const std::vector<double> d = channelDiff(want, got);
        for (std::size_t ch = 0; ch < d.size(); ++ch)
            EXPECT_LE(d[ch], 1e-6) << "channel " << want.channels[ch];
    }
}

INSTANTIATE_TEST_SUITE_P(Inputs, RenderMatrix,
                         ::testing::Values(Input::Raw, Input::Nrrd, Input::Nifti, Input::Nifti4dFrame,
                                           Input::Vdb, Input::DicomFolder, Input::Vcz16, Input::Vcz32,
                                           Input::Vcz64, Input::VczSeriesFrame, Input::VczLossyLodFull,
                                           Input::VczLowRate),
                         [](const ::testing::TestParamInfo<Input>& i) { return inputName(i.param); });

// What the compressed-brick renderer does not draw, by design: cubic filters and smoothing need the whole
// grid and are refused with a one-line message naming the file; the two table paths built from a whole
// volume (pre-integrated lighting, the iso-surface table) are dropped with a note, the image then being the
// per-sample one.
TEST(RenderMatrixRefusals, CompressedBricksRefuseWholeGridFiltersAndDropWholeVolumeTables) {
    ComputeContext& cc = computeContext();
    const auto dir = test::tempDir("render_matrix_refusals");
    Volume decoded;
    const std::filesystem::path path = writeInput(Input::Vcz32, dir, decoded);
    const RenderInput input = openLikeCli(path, std::nullopt);
    const TransferFunction tf = matrixTf();
    const Scene base = combos(input.bounds()).front().scene;
    for (ReconstructionFilter f : {ReconstructionFilter::Cubic, ReconstructionFilter::Bspline}) {
        Scene s = base;
        s.filter = f;
        try {
            (void)input.makeRenderer(cc, tf, s);
            ADD_FAILURE() << filterName(f) << " filter accepted";
        } catch (const UsageError& e) {
            EXPECT_NE(std::string(e.what()).find(path.string()), std::string::npos) << e.what();
            EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
        }
    }
    Scene smooth = base;
    smooth.smoothing = 1.0;
    EXPECT_THROW((void)input.makeRenderer(cc, tf, smooth), UsageError);

    Scene lit = base;
    lit.preintegration = Preintegration::Table2d;
    lit.effects.shading = lit.effects.shadingGiven = lit.effects.shadingPreintegrated = true;
    applyLightingDefaults(lit);
    Scene table = base;
    table.mode = RenderMode::Iso;
    table.effects.isosurfaces = {{120.0, {1, 1, 1, 1}}};
    table.effects.isoTable = true;
    for (const Scene& s : {lit, table}) {
        const std::unique_ptr<VolumeRenderer> r = input.makeRenderer(cc, tf, s);
        EXPECT_FALSE(r->plan().preintLighting);
        EXPECT_FALSE(r->plan().isoTable);
        const std::vector<std::string>& dropped = r->plan().dropped;
        EXPECT_TRUE(std::any_of(dropped.begin(), dropped.end(), [](const std::string& d) {
            return d.find("compressed bricks") != std::string::npos;
        })) << "no note says why the table path was dropped";
        // The image is the per-sample path's: the grid renderer with the table option off.
        Scene plain = s;
        plain.effects.shadingPreintegrated = plain.effects.isoTable = false;
        GridRenderer grid(cc, decoded, tf, plain);
        const std::vector<double> d = channelDiff(grid.render(), r->render());
        for (double x : d)
            EXPECT_LE(x, 1e-6);
    }
}

// Multi-channel volumes where they meet the other features: every format that stores components (NRRD vector
// and RGB-color axes, NIfTI dim[5], .vti components; written, then read back as `volcl render` reads a
// "channels" scene) x every blend x clip plane and crop box, against the channel renderer on the same data
// held in memory; one additive channel against the plain grid renderer (the same emission-absorption sum,
// arranged apart). Effects the channel renderer does not draw are refused in one line (test_channels.cpp).
TEST(RenderMatrixChannels, EveryChannelFormatBlendAndCutEqualsTheInMemoryRender) {
    ComputeContext& cc = computeContext();
    const auto dir = test::tempDir("render_matrix_channels");
    ChannelVolume mem;
    for (std::size_t c = 0; c < 4; ++c)
        mem.channels.push_back(phantomFrame(c));
    mem.color = true;
    const WorldBox box = gridBounds(mem.channels[0]);
    Scene base = combos(box).front().scene;
    base.earlyTermination = 1.0;
    Scene clipped = base;
    clipped.effects.clipPlanes = {ClipPlane{{1, 0.2, 0}, -(box.origin[0] + 0.45 * box.extent[0])}};
    Scene cropped = base;
    CropBox crop;
    crop.lo = {box.origin[0], box.origin[1] + 0.2 * box.extent[1], box.origin[2]};
    crop.hi = {box.origin[0] + box.extent[0], box.origin[1] + 0.8 * box.extent[1],
               box.origin[2] + 0.6 * box.extent[2]};
    cropped.effects.cropBox = crop;
    ChannelStyle additive;
    for (std::size_t c = 0; c < 4; ++c) {
        ChannelLayer l{matrixTf(), c != 2}; // one hidden channel
        additive.layers.push_back(l);
    }
    ChannelStyle maximum = additive;
    maximum.blend = ChannelBlend::Maximum;
    ChannelStyle direct;
    direct.blend = ChannelBlend::DirectColor;
    TransferFunction opacity;
    opacity.domain = {0, 1};
    opacity.color = {{0, {1, 1, 1}}, {1, {1, 1, 1}}};
    opacity.extinction = {{0, 0.0}, {1, 0.4}};
    direct.layers.push_back({opacity, true});
    for (const char* name : {"c.nrrd", "c.nii.gz", "c.vti"}) {
        writeChannelsFile(mem, dir / name);
        for (const ChannelStyle* style : {&additive, &maximum, &direct})
            for (const Scene* cut : {&base, &clipped, &cropped}) {
                SCOPED_TRACE(std::string(name) + " " + std::string(channelBlendName(style->blend)));
                Scene s = *cut;
                s.volume = dir / name;
                s.mode = style->blend == ChannelBlend::Maximum ? RenderMode::Mip : RenderMode::Dvr;
                const ChannelVolume read = readSceneChannels(s, {});
                const ImageBuffer fromFile = ChannelRenderer(cc, read, *style, s).render();
                // In memory on the geometry the file stores (NIfTI keeps it as float32), checked close to the
                // generated one.
                ChannelVolume here = mem;
                for (Volume& v : here.channels) {
                    for (int a = 0; a < 3; ++a) {
                        EXPECT_NEAR(read.channels[0].spacing[a], v.spacing[a], 1e-6);
                        EXPECT_NEAR(read.channels[0].origin[a], v.origin[a], 1e-5);
                    }
                    v.spacing = read.channels[0].spacing;
                    v.origin = read.channels[0].origin;
                    v.direction = read.channels[0].direction;
                }
                const ImageBuffer inMemory = ChannelRenderer(cc, here, *style, s).render();
                for (double x : channelDiff(fromFile, inMemory))
                    EXPECT_LE(x, 1e-6);
            }
    }
    // One channel, additive: the plain grid renderer's point-sampled dvr, no early termination.
    ChannelVolume one;
    one.channels.push_back(mem.channels[1]);
    ChannelStyle single;
    single.layers.push_back({matrixTf(), true});
    for (const Scene* cut : {&base, &clipped, &cropped}) {
        Scene s = *cut;
        s.skipping = SkipMode::Off;
        GridRenderer grid(cc, one.channels[0], matrixTf(), s);
        const ImageBuffer g = grid.render();
        const ImageBuffer c = ChannelRenderer(cc, one, single, s).render();
        for (int ch = 0; ch < 4; ++ch)
            EXPECT_LE(channelDiff(g, c)[std::size_t(ch)], 2e-5) << "channel " << ch;
    }
}

} // namespace
} // namespace volcl
