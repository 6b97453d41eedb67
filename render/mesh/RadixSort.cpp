// Radix sort: the C++ reference and the launches of the device passes.
#include "render/mesh/RadixSort.hpp"

#include "core/Error.hpp"

#include <array>
#include <utility>

namespace volcl {

void radixSortReference(std::vector<std::uint32_t>& keys, std::vector<std::uint32_t>& values) {
    if (keys.size() != values.size()) throw Error("internal: radix sort needs as many values as keys");
    std::vector<std::uint32_t> k2(keys.size()), v2(values.size());
    for (unsigned shift = 0; shift < 32; shift += 8) {
        std::array<std::size_t, 257> start{};
        for (std::uint32_t k : keys)
            ++start[((k >> shift) & 255u) + 1];
        for (std::size_t d = 1; d < start.size(); ++d)
            start[d] += start[d - 1];
        for (std::size_t i = 0; i < keys.size(); ++i) {
            const std::size_t pos = start[(keys[i] >> shift) & 255u]++;
            k2[pos] = keys[i];
            v2[pos] = values[i];
        }
        keys.swap(k2);
        values.swap(v2);
    }
}

DeviceRadixSort::DeviceRadixSort(ComputeContext& cc) : cc_(cc) {
    const std::size_t blocks = cc_.profile().mesh.radixBlocks;
    KernelDefines d;
    d.set("RADIX_BLOCKS", blocks);
    histogram_ = cc_.kernel("mesh/radix_sort.cl", "radix_histogram", d);
    scan_ = cc_.kernel("mesh/radix_sort.cl", "exclusive_scan", d);
    scatter_ = cc_.kernel("mesh/radix_sort.cl", "radix_scatter", d);
    hist_ = cc_.allocate<cl_uint>(256 * blocks);
    total_ = cc_.allocate<cl_uint>(1);
}

void DeviceRadixSort::sort(DeviceBuffer<cl_uint>& keys, DeviceBuffer<cl_uint>& values, std::size_t n) {
    lastMs_ = 0.0;
    if (n <= 1) return;
    if (n > keys.size() || n > values.size())
        throw Error("internal: radix sort of more entries than the buffers hold");
    if (n > 0xFFFFFFFFu) throw DataError("radix sort: at most 2^32 - 1 keys");
    if (keysAux_.size() < n) {
        keysAux_ = cc_.allocate<cl_uint>(n);
        valuesAux_ = cc_.allocate<cl_uint>(n);
    }
    DeviceBuffer<cl_uint>*kIn = &keys, *vIn = &values, *kOut = &keysAux_, *vOut = &valuesAux_;
    const cl_uint count = static_cast<cl_uint>(n);
    const std::size_t blocks = cc_.profile().mesh.radixBlocks, local = cc_.profile().mesh.radixLocal;
    for (cl_uint shift = 0; shift < 32; shift += 8) {
        setArgs(histogram_, *kIn, count, shift, hist_);
        lastMs_ += eventMilliseconds(cc_.launch1d(histogram_, blocks, local));
        setArgs(scan_, hist_, cl_uint(256 * blocks), total_);
        lastMs_ += eventMilliseconds(cc_.launch1d(scan_, 1, 1));
        setArgs(scatter_, *kIn, *vIn, *kOut, *vOut, count, shift, hist_);
        lastMs_ += eventMilliseconds(cc_.launch1d(scatter_, blocks, local));
        std::swap(kIn, kOut);
        std::swap(vIn, vOut);
    }
    // Four passes: the result is back in `keys` and `values`.
}

} // namespace volcl
