// Orientation: NIfTI sform/qform, NRRD space directions and MetaImage direction cosines read as RAS index
// directions (closed-form affines), and `volcl render` framing oriented copies of one anatomy alike.
#include "TestUtil.hpp"
#include "host/image/ImageIo.hpp"
#include "host/io/NiftiMetadata.hpp"
#include "host/io/VolumeIo.hpp"

#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <numbers>
#include <sstream>

using namespace volcl;
namespace fs = std::filesystem;

namespace {

using Matrix = std::array<std::array<double, 3>, 3>; // [row][column]

/// A float32 NIfTI-1 file written byte by byte (not through volcl's writer): `affine` is both the sform
/// (code sformCode) and, when qformCode > 0, the qform given by quaternion (b, c, d) and qfac.
struct NiftiSpec {
    Dims dims;
    std::array<double, 3> pixdim{1, 1, 1};
    std::array<std::array<double, 4>, 3> srow{};
    short sformCode = 0, qformCode = 0;
    std::array<float, 3> quatern{0, 0, 0}, qoffset{0, 0, 0};
    float qfac = 1;
};

void writeNiftiBytes(const fs::path& p, const NiftiSpec& s, std::span<const std::byte> voxels, short datatype,
                     short bitpix) {
    std::string h(352, '\0');
    auto put = [&](std::size_t off, const auto& v) { std::memcpy(h.data() + off, &v, sizeof(v)); };
    put(0, std::int32_t{348});
    const short dim[8] = {3, short(s.dims.x), short(s.dims.y), short(s.dims.z), 1, 1, 1, 1};
    for (int i = 0; i < 8; ++i)
        put(40 + 2 * i, dim[i]);
    put(70, datatype);
    put(72, bitpix);
    const float pixdim[8] = {s.qfac, float(s.pixdim[0]), float(s.pixdim[1]), float(s.pixdim[2]), 1, 0, 0, 0};
    for (int i = 0; i < 8; ++i)
        put(76 + 4 * i, pixdim[i]);
    put(108, 352.0f);
    h[123] = 2; // mm
    put(252, s.qformCode);
    put(254, s.sformCode);
    for (int i = 0; i < 3; ++i) {
        put(256 + 4 * i, s.quatern[std::size_t(i)]);
        put(268 + 4 * i, s.qoffset[std::size_t(i)]);
        for (int j = 0; j < 4; ++j)
            put(280 + 16 * i + 4 * j, float(s.srow[std::size_t(i)][std::size_t(j)]));
    }
    std::memcpy(h.data() + 344, "n+1\0", 4);
    std::ofstream out(p, std::ios::binary);
    out << h;
    out.write(reinterpret_cast<const char*>(voxels.data()), std::streamsize(voxels.size()));
}

void writeNifti(const fs::path& p, const NiftiSpec& s, const std::vector<float>& voxels) {
    writeNiftiBytes(p, s, std::as_bytes(std::span(voxels)), 16, 32);
}

void expectDirection(const Volume& v, const Matrix& expected) {
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
            EXPECT_NEAR(v.direction[std::size_t(3 * r + c)], expected[std::size_t(r)][std::size_t(c)], 1e-6)
                << "row " << r << " column " << c;
}

constexpr Matrix kIdentity{{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};

std::vector<float> zeros(Dims d) {
    return std::vector<float>(d.count(), 0.0f);
}

} // namespace

TEST(Orientation, NiftiSformIsPreferredOverTheQform) {
    const fs::path dir = test::tempDir("orient-nifti-sform");
    NiftiSpec s;
    s.dims = {3, 4, 5};
    s.pixdim = {2, 3, 4};
    // sform: LPS-stored axes (i toward the patient's left, j posterior); qform: identity (must lose).
    s.srow = {{{-2, 0, 0, 10}, {0, -3, 0, 20}, {0, 0, 4, -5}}};
    s.sformCode = 2;
    s.qformCode = 1;
    writeNifti(dir / "a.nii", s, zeros(s.dims));
    const Volume v = readVolumeFile(dir / "a.nii").frames.at(0);
    expectDirection(v, {{{-1, 0, 0}, {0, -1, 0}, {0, 0, 1}}});
    EXPECT_TRUE(v.anatomical);
    EXPECT_EQ(v.spacing, (std::array<double, 3>{2, 3, 4}));

    // An oblique sform: 30 degrees about z, scaled by the spacing per column.
    const double c = std::cos(std::numbers::pi / 6), sn = std::sin(std::numbers::pi / 6);
    s.srow = {{{2 * c, -3 * sn, 0, 0}, {2 * sn, 3 * c, 0, 0}, {0, 0, 4, 0}}};
    writeNifti(dir / "b.nii", s, zeros(s.dims));
    expectDirection(readVolumeFile(dir / "b.nii").frames.at(0), {{{c, -sn, 0}, {sn, c, 0}, {0, 0, 1}}});
}

TEST(Orientation, NiftiQformQuaternionAndQfac) {
    const fs::path dir = test::tempDir("orient-nifti-qform");
    NiftiSpec s;
    s.dims = {3, 4, 5};
    s.qformCode = 1;
    // 90 degrees about z: (b, c, d) = (0, 0, sin 45); R = [[0,-1,0],[1,0,0],[0,0,1]]; qfac -1 negates k.
    s.quatern = {0, 0, float(std::sqrt(0.5))};
    s.qfac = -1;
    writeNifti(dir / "q.nii", s, zeros(s.dims));
    const Volume v = readVolumeFile(dir / "q.nii").frames.at(0);
    expectDirection(v, {{{0, -1, 0}, {1, 0, 0}, {0, 0, -1}}});
    EXPECT_LT(determinant(v.direction), 0.0);

    // Neither code: identity (the Analyze-style default), still a NIfTI (patient axes).
    s.qformCode = 0;
    writeNifti(dir / "n.nii", s, zeros(s.dims));
    expectDirection(readVolumeFile(dir / "n.nii").frames.at(0), kIdentity);
}

TEST(Orientation, NrrdSpaceDirectionsInLpsAndRas) {
    const fs::path dir = test::tempDir("orient-nrrd");
    const std::string data(3 * 4 * 5, '\0');
    auto nrrd = [&](const std::string& name, const std::string& fields) {
        test::writeFile(dir / name, "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 3 4 5\nencoding: raw\n" +
                                        fields + "\n\n" + data);
        return readVolumeFile(dir / name).frames.at(0);
    };
    // LPS y points posterior, so axis 0 = (0,-2,0) runs anterior.
    const Volume lps = nrrd("lps.nrrd", "space: left-posterior-superior\nspace directions: (0,-2,0) (3,0,0) "
                                        "(0,0,4)\nspace origin: (1,2,3)");
    // In RAS: i = LPS (0,-1,0) = anterior = RAS (0,1,0); j = LPS (1,0,0) = left = RAS (-1,0,0).
    expectDirection(lps, {{{0, -1, 0}, {1, 0, 0}, {0, 0, 1}}});
    EXPECT_TRUE(lps.anatomical);
    EXPECT_EQ(lps.spacing, (std::array<double, 3>{2, 3, 4}));
    const Volume ras = nrrd("ras.nrrd", "space: RAS\nspace directions: (0,-2,0) (3,0,0) (0,0,4)");
    expectDirection(ras, {{{0, 1, 0}, {-1, 0, 0}, {0, 0, 1}}});
    // Not a patient space: the directions as given, not anatomical.
    const Volume scanner = nrrd("xyz.nrrd", "space: scanner-xyz\nspace directions: (0,-2,0) (3,0,0) (0,0,4)");
    expectDirection(scanner, {{{0, 1, 0}, {-1, 0, 0}, {0, 0, 1}}});
    EXPECT_FALSE(scanner.anatomical);
    // LPS with spacings only: the LPS axes in RAS.
    const Volume spacings = nrrd("s.nrrd", "space: LPS\nspacings: 1 1 1");
    expectDirection(spacings, {{{-1, 0, 0}, {0, -1, 0}, {0, 0, 1}}});
    const Volume plain = nrrd("p.nrrd", "spacings: 1 1 1");
    expectDirection(plain, kIdentity);
    EXPECT_FALSE(plain.anatomical);
}

TEST(Orientation, MetaImageTransformMatrixAndAnatomicalOrientation) {
    const fs::path dir = test::tempDir("orient-mha");
    const std::string data(3 * 4 * 5, '\0');
    auto mha = [&](const std::string& name, const std::string& fields) {
        test::writeFile(dir / name,
                        "ObjectType = Image\nNDims = 3\n" + fields +
                            "DimSize = 3 4 5\nElementType = MET_UCHAR\nElementDataFile = LOCAL\n" + data);
        return readVolumeFile(dir / name).frames.at(0);
    };
    // ITK: each triple is one index axis's LPS direction. Axis 0 = LPS (0,1,0) (posterior) = RAS (0,-1,0).
    const Volume m = mha("m.mha", "TransformMatrix = 0 1 0 -1 0 0 0 0 1\n");
    expectDirection(m, {{{0, 1, 0}, {-1, 0, 0}, {0, 0, 1}}});
    EXPECT_TRUE(m.anatomical);
    // The identity matrix is LPS: RAS diag(-1, -1, 1).
    expectDirection(mha("i.mha", "TransformMatrix = 1 0 0 0 1 0 0 0 1\n"),
                    {{{-1, 0, 0}, {0, -1, 0}, {0, 0, 1}}});
    // AnatomicalOrientation names the side each axis comes from: RAI is ITK's identity, i.e. LPS.
    expectDirection(mha("r.mha", "AnatomicalOrientation = RAI\n"), {{{-1, 0, 0}, {0, -1, 0}, {0, 0, 1}}});
    expectDirection(mha("l.mha", "AnatomicalOrientation = LPI\n"), kIdentity);
    const Volume none = mha("n.mha", "");
    expectDirection(none, kIdentity);
    EXPECT_FALSE(none.anatomical);
}

TEST(Orientation, WritersKeepTheDirection) {
    // An LPS NRRD whose axes are permuted and flipped, written as NRRD, NIfTI and .vti and read back: the
    // same RAS direction and origin (NRRD and NIfTI stay anatomical; .vti has no patient frame).
    const fs::path dir = test::tempDir("orient-writers");
    const std::string data(3 * 4 * 5, '\x07');
    test::writeFile(dir / "src.nrrd", "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 3 4 5\nencoding: raw\n"
                                      "space: LPS\nspace directions: (0,-2,0) (0,0,3) (-4,0,0)\n"
                                      "space origin: (1,2,3)\n\n" +
                                          data);
    const Volume src = readVolumeFile(dir / "src.nrrd").frames.at(0);
    const Matrix expected{{{0, 0, 1}, {1, 0, 0}, {0, 1, 0}}}; // i anterior, j superior, k right
    expectDirection(src, expected);
    EXPECT_EQ(src.origin, (std::array<double, 3>{-1, -2, 3}));
    for (const char* name : {"out.nrrd", "out.nii", "out.vti"}) {
        SCOPED_TRACE(name);
        writeVolumeFile(src, dir / name);
        const Volume back = readVolumeFile(dir / name).frames.at(0);
        expectDirection(back, expected);
        for (int a = 0; a < 3; ++a) {
            EXPECT_NEAR(back.origin[std::size_t(a)], src.origin[std::size_t(a)], 1e-6) << name;
            EXPECT_NEAR(back.spacing[std::size_t(a)], src.spacing[std::size_t(a)], 1e-6) << name;
        }
        EXPECT_EQ(back.anatomical, std::string(name) != "out.vti") << name;
    }
    // A mirroring direction survives NIfTI's qform too (qfac -1), not only the sform.
    test::writeFile(dir / "las.nrrd", "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 3 4 5\nencoding: raw\n"
                                      "space: RAS\nspace directions: (-1,0,0) (0,1,0) (0,0,1)\n\n" +
                                          data);
    writeVolumeFile(readVolumeFile(dir / "las.nrrd").frames.at(0), dir / "las.nii");
    NiftiMetadata m = readNiftiMetadata(dir / "las.nii");
    m.sformCode = 0; // the qform alone
    EXPECT_EQ(m.qfac, -1.0f);
    const Direction3 q = niftiDirection(m);
    const Direction3 las{-1, 0, 0, 0, 1, 0, 0, 0, 1};
    for (std::size_t i = 0; i < 9; ++i)
        EXPECT_NEAR(q[i], las[i], 1e-6) << i;
}

namespace {

struct RunResult {
    int exitCode;
    std::string err;
};

RunResult run(const std::string& args, const fs::path& dir) {
    const fs::path err = dir / "stderr.txt";
    const std::string cmd =
        std::string(VOLCL_EXE) + " " + args + " >/dev/null 2>" + err.string() + " </dev/null";
    const int status = std::system(cmd.c_str());
    return {WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status), test::readFile(err)};
}

/// The anatomy every copy stores: blobs at distinct patient sides, in RAS millimetres inside the box
/// [0,19] x [0,28.75] x [0,22.5] (the RAS copy's grid): a "nose" anterior, an "ear" on the patient's
/// right, a "crown" on top and a faint core, so front, back, top and a mirror image all differ.
double anatomy(double x, double y, double z) {
    auto blob = [](double dx, double dy, double dz, double sigma) {
        return std::exp(-(dx * dx + dy * dy + dz * dz) / (2 * sigma * sigma));
    };
    return 0.3 * blob(x - 9.5, y - 14, z - 11, 5) + blob(x - 8, y - 23, z - 13, 2.5) +
           0.8 * blob(x - 15, y - 12, z - 9, 2.5) + 0.9 * blob(x - 6, y - 10, z - 18, 2.5);
}

constexpr Dims kRasDims{20, 24, 16};
constexpr std::array<double, 3> kRasSpacing{1.0, 1.25, 1.5};

/// One stored copy of the anatomy: index axis c runs along RAS axis perm[c] with sign sign[c].
struct Layout {
    std::array<int, 3> perm{0, 1, 2};
    std::array<int, 3> sign{1, 1, 1};
};

struct Stored {
    Dims dims;
    std::array<double, 3> spacing{}, origin{}; ///< origin: RAS position of voxel 0
    Matrix direction{};                        ///< [RAS row][index axis]
    std::vector<float> voxels;
};

Stored store(const Layout& l) {
    Stored s;
    const std::size_t n[3] = {kRasDims.x, kRasDims.y, kRasDims.z};
    std::size_t d[3];
    for (int c = 0; c < 3; ++c) {
        const int a = l.perm[std::size_t(c)];
        d[c] = n[a];
        s.spacing[std::size_t(c)] = kRasSpacing[std::size_t(a)];
        s.direction[std::size_t(a)][std::size_t(c)] = l.sign[std::size_t(c)];
        // A reversed axis starts at the far side, so every copy covers the same box.
        if (l.sign[std::size_t(c)] < 0)
            s.origin[std::size_t(a)] = double(n[a] - 1) * kRasSpacing[std::size_t(a)];
    }
    s.dims = {d[0], d[1], d[2]};
    for (std::size_t k = 0; k < d[2]; ++k)
        for (std::size_t j = 0; j < d[1]; ++j)
            for (std::size_t i = 0; i < d[0]; ++i) {
                const double idx[3] = {double(i), double(j), double(k)};
                std::array<double, 3> w = s.origin;
                for (int r = 0; r < 3; ++r)
                    for (int c = 0; c < 3; ++c)
                        w[std::size_t(r)] +=
                            s.direction[std::size_t(r)][std::size_t(c)] * s.spacing[std::size_t(c)] * idx[c];
                s.voxels.push_back(float(anatomy(w[0], w[1], w[2])));
            }
    return s;
}

fs::path writeNiftiCopy(const fs::path& p, const Stored& s) {
    NiftiSpec spec;
    spec.dims = s.dims;
    spec.pixdim = s.spacing;
    spec.sformCode = 1;
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c)
            spec.srow[std::size_t(r)][std::size_t(c)] =
                s.direction[std::size_t(r)][std::size_t(c)] * s.spacing[std::size_t(c)];
        spec.srow[std::size_t(r)][3] = s.origin[std::size_t(r)];
    }
    writeNifti(p, spec, s.voxels);
    return p;
}

std::string joined(const std::array<double, 3>& v, const char* sep) {
    std::ostringstream o;
    o << v[0] << sep << v[1] << sep << v[2];
    return o.str();
}

/// The copy as an NRRD in LPS space (directions and origin with x and y negated).
fs::path writeNrrdLps(const fs::path& p, const Stored& s) {
    std::ostringstream h;
    h << "NRRD0004\ntype: float\ndimension: 3\nsizes: " << s.dims.x << " " << s.dims.y << " " << s.dims.z
      << "\nendian: little\nencoding: raw\nspace: left-posterior-superior\nspace directions:";
    for (int c = 0; c < 3; ++c) {
        std::array<double, 3> v{};
        for (int r = 0; r < 3; ++r)
            v[std::size_t(r)] =
                (r < 2 ? -1 : 1) * s.direction[std::size_t(r)][std::size_t(c)] * s.spacing[std::size_t(c)];
        h << " (" << joined(v, ",") << ")";
    }
    h << "\nspace origin: (" << -s.origin[0] << "," << -s.origin[1] << "," << s.origin[2] << ")\n\n";
    std::ofstream out(p, std::ios::binary);
    out << h.str();
    out.write(reinterpret_cast<const char*>(s.voxels.data()),
              std::streamsize(s.voxels.size() * sizeof(float)));
    return p;
}

/// The copy as a MetaImage: ITK's LPS TransformMatrix (one index axis's direction per triple) and Offset.
fs::path writeMetaImageLps(const fs::path& p, const Stored& s) {
    std::ostringstream h;
    h << "ObjectType = Image\nNDims = 3\nTransformMatrix =";
    for (int c = 0; c < 3; ++c)
        for (int r = 0; r < 3; ++r)
            h << " " << (r < 2 ? -1 : 1) * s.direction[std::size_t(r)][std::size_t(c)];
    h << "\nOffset = " << -s.origin[0] << " " << -s.origin[1] << " " << s.origin[2]
      << "\nElementSpacing = " << joined(s.spacing, " ") << "\nDimSize = " << s.dims.x << " " << s.dims.y
      << " " << s.dims.z
      << "\nElementType = MET_FLOAT\nElementByteOrderMSB = False\nElementDataFile = LOCAL\n";
    std::ofstream out(p, std::ios::binary);
    out << h.str();
    out.write(reinterpret_cast<const char*>(s.voxels.data()),
              std::streamsize(s.voxels.size() * sizeof(float)));
    return p;
}

const char* kTf =
    R"({"domain": [0, 1], "color": [[0, 1, 1, 1], [1, 1, 1, 1]], "extinction": [[0, 0], [1, 0.6]]})";

/// Renders `volume` (64x64 EXR, a fixed TF, step and unit distance) with `camera` flags.
ImageBuffer renderCopy(const fs::path& volume, const std::string& camera, const fs::path& dir) {
    test::writeFile(dir / "tf.json", kTf);
    const fs::path out = dir / (volume.stem().string() + "_" +
                                std::to_string(std::hash<std::string>{}(camera) % 100000) + ".exr");
    const RunResult r =
        run("render --volume " + volume.string() + " --tf " + (dir / "tf.json").string() +
                " --tf-unit-distance 1 --step 0.25 --width 64 --height 64 " + camera + " -o " + out.string(),
            dir);
    EXPECT_EQ(r.exitCode, 0) << r.err;
    return readImage(out);
}

/// RMSE of `image` against `reference` over RGBA, printed with `what` (the figures a report quotes).
double rmseNoted(const ImageBuffer& image, const ImageBuffer& reference, const std::string& what);

double rmse(const ImageBuffer& a, const ImageBuffer& b) {
    EXPECT_EQ(a.width, b.width);
    EXPECT_EQ(a.height, b.height);
    double sum = 0;
    std::size_t n = 0;
    for (int y = 0; y < a.height; ++y)
        for (int x = 0; x < a.width; ++x)
            for (int c = 0; c < 4; ++c, ++n) {
                const double d = a.at(x, y, c) - b.at(x, y, c);
                sum += d * d;
            }
    return std::sqrt(sum / double(std::max<std::size_t>(n, 1)));
}

double rmseNoted(const ImageBuffer& image, const ImageBuffer& reference, const std::string& what) {
    const double e = rmse(image, reference);
    std::printf("orientation: %-40s RMSE %.3g\n", what.c_str(), e);
    return e;
}

} // namespace

TEST(OrientationRender, LpsAsrAndLasNiftiCopiesRenderLikeTheRasOriginal) {
    const fs::path dir = test::tempDir("orient-render-nifti");
    const fs::path ras = writeNiftiCopy(dir / "ras.nii", store({}));
    const fs::path lps = writeNiftiCopy(dir / "lps.nii", store({{0, 1, 2}, {-1, -1, 1}}));
    // ASR: i runs anterior (RAS y), j superior (z), k right (x).
    const fs::path asr = writeNiftiCopy(dir / "asr.nii", store({{1, 2, 0}, {1, 1, 1}}));
    // LAS mirrors (determinant -1): the camera in its index frame must mirror the image back.
    const fs::path las = writeNiftiCopy(dir / "las.nii", store({{0, 1, 2}, {-1, 1, 1}}));
    for (const std::string view : {"front", "top", "iso"}) {
        const ImageBuffer reference = renderCopy(ras, "--view " + view, dir);
        for (const fs::path& copy : {lps, asr, las})
            EXPECT_LE(rmseNoted(renderCopy(copy, "--view " + view, dir), reference,
                                copy.filename().string() + " --view " + view),
                      2e-3)
                << copy.filename() << " --view " << view;
    }
    // The views differ (the comparison above is not between blank or symmetric images).
    const ImageBuffer front = renderCopy(ras, "--view front", dir);
    EXPECT_GT(rmse(renderCopy(ras, "--view back", dir), front), 0.02);
    EXPECT_GT(rmse(renderCopy(ras, "--view top", dir), front), 0.02);
    // No view flag: a NIfTI is framed from the front whatever its storage order.
    EXPECT_LE(rmseNoted(renderCopy(asr, "", dir), front, "asr.nii, no --view"), 2e-3);
}

TEST(OrientationRender, NrrdAndMetaImageInLpsRenderLikeTheRasNifti) {
    const fs::path dir = test::tempDir("orient-render-nrrd-mha");
    const fs::path ras = writeNiftiCopy(dir / "ras.nii", store({}));
    const Stored asl = store({{1, 2, 0}, {1, 1, -1}}); // i anterior, j superior, k toward the left
    const fs::path nrrd = writeNrrdLps(dir / "asl.nrrd", asl);
    const fs::path mha = writeMetaImageLps(dir / "asl.mha", asl);
    const fs::path lpsNrrd = writeNrrdLps(dir / "lps.nrrd", store({{0, 1, 2}, {-1, -1, 1}}));
    for (const std::string view : {"front", "left"}) {
        const ImageBuffer reference = renderCopy(ras, "--view " + view, dir);
        for (const fs::path& copy : {nrrd, mha, lpsNrrd})
            EXPECT_LE(rmseNoted(renderCopy(copy, "--view " + view, dir), reference,
                                copy.filename().string() + " --view " + view),
                      2e-3)
                << copy.filename() << " --view " << view;
    }
}

TEST(OrientationRender, VczOfAnOrientedNiftiRendersLikeTheNifti) {
    const fs::path dir = test::tempDir("orient-render-vcz");
    const fs::path ras = writeNiftiCopy(dir / "ras.nii", store({}));
    const fs::path asr = writeNiftiCopy(dir / "asr.nii", store({{1, 2, 0}, {1, -1, 1}}));
    const RunResult enc =
        run("encode " + asr.string() + " -o " + (dir / "asr.vcz").string() + " --lossless", dir);
    ASSERT_EQ(enc.exitCode, 0) << enc.err;
    const ImageBuffer reference = renderCopy(ras, "--view front", dir);
    EXPECT_LE(rmseNoted(renderCopy(dir / "asr.vcz", "--view front", dir), reference, "asr.vcz --view front"),
              2e-3);
    EXPECT_LE(rmseNoted(renderCopy(dir / "asr.vcz", "", dir), reference, "asr.vcz, no --view"),
              2e-3); // framed from the front too
}

TEST(OrientationRender, ObliqueSformRendersAsARotatedBox) {
    // The RAS copy's grid turned 30 degrees about z (sform = Rz * diag(spacing)), against an independent
    // resampling: the anatomy evaluated in closed form on a fine axis-aligned world grid (0 outside the
    // turned box), rendered unrotated with the camera the front view frames the turned box with.
    const fs::path dir = test::tempDir("orient-render-oblique");
    const double a = std::numbers::pi / 6, c = std::cos(a), s = std::sin(a);
    const Stored flat = store({});
    NiftiSpec spec;
    spec.dims = flat.dims;
    spec.pixdim = flat.spacing;
    spec.sformCode = 1;
    spec.srow = {{{c * kRasSpacing[0], -s * kRasSpacing[1], 0, 0},
                  {s * kRasSpacing[0], c * kRasSpacing[1], 0, 0},
                  {0, 0, kRasSpacing[2], 0}}};
    writeNifti(dir / "oblique.nii", spec, flat.voxels);

    const std::array<double, 3> ext{19, 28.75, 22.5};
    double lo[3] = {1e9, 1e9, 1e9}, hi[3] = {-1e9, -1e9, -1e9};
    for (int i = 0; i < 8; ++i) {
        const double p[3] = {(i & 1) ? ext[0] : 0, (i & 2) ? ext[1] : 0, (i & 4) ? ext[2] : 0};
        const double w[3] = {c * p[0] - s * p[1], s * p[0] + c * p[1], p[2]};
        for (int k = 0; k < 3; ++k) {
            lo[k] = std::min(lo[k], w[k]);
            hi[k] = std::max(hi[k], w[k]);
        }
    }
    const double h = 0.25; // fine steps: a quarter of the finest spacing
    Stored fine;
    fine.dims = {std::size_t(std::ceil((hi[0] - lo[0]) / h)) + 1,
                 std::size_t(std::ceil((hi[1] - lo[1]) / h)) + 1,
                 std::size_t(std::ceil((hi[2] - lo[2]) / h)) + 1};
    fine.spacing = {h, h, h};
    fine.origin = {lo[0], lo[1], lo[2]};
    fine.direction = kIdentity;
    for (std::size_t k = 0; k < fine.dims.z; ++k)
        for (std::size_t j = 0; j < fine.dims.y; ++j)
            for (std::size_t i = 0; i < fine.dims.x; ++i) {
                const double w[3] = {lo[0] + double(i) * h, lo[1] + double(j) * h, lo[2] + double(k) * h};
                const double p[3] = {c * w[0] + s * w[1], -s * w[0] + c * w[1], w[2]}; // Rz^T w
                const bool inside =
                    p[0] >= 0 && p[0] <= ext[0] && p[1] >= 0 && p[1] <= ext[1] && p[2] >= 0 && p[2] <= ext[2];
                fine.voxels.push_back(inside ? float(anatomy(p[0], p[1], p[2])) : 0.0f);
            }
    writeNiftiCopy(dir / "resampled.nii", fine);

    // The front view of the turned box: target its world centre, eye toward +y (anterior), superior up,
    // the orthographic height the diameter of its bounding sphere.
    const double centre[3] = {c * ext[0] / 2 - s * ext[1] / 2, s * ext[0] / 2 + c * ext[1] / 2, ext[2] / 2};
    const double radius = std::hypot(ext[0], ext[1], ext[2]) / 2;
    std::ostringstream cam;
    cam << "--target " << centre[0] << "," << centre[1] << "," << centre[2] << " --eye " << centre[0] << ","
        << centre[1] + 2 * radius << "," << centre[2] << " --up 0,0,1 --view-height " << 2 * radius;
    const ImageBuffer oracle = renderCopy(dir / "resampled.nii", cam.str(), dir);
    const ImageBuffer turned = renderCopy(dir / "oblique.nii", "--view front", dir);
    const ImageBuffer unturned = renderCopy(writeNiftiCopy(dir / "flat.nii", flat), "--view front", dir);
    const double error = rmseNoted(turned, oracle, "oblique.nii vs resampled oracle"),
                 unturnedError = rmseNoted(unturned, oracle, "unturned grid vs resampled oracle");
    EXPECT_LE(error, 0.02);
    EXPECT_GT(unturnedError, 4 * error) << "the oracle does not tell a turned box from an unturned one";
}

TEST(OrientationRender, Ch2RestoredAsLpsAndAsrShowsTheFace) {
    // The MNI "ch2" head (RAS sform) re-stored as LPS and as ASR with the matching sforms, as nibabel's
    // as_reoriented would: all three show the same face from the front.
    const fs::path ch2 = "/usr/share/mricron/templates/ch2.nii.gz";
    if (!fs::exists(ch2)) GTEST_SKIP() << ch2 << " is absent (package mricron-data)";
    const fs::path dir = test::tempDir("orient-ch2");
    const Volume head = readVolumeFile(ch2).frames.at(0);
    ASSERT_EQ(head.type(), ScalarType::UInt8);
    const Dims n = head.dims();
    const auto src = head.values<std::uint8_t>();
    const std::array<double, 3>& o = head.origin; // the RAS sform is diagonal with spacing 1
    ASSERT_EQ(head.spacing, (std::array<double, 3>{1, 1, 1}));

    std::vector<std::uint8_t> lps(n.count()), asr(n.count());
    // LPS: i' = nx-1-i, j' = ny-1-j. ASR: (i', j', k') = (j, k, i), dims (ny, nz, nx).
    for (std::size_t k = 0; k < n.z; ++k)
        for (std::size_t j = 0; j < n.y; ++j)
            for (std::size_t i = 0; i < n.x; ++i) {
                const std::uint8_t v = src[head.index(i, j, k)];
                lps[(n.x - 1 - i) + n.x * ((n.y - 1 - j) + n.y * k)] = v;
                asr[j + n.y * (k + n.z * i)] = v;
            }
    NiftiSpec l;
    l.dims = n;
    l.sformCode = 4;
    l.srow = {{{-1, 0, 0, o[0] + double(n.x - 1)}, {0, -1, 0, o[1] + double(n.y - 1)}, {0, 0, 1, o[2]}}};
    writeNiftiBytes(dir / "lps.nii", l, std::as_bytes(std::span(lps)), 2, 8);
    NiftiSpec a;
    a.dims = {n.y, n.z, n.x};
    a.sformCode = 4;
    a.srow = {{{0, 0, 1, o[0]}, {1, 0, 0, o[1]}, {0, 1, 0, o[2]}}};
    writeNiftiBytes(dir / "asr.nii", a, std::as_bytes(std::span(asr)), 2, 8);

    test::writeFile(dir / "head.json", R"({"domain": [0, 255], "color": [[0, 1, 1, 1], [255, 1, 1, 1]],
                                          "extinction": [[0, 0], [40, 0], [255, 0.2]]})");
    auto render = [&](const fs::path& volume, const std::string& view) {
        const fs::path out = dir / (volume.stem().string() + "_" + view + ".exr");
        const RunResult r =
            run("render --volume " + volume.string() + " --tf " + (dir / "head.json").string() +
                    " --tf-unit-distance 1 --step 0.5 --width 64 --height 64 --view " + view + " -o " +
                    out.string(),
                dir);
        EXPECT_EQ(r.exitCode, 0) << r.err;
        return readImage(out);
    };
    const ImageBuffer front = render(ch2, "front");
    EXPECT_LE(rmseNoted(render(dir / "lps.nii", "front"), front, "ch2 LPS --view front"), 2e-3);
    EXPECT_LE(rmseNoted(render(dir / "asr.nii", "front"), front, "ch2 ASR --view front"), 2e-3);
    EXPECT_GT(rmse(render(ch2, "back"), front), 0.02); // the back of the head is not the face
}
