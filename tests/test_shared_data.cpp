// Every volume file in ../shared/data: dims, type, geometry and value range as documented in its README.
// Sums marked "VTK" were computed with VTK 9.1's own readers (python3-vtk9) as an independent reference.
#include "TestUtil.hpp"
#include "core/Error.hpp"
#include "host/io/VolumeIo.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numeric>

namespace {

namespace fs = std::filesystem;
using namespace volcl;

struct Range {
    double min, max;
};

Range rangeOf(const Volume& v, std::size_t expectedNans = 0) {
    const VolumeStats s = v.stats();
    EXPECT_EQ(s.nanCount, expectedNans);
    EXPECT_EQ(s.infCount, 0u);
    return {s.min, s.max};
}

double sumOf(const Volume& v) {
    double sum = 0;
    for (std::size_t n = 0; n < v.voxelCount(); ++n)
        sum += v.valueAt(n);
    return sum;
}

void expectGrid(const Volume& v, Dims dims, ScalarType type, std::array<double, 3> spacing = {1, 1, 1},
                std::array<double, 3> origin = {0, 0, 0}) {
    EXPECT_EQ(v.dims(), dims);
    EXPECT_EQ(scalarTypeName(v.type()), scalarTypeName(type));
    for (int a = 0; a < 3; ++a) {
        EXPECT_NEAR(v.spacing[a], spacing[a], 1e-9 * std::abs(spacing[a])) << "axis " << a;
        EXPECT_NEAR(v.origin[a], origin[a], 1e-9) << "axis " << a;
    }
}

/// The regular uint8 volumes: dims, spacing and range from the README (range for neghip, ironProt
/// and HeadMR computed once); sums from VTK's readers where VTK reads the format.
struct RegularCase {
    const char* file;
    Dims dims;
    std::array<double, 3> spacing;
    double min, max;
    double vtkSum; ///< 0 when not cross-checked
};

TEST(SharedData, RegularUint8Volumes) {
    fs::path d;
    VOLCL_REQUIRE_SHARED_DATA(d);
    const RegularCase cases[] = {
        {"regular/Bucky.raw", {32, 32, 32}, {1, 1, 1}, 0, 255, 0},
        {"regular/nucleon.nrrd", {41, 41, 41}, {1, 1, 1}, 0, 249, 0},           // detached NRRD0001
        {"regular/hydrogenatom.dat", {128, 128, 128}, {1, 1, 1}, 0, 250, 0},    // Inviwo .dat
        {"regular/neghip.slc", {66, 66, 66}, {1, 1, 1}, 0, 255, 4824177},       // vtkSLCReader
        {"regular/ironProt.vtk", {68, 68, 68}, {1, 1, 1}, 0, 255, 4131089},     // vtkStructuredPointsReader
        {"regular/HeadMRVolume.mhd", {48, 62, 42}, {4, 4, 4}, 0, 255, 3058332}, // vtkMetaImageReader
        {"regular/t1_icbm_normal_1mm_pn0_rf0_180x216x180_uint8_1x1.bin-gz",
         {180, 216, 180},
         {1, 1, 1},
         0,
         255,
         0},
    };
    for (const RegularCase& c : cases) {
        SCOPED_TRACE(c.file);
        ReadOptions o;
        if (std::string_view(c.file).ends_with("Bucky.raw")) { // no size in the name: given as flags
            o.dims = Dims{32, 32, 32};
            o.type = ScalarType::UInt8;
        }
        const Volume v = readVolume(d / c.file, o);
        expectGrid(v, c.dims, ScalarType::UInt8, c.spacing);
        const Range r = rangeOf(v);
        EXPECT_EQ(r.min, c.min);
        EXPECT_EQ(r.max, c.max);
        if (c.vtkSum > 0) EXPECT_EQ(sumOf(v), c.vtkSum);
    }
}

TEST(SharedData, HeadsqNhdrSlicePattern) {
    fs::path d;
    VOLCL_REQUIRE_SHARED_DATA(d);
    const Volume v = readVolume(d / "regular/headsq/quarter.nhdr");
    expectGrid(v, {64, 64, 93}, ScalarType::Int16, {3.2, 3.2, 1.5});
    // README: slice 40 (file quarter.40, z = 39) decodes as little-endian to 0..2523.
    auto s = v.values<std::int16_t>().subspan(v.index(0, 0, 39), 64 * 64);
    EXPECT_EQ(*std::min_element(s.begin(), s.end()), 0);
    EXPECT_EQ(*std::max_element(s.begin(), s.end()), 2523);
    EXPECT_GE(rangeOf(v).min, 0);
}

TEST(SharedData, WalnutVoreen) {
    fs::path d;
    VOLCL_REQUIRE_SHARED_DATA(d);
    const Volume v = readVolume(d / "regular/walnut.vvd");
    expectGrid(v, {128, 96, 114}, ScalarType::UInt16, {0.015625, 0.015625, 0.015625}, {-1, -0.75, -0.890625});
    const Range r = rangeOf(v);
    EXPECT_EQ(r.min, 0);
    EXPECT_EQ(r.max, 22526);                        // little-endian; big-endian would reach 65364
    EXPECT_NEAR(r.max / 65535.0, 0.34372473, 1e-6); // the .vvd's normalised VolumeMinMax
}

TEST(SharedData, FrogZlibMetaImageIgnoresWrongCompressedSize) {
    fs::path d;
    VOLCL_REQUIRE_SHARED_DATA(d);
    const Volume v = readVolume(d / "regular/froggy/frogtissue.mhd");
    expectGrid(v, {500, 470, 136}, ScalarType::UInt8, {1, 1, 1.5});
    const Range r = rangeOf(v);
    EXPECT_EQ(r.min, 0);
    EXPECT_EQ(r.max, 29); // README: labels 0..~30
    // A reader trusting CompressedDataSize = 260020 stops early (VTK 9.1 then sums to 12244762);
    // inflating the whole stream gives every voxel.
    EXPECT_EQ(sumOf(v), 12279472.0);
    auto last = v.values<std::uint8_t>().subspan(v.index(0, 0, 100));
    EXPECT_GT(std::accumulate(last.begin(), last.end(), 0.0), 0.0);
}

TEST(SharedData, IsabelTimeSteps) {
    fs::path d;
    VOLCL_REQUIRE_SHARED_DATA(d);
    int files = 0;
    for (int t : {2, 3, 4, 5, 30, 31, 32, 33, 45, 46, 47, 48}) {
        char name[64];
        std::snprintf(name, sizeof(name), "timevarying/isabel/isabel_%02d.vti", t);
        SCOPED_TRACE(name);
        const TimeSeries s = readVolumeFile(d / name);
        ASSERT_EQ(s.frames.size(), 1u);
        ASSERT_EQ(s.times.size(), 1u);
        EXPECT_EQ(s.times[0], t); // FieldData TimeStep
        const Volume& v = s.frames[0];
        expectGrid(v, {125, 125, 25}, ScalarType::Float64, {4.0080321286, 4.0080321286, 4.0408163266});
        const Range r = rangeOf(v);
        EXPECT_EQ(r.min, 0);
        EXPECT_GE(r.max, 56);
        EXPECT_LE(r.max, 79);
        if (t == 2) EXPECT_NEAR(r.max, 68.245477692, 1e-9); // the file's RangeMax (Float64, kept)
        ++files;
    }
    EXPECT_EQ(files, 12);
}

TEST(SharedData, ViscousFingersDensityGrows) {
    fs::path d;
    VOLCL_REQUIRE_SHARED_DATA(d);
    double previous = 0;
    for (int t = 1; t <= 20; ++t) {
        char name[96];
        std::snprintf(name, sizeof(name), "timevarying/viscousfingers/%03d_density_%03d_064_2.0.vti", t, t);
        SCOPED_TRACE(name);
        const Volume v = readVolume(d / name);
        expectGrid(v, {64, 64, 64}, ScalarType::Float32);
        const Range r = rangeOf(v);
        EXPECT_GE(r.min, 0);
        EXPECT_GT(r.max, previous) << "max density must grow steadily";
        previous = r.max;
        if (t == 1) EXPECT_NEAR(r.max, 76.763237, 1e-4); // README: 76.8
        if (t == 20) EXPECT_NEAR(r.max, 100.289, 1e-3);  // README: 100.3
    }
}

TEST(SharedData, FunctionalNiftiFourD) {
    fs::path d;
    VOLCL_REQUIRE_SHARED_DATA(d);
    const TimeSeries s = readVolumeFile(d / "timevarying/functional.nii.gz");
    ASSERT_EQ(s.frames.size(), 20u);
    ASSERT_EQ(s.times.size(), 20u);
    EXPECT_EQ(s.times[1], 2.0); // TR 2.0 s
    EXPECT_EQ(s.times[19], 38.0);
    // Stored as int16 (datatype 4) with scl_slope 0.0754 / scl_inter 3100.76: read as float32 data units.
    for (const Volume& v : s.frames)
        expectGrid(v, {17, 21, 3}, ScalarType::Float32, {4, 4, 8}, v.origin);
    const Range r = rangeOf(s.frames[0]);
    EXPECT_NEAR(r.min, 762.5424365997314, 1e-3); // VTK vtkNIFTIImageReader, frame 0, scaled
    EXPECT_NEAR(r.max, 5538.065757632256, 1e-3);
    EXPECT_NEAR(sumOf(s.frames[0]), 3883746.5529, 1e-2);
}

TEST(SharedData, SmokeVdbDoubleGrid) {
    fs::path d;
    VOLCL_REQUIRE_SHARED_DATA(d);
    const Volume v = readVolume(d / "vdb/smoke.vdb");
    // README: one DoubleGrid 'density', bbox (0,0,0)-(127,63,63), fully dense.
    EXPECT_EQ(v.dims(), (Dims{128, 64, 64}));
    EXPECT_EQ(v.type(), ScalarType::Float32);
    const Range r = rangeOf(v);
    EXPECT_GE(r.min, 0);
    EXPECT_LE(r.max, 1.0);
    EXPECT_GT(r.max, 0);
}

TEST(SharedData, Grid0VdbFloatGrid) {
    fs::path d;
    VOLCL_REQUIRE_SHARED_DATA(d);
    const Volume v = readVolume(d / "vdb/grid0.vdb");
    // README: FloatGrid 'posdensity', bbox (-40,-40,-40)-(40,40,40) = 81^3.
    expectGrid(v, {81, 81, 81}, ScalarType::Float32, {1, 1, 1}, {-40, -40, -40});
    // The file holds exactly one NaN voxel (not mentioned in the README): readers must pass it through.
    const Range r = rangeOf(v, 1);
    std::size_t nanAt = v.voxelCount();
    for (std::size_t n = 0; n < v.voxelCount(); ++n)
        if (std::isnan(v.valueAt(n))) nanAt = n;
    EXPECT_LT(nanAt, v.voxelCount());
    EXPECT_NEAR(r.min, -0.235319, 1e-5);
    EXPECT_NEAR(r.max, 1.38177, 1e-5);
    ReadOptions o;
    o.vdbGrid = "posdensity";
    EXPECT_EQ(readVolume(d / "vdb/grid0.vdb", o), v);
}

TEST(SharedData, PointsVdbIsRefused) {
    fs::path d;
    VOLCL_REQUIRE_SHARED_DATA(d);
    try {
        (void)readVolume(d / "vdb/sphere_points.vdb");
        ADD_FAILURE() << "points grid accepted";
    } catch (const DataError& e) {
        const std::string m = e.what();
        EXPECT_NE(m.find("points"), std::string::npos) << m;
        EXPECT_NE(m.find("point data grid"), std::string::npos) << m;
        EXPECT_EQ(m.find('\n'), std::string::npos) << "one line";
    }
}

TEST(SharedData, ConvertedCopiesRoundTrip) {
    // The writers keep real integer volumes bit-exact: raw -> NRRD -> VDB -> raw on walnut (uint16)
    // and headsq (int16), through the same calls `volcl convert` uses.
    fs::path d;
    VOLCL_REQUIRE_SHARED_DATA(d);
    const fs::path tmp = test::tempDir("io-shared-convert");
    for (const char* name : {"regular/walnut.vvd", "regular/headsq/quarter.nhdr", "regular/neghip.slc"}) {
        SCOPED_TRACE(name);
        const Volume v = readVolume(d / name);
        writeVolumeFile(v, tmp / "a.nrrd");
        writeVolumeFile(readVolume(tmp / "a.nrrd"), tmp / "b.vdb");
        const Volume back = readVolume(tmp / "b.vdb");
        EXPECT_EQ(back, v);
        writeVolumeFile(back, tmp / "c.raw");
        ReadOptions o;
        o.dims = v.dims();
        o.type = v.type();
        Volume raw = readVolume(tmp / "c.raw", o);
        raw.spacing = v.spacing;
        raw.origin = v.origin;
        EXPECT_EQ(raw, v);
    }
}

} // namespace
