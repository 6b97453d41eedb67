// Stable LSD radix sort of 32-bit keys with values: the device sort (cl/mesh/radix_sort.cl) and its C++ reference.
#pragma once

#include "core/runtime/ClRuntime.hpp"

#include <cstddef>
#include <cstdint>
#include <vector>

namespace volcl {

/// Float-to-key transform (Hacker's Delight, as in Callahan 2005): the IEEE bits XOR all-ones when the sign
/// is set, else XOR 0x80000000, so keys compare as unsigned integers in the order of the floats (-0 sorts
/// just before +0; NaN is not ordered).
inline std::uint32_t floatSortKey(float f) noexcept {
    std::uint32_t u;
    static_assert(sizeof(u) == sizeof(f));
    __builtin_memcpy(&u, &f, sizeof u);
    return u ^ ((u & 0x80000000u) ? 0xFFFFFFFFu : 0x80000000u);
}

/// Plain C++ LSD radix sort, 4 passes of 8-bit digits (counting sort each, ping-pong with an auxiliary
/// array): stable, so equal keys keep their input order. Sorts `values` along with `keys` (same size).
void radixSortReference(std::vector<std::uint32_t>& keys, std::vector<std::uint32_t>& values);

/// The device sort: per pass a histogram per block of keys, one exclusive scan over (digit, block) and a
/// stable scatter. Sorts the first n entries of two device buffers in place (through auxiliary buffers it
/// keeps between calls). Example:
/// ```
/// volcl::DeviceRadixSort sorter(cc);
/// sorter.sort(keys, values, n);      // keys ascending, values permuted alike, stable
/// ```
class DeviceRadixSort {
public:
    explicit DeviceRadixSort(ComputeContext& cc);
    void sort(DeviceBuffer<cl_uint>& keys, DeviceBuffer<cl_uint>& values, std::size_t n);
    /// Kernel time of the last sort (profiling events), milliseconds.
    double lastMilliseconds() const noexcept { return lastMs_; }

private:
    ComputeContext& cc_;
    cl::Kernel histogram_, scan_, scatter_;
    DeviceBuffer<cl_uint> keysAux_, valuesAux_, hist_, total_;
    double lastMs_ = 0.0;
};

} // namespace volcl
