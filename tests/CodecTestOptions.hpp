// Codec options the lossy codec tests share: a rate mode and target on small bricks (16 voxels, 3 levels),
// so small test volumes cross brick borders.
#pragma once

#include "wavelet/Codec.hpp"

namespace volcl::test {

inline CodecOptions smallBrickOptions(RateMode r, double target) {
    CodecOptions o;
    o.rate = r;
    o.target = target;
    o.brick = {16, 16, 16};
    o.levels = 3;
    return o;
}

} // namespace volcl::test
