// The brick pool's gradient words: staleness by face-neighbour signatures, the rebuild launch, the reference.
#include "render/bricks/BrickGradientCache.hpp"

#include "render/bricks/BrickLod.hpp"
#include "render/grid/GradientCache.hpp"
#include "wavelet/container/VczFormat.hpp"

#include <array>
#include <cstring>

namespace volcl {
namespace {

constexpr std::size_t kHeaderWords = 16; // VOLCL_BRICK_HEADER in cl/common/brick_sample.h

std::uint32_t floatBits(float f) {
    std::uint32_t u;
    std::memcpy(&u, &f, 4);
    return u;
}

/// FNV-1a over 32-bit words.
struct Fnv {
    std::uint64_t h = 1469598103934665603ull;
    void add(std::uint32_t w) {
        for (int i = 0; i < 4; ++i) {
            h ^= (w >> (8 * i)) & 0xffu;
            h *= 1099511628211ull;
        }
    }
};

} // namespace

void BrickGradientCache::forget(const std::vector<char>& fresh) {
    for (std::size_t b = 0; b < signature_.size() && b < fresh.size(); ++b)
        if (fresh[b]) signature_[b] = 0;
}

double BrickGradientCache::refresh(ComputeContext& cc, const cl::Buffer& pool, const VczHeader& h,
                                   const std::vector<float>& page, const std::vector<char>& fresh,
                                   const VolclGridParams& grid, std::size_t& rebuilt) {
    const std::size_t n = h.brickCount();
    const Dims g = h.brickGrid();
    if (signature_.size() != n) signature_.assign(n, 0);
    auto entry = [&](std::size_t b, int word) {
        return floatBits(page[kHeaderWords + 4 * b + std::size_t(word)]);
    };
    std::vector<cl_uint> stale;
    for (std::size_t b = 0; b < n; ++b) {
        if (entry(b, 1) == 0xffffffffu) continue; // absent: no words
        // Its place and level, the scale, and each face neighbour's level (or stand-in when absent).
        Fnv f;
        f.add(entry(b, 0));
        f.add(entry(b, 1));
        f.add(floatBits(grid.gradientMax));
        const std::array<std::size_t, 3> c{b % g.x, b / g.x % g.y, b / (g.x * g.y)};
        const std::array<std::size_t, 3> extent{g.x, g.y, g.z}, stride{1, g.x, g.x * g.y};
        for (std::size_t a = 0; a < 3; ++a)
            for (int side : {-1, 1}) {
                if ((side < 0 && c[a] == 0) || (side > 0 && c[a] + 1 >= extent[a])) {
                    f.add(0xfffffffeu); // the grid's face
                    continue;
                }
                const std::size_t nb = side < 0 ? b - stride[a] : b + stride[a];
                const std::uint32_t level = entry(nb, 1);
                f.add(level);
                if (level == 0xffffffffu) f.add(entry(nb, 2));
            }
        const std::uint64_t sig = f.h | 1u; // never 0 ("not built")
        if (fresh[b] || signature_[b] != sig) {
            stale.push_back(cl_uint(b));
            signature_[b] = sig;
        }
    }
    rebuilt = stale.size();
    if (stale.empty()) return 0.0;
    const DeviceBuffer<cl_uint> list = cc.upload(stale, CL_MEM_READ_ONLY);
    cl::Kernel k = cc.kernel("render/brick_gradient_cache.cl", "brick_gradient_build", KernelDefines{});
    setArgs(k, pool, grid, list, cl_uint(stale.size()));
    return eventMilliseconds(cc.launch2d(k, h.brick.count(), stale.size()));
}

std::vector<std::uint32_t> brickGradientReference(const Volume& nodes, const VczHeader& h, std::size_t b,
                                                  int level, float gradientMax) {
    const std::vector<float> v = nodes.toFloat();
    const std::array<float, 3> inv = {static_cast<float>(1.0 / h.spacing[0]),
                                      static_cast<float>(1.0 / h.spacing[1]),
                                      static_cast<float>(1.0 / h.spacing[2])};
    const Dims o = h.brickOrigin(b), m = brickSamples(h, b, level);
    std::vector<std::uint32_t> out;
    out.reserve(m.count());
    for (std::size_t k = 0; k < m.z; ++k)
        for (std::size_t j = 0; j < m.y; ++j)
            for (std::size_t i = 0; i < m.x; ++i)
                out.push_back(nodeGradientWord(v, nodes.dims(), inv, o.x + (i << level), o.y + (j << level),
                                               o.z + (k << level), gradientMax, std::size_t(1) << level));
    return out;
}

} // namespace volcl
