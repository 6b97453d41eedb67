// Codec options the lossy codec tests share: a rate mode and target on small bricks (16 voxels, 3 levels),
// so small test volumes cross brick borders; generated test volumes.
#pragma once

#include "wavelet/Codec.hpp"

#include <cmath>
#include <functional>
#include <random>

namespace volcl::test {

inline CodecOptions smallBrickOptions(RateMode r, double target) {
    CodecOptions o;
    o.rate = r;
    o.target = target;
    o.brick = {16, 16, 16};
    o.levels = 3;
    return o;
}

/// A volume of T (float or double) of dims `d` with voxel (x, y, z) = f(x, y, z, rng), rng seeded by `seed`.
template <class T>
Volume generatedVolume(Dims d,
                       const std::function<T(std::size_t, std::size_t, std::size_t, std::mt19937&)>& f,
                       unsigned seed) {
    Volume v(d, scalarTypeOf<T>());
    std::mt19937 rng(seed);
    auto s = v.values<T>();
    for (std::size_t z = 0; z < d.z; ++z)
        for (std::size_t y = 0; y < d.y; ++y)
            for (std::size_t x = 0; x < d.x; ++x)
                s[v.index(x, y, z)] = f(x, y, z, rng);
    return v;
}

/// A smooth field that crosses zero everywhere (the lossy codec tests' base).
inline double smoothWave(std::size_t x, std::size_t y, std::size_t z) {
    return std::sin(0.4 * double(x)) * std::cos(0.3 * double(y)) + 0.2 * std::sin(0.5 * double(z));
}

} // namespace volcl::test
