// NIfTI-1 and VTK XML ImageData writers: round trips through the readers, kept header fields, re-anchored
// orientation after crops and coarser levels, scaled integers (as data units or stored), 4D series, refused outputs.
#include "TestUtil.hpp"
#include "core/Error.hpp"
#include "host/io/NiftiMetadata.hpp"
#include "host/io/VolumeIo.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>

namespace {

namespace fs = std::filesystem;
using namespace volcl;

// A volume of every scalar type with distinct voxels (a ramp that wraps in the integer range).
Volume ramp(Dims d, ScalarType t) {
    Volume v(d, t);
    for (std::size_t n = 0; n < v.voxelCount(); ++n) {
        const double x = static_cast<double>(n % 251) - (t == ScalarType::Int16 ? 100.0 : 0.0);
        switch (t) {
        case ScalarType::UInt8:
            v.values<std::uint8_t>()[n] = static_cast<std::uint8_t>(x);
            break;
        case ScalarType::UInt16:
            v.values<std::uint16_t>()[n] = static_cast<std::uint16_t>(x * 200);
            break;
        case ScalarType::Int16:
            v.values<std::int16_t>()[n] = static_cast<std::int16_t>(x * 100);
            break;
        case ScalarType::Float32:
            v.values<float>()[n] = static_cast<float>(x * 0.37 - 11.5);
            break;
        }
    }
    v.spacing = {0.5, 1.25, 2.0};
    v.origin = {-3.0, 4.5, 10.0};
    return v;
}

// An oblique NIfTI header: LAS-style flip on x, a rotation in the qform, units, intent, description.
NiftiMetadata obliqueMeta(const Volume& v) {
    NiftiMetadata m = niftiMetadataForVolume(v);
    m.qformCode = 1;
    m.sformCode = 4;
    m.quaternB = 0.1f;
    m.quaternC = -0.2f;
    m.quaternD = 0.05f;
    m.qfac = -1;
    m.srow = {{{-0.5f, 0.1f, 0.0f, 40.0f}, {0.05f, 1.25f, 0.2f, -7.0f}, {0.0f, -0.1f, 2.0f, 10.0f}}};
    m.origin = {40.0, -7.0, 10.0}; // what the reader sets: the sform translation
    m.xyztUnits = 10;              // mm, s
    m.intentCode = 1002;           // NIFTI_INTENT_LABEL
    m.intentP = {1.5f, 0.0f, -2.0f};
    m.intentName = "labels";
    m.descrip = "volcl writer test";
    m.calMin = 0;
    m.calMax = 200;
    return m;
}

std::array<double, 3> world(const std::array<std::array<double, 4>, 3>& a, double i, double j, double k) {
    return {a[0][0] * i + a[0][1] * j + a[0][2] * k + a[0][3],
            a[1][0] * i + a[1][1] * j + a[1][2] * k + a[1][3],
            a[2][0] * i + a[2][1] * j + a[2][2] * k + a[2][3]};
}

TEST(NiftiWriter, EveryTypeRoundTripsWithGeometry) {
    const fs::path dir = test::tempDir("nifti_writer_types");
    for (ScalarType t : {ScalarType::UInt8, ScalarType::UInt16, ScalarType::Int16, ScalarType::Float32})
        for (const char* name : {"v.nii", "v.nii.gz"}) {
            const Volume v = ramp({7, 5, 3}, t);
            writeVolumeFile(v, dir / name);
            const Volume back = readVolume(dir / name);
            EXPECT_EQ(back, v) << name << " " << scalarTypeName(t); // voxels, type, spacing and origin
            const NiftiMetadata m = readNiftiMetadata(dir / name);
            EXPECT_EQ(m.qformCode, 1);
            EXPECT_EQ(m.sformCode, 1);
            EXPECT_EQ(m.srow[0][0], 0.5f);
            EXPECT_EQ(m.srow[2][3], 10.0f);
        }
}

TEST(NiftiWriter, KeepsEveryHeaderFieldOfItsSource) {
    const fs::path dir = test::tempDir("nifti_writer_fields");
    Volume v = ramp({6, 4, 5}, ScalarType::Int16);
    const NiftiMetadata meta = obliqueMeta(v);
    v.origin = meta.origin;
    WriteOptions o;
    o.nifti = meta;
    writeVolumeFile(v, dir / "a.nii.gz", o);
    NiftiMetadata back = readNiftiMetadata(dir / "a.nii.gz");
    back.datatype = meta.datatype; // the written type is the volume's (int16 = 4)
    EXPECT_EQ(back, meta);
    EXPECT_EQ(readNiftiMetadata(dir / "a.nii.gz").datatype, 4);
    EXPECT_EQ(readVolume(dir / "a.nii.gz"), v);
    // Written again from what was read: the same bytes.
    WriteOptions again;
    again.nifti = readNiftiMetadata(dir / "a.nii.gz");
    writeVolumeFile(readVolume(dir / "a.nii.gz"), dir / "b.nii", again);
    writeVolumeFile(readVolume(dir / "a.nii.gz"), dir / "c.nii", again);
    std::ifstream b(dir / "b.nii", std::ios::binary), c(dir / "c.nii", std::ios::binary);
    EXPECT_TRUE(std::equal(std::istreambuf_iterator<char>(b), {}, std::istreambuf_iterator<char>(c)));
}

TEST(NiftiWriter, ScaledIntegersGoBackToTheirStoredType) {
    const fs::path dir = test::tempDir("nifti_writer_scaled");
    // Data units of an int16 file with slope 0.5 and intercept 10, as the reader produces them.
    Volume stored = ramp({5, 4, 3}, ScalarType::Int16);
    Volume units(stored.dims(), ScalarType::Float32);
    units.spacing = stored.spacing;
    units.origin = stored.origin;
    for (std::size_t n = 0; n < units.voxelCount(); ++n)
        units.values<float>()[n] = static_cast<float>(stored.valueAt(n) * 0.5 + 10.0);
    NiftiMetadata meta = niftiMetadataForVolume(units);
    meta.datatype = 4;
    meta.sclSlope = 0.5f;
    meta.sclInter = 10.0f;
    WriteOptions o;
    o.nifti = meta;
    writeVolumeFile(units, dir / "s.nii", o);
    const NiftiMetadata back = readNiftiMetadata(dir / "s.nii");
    EXPECT_EQ(back.datatype, 4);
    EXPECT_EQ(back.sclSlope, 0.5f);
    EXPECT_EQ(back.sclInter, 10.0f);
    EXPECT_EQ(readVolume(dir / "s.nii"), units);
    // A value no stored integer gives (a lossy decode, an edit): float32, unscaled, same values.
    units.values<float>()[7] += 0.25f;
    writeVolumeFile(units, dir / "f.nii", o);
    EXPECT_EQ(readNiftiMetadata(dir / "f.nii").datatype, 16);
    EXPECT_EQ(readNiftiMetadata(dir / "f.nii").sclSlope, 1.0f);
    EXPECT_EQ(readVolume(dir / "f.nii"), units);
}

TEST(NiftiWriter, CropAndLevelMoveTheTransformsWithTheGrid) {
    const fs::path dir = test::tempDir("nifti_writer_crop");
    Volume v = ramp({8, 6, 4}, ScalarType::Float32);
    const NiftiMetadata meta = obliqueMeta(v);
    v.origin = meta.origin;
    // Crop [2,1,1]..: voxel (i,j,k) of the crop is source voxel (i+2, j+1, k+1) in sform and qform.
    const Volume crop = v.cropped({2, 1, 1}, {6, 5, 4});
    WriteOptions o;
    o.nifti = meta;
    writeVolumeFile(crop, dir / "c.nii", o);
    const NiftiMetadata m = readNiftiMetadata(dir / "c.nii");
    NiftiMetadata qOnly = meta, qOnlyCrop = m;
    qOnly.sformCode = qOnlyCrop.sformCode = 0;
    for (auto [i, j, k] : {std::array<double, 3>{0, 0, 0}, {3, 2, 1}, {1, 3, 2}}) {
        const auto want = world(niftiVoxelToWorld(meta), i + 2, j + 1, k + 1);
        const auto got = world(niftiVoxelToWorld(m), i, j, k);
        const auto wantQ = world(niftiVoxelToWorld(qOnly), i + 2, j + 1, k + 1);
        const auto gotQ = world(niftiVoxelToWorld(qOnlyCrop), i, j, k);
        for (int a = 0; a < 3; ++a) {
            EXPECT_NEAR(got[a], want[a], 1e-4) << "sform axis " << a;
            EXPECT_NEAR(gotQ[a], wantQ[a], 1e-4) << "qform axis " << a;
        }
    }
    EXPECT_EQ(m.intentName, "labels");
    EXPECT_EQ(m.xyztUnits, 10);
    // A 2x coarser grid from origin sample 0: voxel (i,j,k) is source voxel (2i, 2j, 2k).
    Volume coarse({4, 3, 2}, ScalarType::Float32);
    coarse.spacing = {1.0, 2.5, 4.0};
    coarse.origin = v.origin;
    const NiftiMetadata c = niftiMetadataOnGrid(meta, coarse);
    const auto want = world(niftiVoxelToWorld(meta), 6, 4, 2);
    const auto got = world(niftiVoxelToWorld(c), 3, 2, 1);
    for (int a = 0; a < 3; ++a)
        EXPECT_NEAR(got[a], want[a], 1e-4);
    EXPECT_EQ(c.pixdim[1], 2.5f);
}

TEST(NiftiWriter, MetadataTextRoundTripsAndRefusesGarbage) {
    const NiftiMetadata meta = obliqueMeta(ramp({3, 3, 3}, ScalarType::UInt8));
    EXPECT_EQ(niftiMetadataFromText(niftiMetadataToText(meta), "x.vcz"), meta);
    EXPECT_THROW(niftiMetadataFromText("{", "x.vcz"), IoError);
    EXPECT_THROW(niftiMetadataFromText("[1,2]", "x.vcz"), IoError);
    std::string text = niftiMetadataToText(meta);
    text.replace(text.find("\"qform_code\":1"), 14, "\"qform_code\":99999");
    try {
        niftiMetadataFromText(text, "x.vcz");
        ADD_FAILURE() << "an out-of-range code was accepted";
    } catch (const IoError& e) {
        EXPECT_NE(std::string(e.what()).find("x.vcz: NIfTI metadata: qform_code"), std::string::npos)
            << e.what();
    }
}

TEST(NiftiWriter, RefusesWhatNiftiCannotHoldAndLeavesNothing) {
    const fs::path dir = test::tempDir("nifti_writer_refused");
    EXPECT_THROW(writeVolumeFile(Volume({32768, 1, 1}, ScalarType::UInt8), dir / "wide.nii"), UsageError);
    EXPECT_THROW(writeVolumeFile(ramp({2, 2, 2}, ScalarType::UInt8), dir / "missing" / "x.nii.gz"), IoError);
    EXPECT_TRUE(fs::is_empty(dir));
}

TEST(VtiWriter, EveryTypeRoundTripsCompressedAndRaw) {
    const fs::path dir = test::tempDir("vti_writer_types");
    for (ScalarType t : {ScalarType::UInt8, ScalarType::UInt16, ScalarType::Int16, ScalarType::Float32})
        for (bool zlib : {true, false}) {
            // Over 32 KiB so the zlib path writes several blocks.
            const Volume v = ramp({40, 30, 20}, t);
            WriteOptions o;
            o.compress = zlib;
            writeVolumeFile(v, dir / "v.vti", o);
            EXPECT_EQ(readVolume(dir / "v.vti"), v) << scalarTypeName(t) << (zlib ? " zlib" : " raw");
        }
}

TEST(VtiWriter, NiftiOrientationBecomesOriginSpacingAndDirection) {
    const fs::path dir = test::tempDir("vti_writer_direction");
    Volume v = ramp({4, 3, 2}, ScalarType::UInt8);
    NiftiMetadata meta = niftiMetadataForVolume(v);
    meta.srow = {{{-2.0f, 0.0f, 0.0f, 90.0f}, {0.0f, 2.0f, 0.0f, -126.0f}, {0.0f, 0.0f, 2.0f, -72.0f}}};
    meta.origin = {90.0, -126.0, -72.0};
    meta.spacing = {2.0, 2.0, 2.0};
    v.spacing = meta.spacing;
    v.origin = meta.origin;
    WriteOptions o;
    o.nifti = meta;
    writeVolumeFile(v, dir / "las.vti", o);
    std::ifstream in(dir / "las.vti", std::ios::binary);
    std::string text((std::istreambuf_iterator<char>(in)), {});
    EXPECT_NE(text.find("Origin=\"90 -126 -72\" Spacing=\"2 2 2\" Direction=\"-1 0 0 0 1 0 0 0 1\""),
              std::string::npos)
        << text.substr(0, 400);
    EXPECT_EQ(readVolume(dir / "las.vti").values<std::uint8_t>()[5], v.values<std::uint8_t>()[5]);
}

} // namespace

namespace {

// Frame f of a test series: the ramp plus 3f, so every frame differs from the others.
TimeSeries rampSeries(ScalarType t, std::size_t frames) {
    TimeSeries ts;
    for (std::size_t f = 0; f < frames; ++f) {
        Volume v = ramp({5, 4, 3}, t);
        for (std::size_t n = 0; n < v.voxelCount(); ++n)
            if (t == ScalarType::Int16)
                v.values<std::int16_t>()[n] = static_cast<std::int16_t>(v.values<std::int16_t>()[n] + 3 * f);
            else
                v.values<float>()[n] += static_cast<float>(3 * f);
        ts.frames.push_back(std::move(v));
        ts.times.push_back(1.5 * static_cast<double>(f));
    }
    return ts;
}

template <class T> T headerField(const std::string& bytes, std::size_t offset) {
    T v;
    std::memcpy(&v, bytes.data() + offset, sizeof(T));
    return v;
}

} // namespace

TEST(NiftiWriter, SeriesIsOne4DFileWithEveryFrameAndTheTimeStep) {
    const fs::path dir = test::tempDir("nifti_writer_4d");
    const TimeSeries ts = rampSeries(ScalarType::Float32, 4);
    writeSeriesFile(ts, dir / "s.nii");
    // The header as nifti1.h lays it out, read here byte by byte.
    const std::string bytes = test::readFile(dir / "s.nii");
    ASSERT_EQ(bytes.size(), 352 + 4 * 5 * 4 * 3 * sizeof(float));
    EXPECT_EQ(headerField<std::int16_t>(bytes, 40), 4);          // dim[0]
    EXPECT_EQ(headerField<std::int16_t>(bytes, 48), 4);          // dim[4]: frames
    EXPECT_EQ(headerField<float>(bytes, 92), 1.5f);              // pixdim[4]: the time step
    EXPECT_EQ(static_cast<unsigned char>(bytes[123]) & 0x38, 8); // time in seconds
    const TimeSeries back = readVolumeFile(dir / "s.nii");
    ASSERT_EQ(back.frames.size(), 4u);
    for (std::size_t f = 0; f < 4; ++f)
        EXPECT_EQ(back.frames[f], ts.frames[f]) << "frame " << f;
    EXPECT_EQ(back.times, ts.times);
    // A NRRD holds the frames along a fourth axis (no times); a format that holds one volume refuses the
    // series and leaves no file.
    writeSeriesFile(ts, dir / "s.nhdr");
    const std::string nhdr = test::readFile(dir / "s.nhdr");
    EXPECT_NE(nhdr.find("dimension: 4\n"), std::string::npos) << nhdr;
    EXPECT_NE(nhdr.find("sizes: 5 4 3 4\n"), std::string::npos) << nhdr;
    const std::size_t dataAt = nhdr.find("data file: ") + 11;
    const std::string dataFile = nhdr.substr(dataAt, nhdr.find('\n', dataAt) - dataAt);
    EXPECT_EQ(test::readFile(dir / dataFile).size(), 4 * 5 * 4 * 3 * sizeof(float));
    const TimeSeries nrrd = readVolumeFile(dir / "s.nhdr");
    ASSERT_EQ(nrrd.frames.size(), 4u);
    for (std::size_t f = 0; f < 4; ++f)
        EXPECT_EQ(nrrd.frames[f], ts.frames[f]) << "NRRD frame " << f;
    EXPECT_THROW(writeSeriesFile(ts, dir / "s.vti"), UsageError);
    EXPECT_FALSE(fs::exists(dir / "s.vti"));
}

TEST(NiftiWriter, StoredIntegersKeepTheirScaleAndOtherFormatsGetDataUnits) {
    const fs::path dir = test::tempDir("nifti_writer_stored");
    const TimeSeries stored = rampSeries(ScalarType::Int16, 3);
    WriteOptions o;
    o.nifti = niftiMetadataForVolume(stored.frames[0]);
    o.nifti->datatype = 4;
    o.nifti->sclSlope = 0.5f;
    o.nifti->sclInter = 10.0f;
    o.niftiStoredValues = true;
    writeSeriesFile(stored, dir / "s.nii", o);
    const NiftiMetadata meta = readNiftiMetadata(dir / "s.nii");
    EXPECT_EQ(meta.datatype, 4);
    EXPECT_EQ(meta.sclSlope, 0.5f);
    EXPECT_EQ(meta.sclInter, 10.0f);
    ReadOptions raw;
    raw.niftiStoredValues = true;
    const TimeSeries asStored = readVolumeFile(dir / "s.nii", raw), asUnits = readVolumeFile(dir / "s.nii");
    ASSERT_EQ(asStored.frames.size(), 3u);
    ASSERT_EQ(asUnits.frames.size(), 3u);
    writeVolumeFile(stored.frames[2], dir / "f2.nrrd", o);
    const Volume nrrd = readVolume(dir / "f2.nrrd");
    for (std::size_t f = 0; f < 3; ++f) {
        EXPECT_EQ(asStored.frames[f], stored.frames[f]) << "frame " << f;
        ASSERT_EQ(asUnits.frames[f].type(), ScalarType::Float32);
        for (std::size_t n = 0; n < stored.frames[f].voxelCount(); ++n) {
            const float units = static_cast<float>(stored.frames[f].values<std::int16_t>()[n] * 0.5 + 10.0);
            ASSERT_EQ(asUnits.frames[f].values<float>()[n], units) << "frame " << f << " voxel " << n;
            if (f == 2) ASSERT_EQ(nrrd.values<float>()[n], units) << "NRRD voxel " << n;
        }
    }
}
