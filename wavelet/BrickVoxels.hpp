// Typed voxel access of the codec: dispatch on the scalar type, the reconstruction-to-voxel rounding, and
// copies between a volume's bricks and brick arrays or batch slots.
#pragma once

#include "core/Error.hpp"
#include "core/Volume.hpp"
#include "wavelet/container/VczFormat.hpp"

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <type_traits>
#include <utility>
#include <vector>

namespace volcl::codec {

// Calls fn with the volume's typed span.
template <class V, class Fn> decltype(auto) visitTyped(V& v, Fn fn) { // V: Volume or const Volume
    switch (v.type()) {
    case ScalarType::UInt8:
        return fn(v.template values<std::uint8_t>());
    case ScalarType::UInt16:
        return fn(v.template values<std::uint16_t>());
    case ScalarType::Int16:
        return fn(v.template values<std::int16_t>());
    case ScalarType::Float32:
        return fn(v.template values<float>());
    case ScalarType::Float64:
        break; // the wavelet stages take a float64 volume's float32 layer (wavelet/Float64Layer.hpp)
    }
    throw Error("internal: voxel type the wavelet stages do not take");
}

// Converts a reconstructed value to the voxel type: round to nearest (even) and clamp for integers.
// Without a libm call: clamping first is equivalent (the bounds are integers) and keeps |v| < 2^22, where
// adding and subtracting 1.5 * 2^23 rounds exactly like std::nearbyint. The encoder's error check and the
// decoder's output both use this, so the bound is checked on what the decoder writes. NaN (a forged
// quantisation step) becomes 0, as the kernels' to_voxel8 (cl/codec/motion.cl) gives it; std::clamp would pass it
// on to a float-to-int conversion, which is undefined for NaN.
template <class T> T toVoxel(float v) {
    if constexpr (std::is_same_v<T, float>) {
        return v;
    } else {
        const float c = v == v ? std::min(std::max(float(std::numeric_limits<T>::min()), v),
                                          float(std::numeric_limits<T>::max()))
                               : 0.0f;
        return static_cast<T>(static_cast<std::int32_t>((c + 12582912.0f) - 12582912.0f));
    }
}

// Rows of `pitch` elements (a batch slot) -> a dense brick array (brick dims, x fastest).
template <class T> std::vector<T> denseBrick(Dims d, const T* src, std::size_t pitch) {
    std::vector<T> dense(d.count());
    for (std::size_t r = 0; r < d.y * d.z; ++r)
        std::copy_n(src + r * pitch, d.x, dense.data() + r * d.x);
    return dense;
}

// Voxels of the box at origin `o`, dims `d` of the volume as T (dense, x fastest); floats convert to int32
// by their bit pattern.
template <class T> std::vector<T> regionVoxels(const Volume& v, Dims o, Dims d) {
    std::vector<T> out(d.count());
    visitTyped(v, [&](auto src) {
        for (std::size_t z = 0; z < d.z; ++z)
            for (std::size_t y = 0; y < d.y; ++y) {
                const std::size_t s = v.index(o.x, o.y + y, o.z + z);
                T* dst = out.data() + (z * d.y + y) * d.x;
                for (std::size_t x = 0; x < d.x; ++x) {
                    if constexpr (std::is_same_v<T, std::int32_t> &&
                                  std::is_same_v<typename decltype(src)::element_type, const float>) {
                        std::int32_t bits;
                        std::memcpy(&bits, &src[s + x], 4);
                        dst[x] = bits;
                    } else {
                        dst[x] = static_cast<T>(src[s + x]);
                    }
                }
            }
    });
    return out;
}

// Voxels of one brick of the volume as T (dense brick layout).
template <class T> std::vector<T> brickVoxels(const Volume& v, const VczHeader& h, std::size_t brick) {
    return regionVoxels<T>(v, h.brickOrigin(brick), h.brickDims(brick));
}

// Writes the voxels of one brick, converted to T, straight into a batch layout with row pitch `pitch`;
// returns the brick's voxel min and max (values convert exactly: integers to int32, up to 16 bits to float).
template <class T>
std::pair<double, double> gatherBrick(const Volume& v, const VczHeader& h, std::size_t brick, T* dst,
                                      std::size_t pitch) {
    const Dims o = h.brickOrigin(brick), d = h.brickDims(brick);
    return visitTyped(v, [&](auto src) {
        using S = std::remove_const_t<typename decltype(src)::element_type>;
        S lo = src[v.index(o.x, o.y, o.z)], hi = lo;
        for (std::size_t z = 0; z < d.z; ++z)
            for (std::size_t y = 0; y < d.y; ++y) {
                const S* in = src.data() + v.index(o.x, o.y + y, o.z + z);
                T* out = dst + (z * d.y + y) * pitch;
                for (std::size_t x = 0; x < d.x; ++x) {
                    const S s = in[x];
                    out[x] = static_cast<T>(s);
                    lo = s < lo ? s : lo; // value selects vectorise; std::min on references did not
                    hi = s > hi ? s : hi;
                }
            }
        return std::pair<double, double>(double(lo), double(hi));
    });
}

} // namespace volcl::codec
