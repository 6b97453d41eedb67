// The OpenVDB half of .vdb I/O, a module libvolcl loads when a .vdb file is first read or written: float/double
// grids densified over their box, and the exact FloatGrid writer.
#include "host/io/VdbModule.hpp"
#include "core/AtomicFile.hpp"
#include "core/MemoryBudget.hpp"
#include "host/io/IoDetail.hpp"

#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <limits>

namespace volcl::io {

namespace fs = std::filesystem;

namespace {

void initOpenVdb() {
    static const bool once = [] {
        openvdb::initialize();
        return true;
    }();
    (void)once;
}

std::string describeGrid(const openvdb::GridBase& g) {
    const std::string type = g.type();
    std::string what = "a " + g.valueType() + " grid";
    if (type.find("ptdataidx") != std::string::npos)
        what = "a point data grid";
    else if (type.find("vec3") != std::string::npos)
        what = "a vector grid";
    return "grid '" + g.getName() + "' is " + what + " (" + type + "), not a scalar float/double grid";
}

bool isScalarGrid(const openvdb::GridBase& g) {
    return g.isType<openvdb::FloatGrid>() || g.isType<openvdb::DoubleGrid>();
}

template <class GridT>
Volume densify(const GridT& grid, const openvdb::CoordBBox& box, const fs::path& path,
               std::size_t memoryBudget) {
    const openvdb::Coord size = box.dim();
    const Dims dims{static_cast<std::size_t>(size.x()), static_cast<std::size_t>(size.y()),
                    static_cast<std::size_t>(size.z())};
    const std::size_t voxels = checkedVoxelCount(dims, 1, path);
    // The dense float box and its copy in the volume model's type.
    if (voxels > std::numeric_limits<std::size_t>::max() / 8) fail(path, "dense box size overflows");
    checkMemoryBudget(voxels * 8, memoryBudget, path,
                      "dense box " + std::to_string(dims.x) + "x" + std::to_string(dims.y) + "x" +
                          std::to_string(dims.z));
    Volume v(dims, ScalarType::Float32);
    auto out = v.values<float>();
    std::fill(out.begin(), out.end(), static_cast<float>(grid.background()));
    const openvdb::Coord lo = box.min();
    // Active voxels and tiles only: inactive voxels read as the background, as the grid defines them.
    for (auto it = grid.cbeginValueOn(); it; ++it) {
        openvdb::CoordBBox b = it.getBoundingBox();
        b.intersect(box);
        if (b.empty()) continue;
        const float value = static_cast<float>(*it);
        for (int z = b.min().z(); z <= b.max().z(); ++z)
            for (int y = b.min().y(); y <= b.max().y(); ++y) {
                const std::size_t row =
                    v.index(0, static_cast<std::size_t>(y - lo.y()), static_cast<std::size_t>(z - lo.z()));
                for (int x = b.min().x(); x <= b.max().x(); ++x)
                    out[row + static_cast<std::size_t>(x - lo.x())] = value;
            }
    }
    return v;
}

std::optional<ScalarType> storedTypeOf(const openvdb::GridBase& g) {
    const auto meta = g.getMetadata<openvdb::StringMetadata>("volcl:type");
    if (!meta) return std::nullopt;
    const std::string& t = meta->value();
    if (t == "uint8") return ScalarType::UInt8;
    if (t == "uint16") return ScalarType::UInt16;
    if (t == "int16") return ScalarType::Int16;
    if (t == "float32") return ScalarType::Float32;
    return std::nullopt;
}

template <class T> void restoreIntegers(const Volume& f, Volume& out, const fs::path& path) {
    auto src = f.values<float>();
    auto dst = out.values<T>();
    for (std::size_t i = 0; i < src.size(); ++i) {
        const float x = src[i];
        if (!(x >= static_cast<float>(std::numeric_limits<T>::min()) &&
              x <= static_cast<float>(std::numeric_limits<T>::max())) ||
            x != std::floor(x))
            fail(path, "value " + formatDouble(x) + " does not fit the recorded volcl:type " +
                           std::string(scalarTypeName(out.type())));
        dst[i] = static_cast<T>(x);
    }
}

TimeSeries readDense(const fs::path& path, const ReadOptions& options) {
    initOpenVdb();
    openvdb::io::File file(path.string());
    file.open(false); // no delayed loading: the whole file is validated while reading, no mapping kept
    const openvdb::GridPtrVecPtr metas = file.readAllGridMetadata();
    if (!metas || metas->empty()) {
        file.close();
        fail(path, "contains no grids");
    }
    openvdb::GridBase::ConstPtr chosenMeta;
    if (options.vdbGrid) {
        std::string names;
        for (const auto& g : *metas) {
            names += (names.empty() ? "" : ", ") + g->getName();
            if (g->getName() == *options.vdbGrid) chosenMeta = g;
        }
        if (!chosenMeta)
            throw UsageError(path.string() + ": no grid named '" + *options.vdbGrid + "' (grids: " + names +
                             ")");
    } else {
        for (const auto& g : *metas)
            if (isScalarGrid(*g)) {
                chosenMeta = g;
                break;
            }
        if (!chosenMeta) chosenMeta = metas->front();
    }
    if (!isScalarGrid(*chosenMeta)) unsupported(path, describeGrid(*chosenMeta));

    const openvdb::GridBase::Ptr base = file.readGrid(chosenMeta->getName());
    file.close();
    const openvdb::math::Transform& xform = base->transform();
    if (!xform.isLinear())
        unsupported(path, "grid '" + base->getName() + "' has a non-linear (frustum) transform");

    // Our own files record the original box and type so zero voxels and integer types come back exactly.
    openvdb::CoordBBox box;
    const auto dimsMeta = base->getMetadata<openvdb::Vec3IMetadata>("volcl:dims");
    const auto minMeta = base->getMetadata<openvdb::Vec3IMetadata>("volcl:indexMin");
    // Serial on purpose: this runs in the reader program, whose address space is capped (VdbReaderMain.cpp),
    // and TBB's worker threads would each reserve a stack inside the cap.
    openvdb::CoordBBox active;
    auto expand = [&](const auto& grid) {
        for (auto it = grid.cbeginValueOn(); it; ++it)
            active.expand(it.getBoundingBox());
    };
    if (auto fg = openvdb::gridConstPtrCast<openvdb::FloatGrid>(base))
        expand(*fg);
    else if (auto dg = openvdb::gridConstPtrCast<openvdb::DoubleGrid>(base))
        expand(*dg);
    if (dimsMeta) {
        const openvdb::Vec3i d = dimsMeta->value();
        const openvdb::Vec3i m = minMeta ? minMeta->value() : openvdb::Vec3i(0, 0, 0);
        if (d.x() <= 0 || d.y() <= 0 || d.z() <= 0) fail(path, "volcl:dims metadata is not positive");
        box = openvdb::CoordBBox(openvdb::Coord(m.x(), m.y(), m.z()),
                                 openvdb::Coord(m.x() + d.x() - 1, m.y() + d.y() - 1, m.z() + d.z() - 1));
        if (!active.empty() && !box.isInside(active))
            fail(path, "active voxels lie outside the box recorded in volcl:dims");
    } else {
        box = active;
        if (box.empty()) unsupported(path, "grid '" + base->getName() + "' has no active voxels");
    }

    Volume dense;
    if (auto fg = openvdb::gridPtrCast<openvdb::FloatGrid>(base))
        dense = densify(*fg, box, path, options.memoryBudget);
    else if (auto dg = openvdb::gridPtrCast<openvdb::DoubleGrid>(base))
        dense = densify(*dg, box, path, options.memoryBudget);
    else
        unsupported(path, describeGrid(*base));

    const openvdb::Vec3d vs = xform.voxelSize();
    const openvdb::Vec3d o = xform.indexToWorld(box.min());
    for (int a = 0; a < 3; ++a) {
        dense.spacing[a] = vs[a] > 0 && std::isfinite(vs[a]) ? vs[a] : 1.0;
        dense.origin[a] = std::isfinite(o[a]) ? o[a] : 0.0;
    }
    // The transform may hold spacing/origin in single precision; our files also keep the exact doubles.
    if (const auto sp = base->getMetadata<openvdb::Vec3DMetadata>("volcl:spacing"); sp && dimsMeta) {
        for (int a = 0; a < 3; ++a)
            if (std::abs(sp->value()[a] - dense.spacing[a]) <= 1e-6 * std::abs(dense.spacing[a]))
                dense.spacing[a] = sp->value()[a];
    }
    if (const auto og = base->getMetadata<openvdb::Vec3DMetadata>("volcl:origin"); og && dimsMeta) {
        for (int a = 0; a < 3; ++a)
            if (std::abs(og->value()[a] - dense.origin[a]) <=
                1e-6 * (std::abs(dense.origin[a]) + dense.spacing[a]))
                dense.origin[a] = og->value()[a];
    }
    Volume result;
    const auto stored = storedTypeOf(*base);
    if (stored && *stored != ScalarType::Float32 && base->isType<openvdb::FloatGrid>()) {
        result = Volume(dense.dims(), *stored);
        switch (*stored) {
        case ScalarType::UInt8:
            restoreIntegers<std::uint8_t>(dense, result, path);
            break;
        case ScalarType::UInt16:
            restoreIntegers<std::uint16_t>(dense, result, path);
            break;
        case ScalarType::Int16:
            restoreIntegers<std::int16_t>(dense, result, path);
            break;
        case ScalarType::Float32:
        case ScalarType::Float64:
            break;
        }
        result.spacing = dense.spacing;
        result.origin = dense.origin;
    } else {
        result = std::move(dense);
    }
    TimeSeries series;
    series.frames.push_back(std::move(result));
    return series;
}

// What io::File::write does (a seekable archive: grid offsets for random access), into a stream volcl owns.
class CheckedArchive : public openvdb::io::Archive {
public:
    void writeTo(std::ostream& os, const openvdb::GridCPtrVec& grids) const {
        Archive::write(os, grids, /*seekable=*/true);
    }
};

void write(const Volume& volume, const fs::path& path, const WriteOptions& options) {
    initOpenVdb();
    const Dims& d = volume.dims();
    constexpr std::size_t kMaxCoord = static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max());
    if (d.x > kMaxCoord || d.y > kMaxCoord || d.z > kMaxCoord)
        throw UsageError(path.string() + ": volume too large for OpenVDB coordinates");
    auto grid = openvdb::FloatGrid::create(0.0f);
    grid->setName("density");
    grid->setGridClass(openvdb::GRID_FOG_VOLUME);
    openvdb::math::Mat4d m = openvdb::math::Mat4d::identity();
    m.setToScale(openvdb::Vec3d(volume.spacing[0], volume.spacing[1], volume.spacing[2]));
    m.setTranslation(openvdb::Vec3d(volume.origin[0], volume.origin[1], volume.origin[2]));
    grid->setTransform(openvdb::math::Transform::createLinearTransform(m));
    {
        const bool isFloat = volume.type() == ScalarType::Float32;
        const std::span<const float> floats = isFloat ? volume.values<float>() : std::span<const float>();
        auto acc = grid->getAccessor();
        for (std::size_t k = 0; k < d.z; ++k)
            for (std::size_t j = 0; j < d.y; ++j)
                for (std::size_t i = 0; i < d.x; ++i) {
                    const std::size_t n = volume.index(i, j, k);
                    const float value = isFloat ? floats[n] : static_cast<float>(volume.valueAt(n));
                    // Only +0.0 is left as background; -0.0 and NaN are stored so floats come back bit-exact.
                    if (std::bit_cast<std::uint32_t>(value) == 0u) continue;
                    acc.setValueOn(
                        openvdb::Coord(static_cast<int>(i), static_cast<int>(j), static_cast<int>(k)), value);
                }
    }
    grid->insertMeta("volcl:type", openvdb::StringMetadata(std::string(scalarTypeName(volume.type()))));
    grid->insertMeta("volcl:dims", openvdb::Vec3IMetadata(openvdb::Vec3i(
                                       static_cast<int>(d.x), static_cast<int>(d.y), static_cast<int>(d.z))));
    grid->insertMeta("volcl:indexMin", openvdb::Vec3IMetadata(openvdb::Vec3i(0, 0, 0)));
    grid->insertMeta("volcl:spacing", openvdb::Vec3DMetadata(openvdb::Vec3d(
                                          volume.spacing[0], volume.spacing[1], volume.spacing[2])));
    grid->insertMeta("volcl:origin", openvdb::Vec3DMetadata(openvdb::Vec3d(volume.origin[0], volume.origin[1],
                                                                           volume.origin[2])));

    AtomicFile out(path);
    try {
        // io::File::write writes through its own std::ofstream and never checks it (a full disk gave a
        // truncated file and success); the same archive goes to AtomicFile's stream, whose every write,
        // flush and size the commit checks.
        CheckedArchive archive;
        std::uint32_t compression = openvdb::io::COMPRESS_NONE;
        if (options.compress)
            compression = openvdb::io::COMPRESS_ACTIVE_MASK |
                          (openvdb::io::Archive::hasBloscCompression() ? openvdb::io::COMPRESS_BLOSC
                                                                       : openvdb::io::COMPRESS_ZIP);
        archive.setCompression(compression);
        archive.writeTo(out.stream(), openvdb::GridCPtrVec{grid});
    } catch (const openvdb::Exception& e) {
        throw IoError(path.string() + ": OpenVDB cannot write it: " + e.what());
    }
    out.commit();
}

const VdbModule kModule{readDense, write};

} // namespace
} // namespace volcl::io

// Returns const void*, the type loadRuntimeModule calls it through (see volcl_oiio_module).
extern "C" __attribute__((visibility("default"))) const void* volcl_vdb_module() {
    return &volcl::io::kModule;
}
