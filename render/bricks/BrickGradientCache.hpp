// The gradient cache of the brick pool: which resident bricks' words are stale, their rebuild on the device, and
// the words' C++ reference.
#pragma once

#include "cl/volcl_shared.h"
#include "core/Volume.hpp"
#include "core/runtime/ClRuntime.hpp"

#include <cstddef>
#include <cstdint>
#include <vector>

namespace volcl {

struct VczHeader;

/// Keeps the gradient words of the pool's resident bricks (cl/common/brick_gradient_cache.h) in step with the
/// page table. A brick's words depend on its own samples and, through the central differences on its faces,
/// on the node values of its six face neighbours (their level, or their stand-in when absent). Each frame,
/// after the page table is written, refresh() rebuilds the words of every brick that was decoded or moved
/// this frame and of every brick whose face neighbours changed level or residency since its words were built
/// (one launch for all of them).
class BrickGradientCache {
public:
    /// Forgets every built brick (a new pool).
    void reset() { signature_.clear(); }
    /// Marks the bricks with `fresh[b]` as not built (their samples were written in a frame without the cache).
    void forget(const std::vector<char>& fresh);

    /// Rebuilds the stale words. `page`: the pool's header and page table as uploaded; `fresh[b]`: brick b's
    /// samples were written this frame (decoded or moved). Returns the kernel time in ms (0: nothing stale)
    /// and counts the rebuilt bricks in `rebuilt`.
    double refresh(ComputeContext& cc, const cl::Buffer& pool, const VczHeader& h,
                   const std::vector<float>& page, const std::vector<char>& fresh,
                   const VolclGridParams& grid, std::size_t& rebuilt);

private:
    std::vector<std::uint64_t> signature_; ///< per brick: what its words were built from (0: not built)
};

/// The words the device holds for brick b drawn at `level` (its samples' nodes o + 2^level i, x fastest):
/// central differences over 2^level nodes of `nodes`, the full-resolution node values of the whole frame as
/// drawn (brickNodeValues), packed against `gradientMax`.
std::vector<std::uint32_t> brickGradientReference(const Volume& nodes, const VczHeader& h, std::size_t b,
                                                  int level, float gradientMax);

} // namespace volcl
