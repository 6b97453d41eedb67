// Light volumes for compressed bricks: the plan (level, cell, memory against the budget) and the field's pool.
#include "render/bricks/BrickLightField.hpp"

#include "core/Error.hpp"
#include "core/Format.hpp"
#include "core/Volume.hpp"
#include "render/bricks/BrickLod.hpp"
#include "render/grid/LightVolume.hpp"
#include "wavelet/Codec.hpp"

#include <algorithm>
#include <cstring>

namespace volcl {
namespace {

constexpr std::size_t kHeaderWords = 16; // VOLCL_BRICK_HEADER in cl/common/brick_sample.h

std::string megabytes(std::size_t floats) {
    return formatNumber(double(floats) * sizeof(float) / (1024.0 * 1024.0), 3) + " MB";
}

/// Field and volumes of `cell` (level: the coarsest with 2^level <= cell, at most maxLevel).
BrickLightPlan sized(const VczHeader& h, int maxLevel, const std::vector<char>& nonFinite, int cell,
                     std::size_t lights) {
    BrickLightPlan p;
    p.cell = cell;
    while (p.level < maxLevel && (2 << p.level) <= cell)
        ++p.level;
    p.fieldFloats = kHeaderWords + 4 * h.brickCount();
    for (std::size_t b = 0; b < h.brickCount(); ++b)
        p.fieldFloats += brickSamples(h, b, nonFinite[b] ? 0 : p.level).count();
    const VolclLightVolumeParams lv = lightVolumeGeometry({h.dims.x, h.dims.y, h.dims.z}, cell, lights);
    p.volumeFloats = std::size_t(lv.dims[3]) * lights;
    return p;
}

} // namespace

std::string BrickLightPlan::how() const {
    std::string s = ", extinction from the bricks at level " + std::to_string(level) + ", " +
                    megabytes(fieldFloats + volumeFloats);
    if (cell != askedCell)
        s += "; coarsened from " + std::to_string(askedCell) + "-voxel cells to fit render.cache_mb";
    return s;
}

BrickLightPlan planBrickLightVolume(const VczHeader& h, int maxLevel, const std::vector<char>& nonFinite,
                                    int cell, std::size_t lights, double budgetBytes,
                                    const std::string& file) {
    lights = std::max<std::size_t>(lights, 1);
    std::string first;
    for (int c = cell;; c *= 2) {
        const int tried = std::min(c, 64);
        std::size_t floats = 0;
        BrickLightPlan p;
        try {
            p = sized(h, maxLevel, nonFinite, tried, lights);
            floats = p.fieldFloats + p.volumeFloats;
        } catch (const DataError&) { // more than 2^32 nodes: larger than any budget
            floats = std::size_t(-1) / sizeof(float);
        }
        if (first.empty())
            first = floats == std::size_t(-1) / sizeof(float) ? "over 16 GiB" : megabytes(floats);
        if (double(floats) * sizeof(float) <= budgetBytes) {
            p.askedCell = cell;
            return p;
        }
        if (tried == 64)
            throw UsageError(file + ": light-volume shadows need " + first + " at " + std::to_string(cell) +
                             "-voxel cells and more than render.cache_mb " +
                             formatNumber(budgetBytes / (1024.0 * 1024.0)) +
                             " MB even at 64 (raise render.cache_mb or use effects.shadow_method rays)");
    }
}

float brickPageWord(std::uint32_t v) {
    float f;
    std::memcpy(&f, &v, 4);
    return f;
}

std::vector<float> brickPageTable(const VczHeader& h, const std::vector<float>& standIn) {
    std::vector<float> page(kHeaderWords + 4 * h.brickCount(), 0.0f);
    const Dims g = h.brickGrid();
    const std::uint32_t head[6] = {std::uint32_t(h.brick.x), std::uint32_t(h.brick.y),
                                   std::uint32_t(h.brick.z), std::uint32_t(g.x),
                                   std::uint32_t(g.y),       std::uint32_t(g.z)};
    for (std::size_t i = 0; i < 6; ++i)
        page[i] = brickPageWord(head[i]);
    for (std::size_t b = 0; b < h.brickCount(); ++b) {
        page[kHeaderWords + 4 * b + 0] = brickPageWord(0);
        page[kHeaderWords + 4 * b + 1] = brickPageWord(kBrickAbsent);
        page[kHeaderWords + 4 * b + 2] = standIn[b];
    }
    return page;
}

DeviceBuffer<float> buildBrickLightField(ComputeContext& cc, const VczReader& reader, std::size_t frame,
                                         const Volume* whole, const BrickLightPlan& plan,
                                         const std::vector<char>& nonFinite) {
    const VczHeader& h = reader.header();
    std::vector<float> pool = brickPageTable(h, std::vector<float>(h.brickCount(), 0.0f));
    pool.reserve(plan.fieldFloats);
    for (std::size_t b = 0; b < h.brickCount(); ++b) {
        const int level = nonFinite[b] ? 0 : plan.level;
        Volume v;
        if (whole) {
            const Dims o = h.brickOrigin(b), d = h.brickDims(b);
            v = whole->cropped(o, {o.x + d.x, o.y + d.y, o.z + d.z});
        } else {
            v = reader.decodeBrick(cc, frame, b, level);
        }
        const std::vector<float> samples = v.toFloat();
        if (samples.size() != brickSamples(h, b, level).count())
            throw Error("internal: decoded brick has an unexpected size");
        pool[kHeaderWords + 4 * b + 0] = brickPageWord(std::uint32_t(pool.size()));
        pool[kHeaderWords + 4 * b + 1] = brickPageWord(std::uint32_t(level));
        pool.insert(pool.end(), samples.begin(), samples.end());
    }
    if (pool.size() >= (std::size_t(1) << 32))
        throw UsageError(reader.name() +
                         ": the light volumes' field exceeds the 16 GiB a page table addresses");
    return cc.upload(pool, CL_MEM_READ_ONLY);
}

} // namespace volcl
