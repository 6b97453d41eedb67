// Light volumes for compressed bricks: the level a .vcz's light volume reads its extinction at, its device memory
// against render.cache_mb, and the field itself, a pool holding every brick of the frame at that level.
#pragma once

#include "core/runtime/ClRuntime.hpp"
#include "wavelet/container/VczFormat.hpp"

#include <cstddef>
#include <string>
#include <vector>

namespace volcl {

class Volume;
class VczReader;

/// How a .vcz's light volumes are built. A light volume needs extinction only at its own node spacing, so its
/// field is every brick decoded at `level`, the coarsest with 2^level <= cell (bricks holding NaN/Inf at level 0,
/// as the view's pool keeps them). Every brick, not only the view's working set: bricks outside the view cast
/// shadows into it. Device memory: the field (one float per level-`level` sample: at most 8x one light's volume,
/// its size when the cell is a power of two) plus the volumes (one float per node per light).
struct BrickLightPlan {
    int cell = 1;                 ///< the cell built: the scene's, or coarser when that exceeds the budget
    int level = 0;                ///< the level the field is decoded at
    std::size_t fieldFloats = 0;  ///< the field's pool: header, page table and samples
    std::size_t volumeFloats = 0; ///< every light's volume
    int askedCell = 1;            ///< effects.light_volume_cell
    /// The --explain wording after the cell: ", from the bricks at level 1, 3.2 MB" and, when coarsened, why.
    std::string how() const;
};

/// The plan for `lights` lights and the scene's `cell` within `budgetBytes` (render.cache_mb): the cell doubles
/// until field and volumes fit. `maxLevel`: the frame's coarsest decodable level (0 for P/B frames and raw
/// bits). Throws UsageError naming `file` when even 64-voxel cells do not fit.
BrickLightPlan planBrickLightVolume(const VczHeader& h, int maxLevel, const std::vector<char>& nonFinite,
                                    int cell, std::size_t lights, double budgetBytes,
                                    const std::string& file);

/// The pool format's first words (cl/common/brick_sample.h): the header (brick size, brick grid) and one page
/// entry per brick, each absent with its stand-in value `standIn[b]` until a slot is written into it.
std::vector<float> brickPageTable(const VczHeader& h, const std::vector<float>& standIn);
/// A page-table level meaning "not decoded" (VOLCL_BRICK_ABSENT in cl/common/brick_sample.h).
inline constexpr std::uint32_t kBrickAbsent = 0xffffffffu;
/// A page-table word: `v`'s bits as a float (the pool is a float buffer).
float brickPageWord(std::uint32_t v);

/// The light volumes' field of `frame`: every brick at `plan.level` (NaN/Inf bricks at 0) in one pool buffer
/// read by cl/render/light_volume_bricks.cl. `whole`: the frame decoded whole (P/B frames), else null. Throws
/// IoError for a corrupted brick (naming it).
DeviceBuffer<float> buildBrickLightField(ComputeContext& cc, const VczReader& reader, std::size_t frame,
                                         const Volume* whole, const BrickLightPlan& plan,
                                         const std::vector<char>& nonFinite);

} // namespace volcl
