// Symbol tables of the dense coder rebuilt from the quantised weights a section stores.
#include "wavelet/entropy/DenseModel.hpp"

namespace volcl::entropy {

bool buildTable(const std::array<std::uint8_t, kSymbols>& q, int nsym, SymbolTable& t) {
    std::uint64_t total = 0;
    for (int s = 0; s < nsym; ++s)
        if (q[static_cast<std::size_t>(s)]) total += weightOf(q[static_cast<std::size_t>(s)]);
    if (total == 0) return false;
    std::array<std::uint32_t, kSymbols> f{};
    std::uint32_t sum = 0;
    for (int s = 0; s < nsym; ++s) {
        const auto i = static_cast<std::size_t>(s);
        if (!q[i]) continue;
        f[i] = static_cast<std::uint32_t>(std::max<std::uint64_t>(1, weightOf(q[i]) * kTableScale / total));
        sum += f[i];
    }
    // Rounding leaves the sum a little off: the largest entries absorb the difference.
    while (sum != kTableScale) {
        const auto big = static_cast<std::size_t>(std::max_element(f.begin(), f.begin() + nsym) - f.begin());
        if (sum < kTableScale) {
            f[big] += kTableScale - sum;
            sum = kTableScale;
        } else {
            const std::uint32_t take = std::min(sum - kTableScale, f[big] - 1);
            f[big] -= take;
            sum -= take;
        }
    }
    std::uint32_t c = 0;
    for (std::size_t i = 0; i < kSymbols; ++i) {
        t.start[i] = static_cast<std::uint16_t>(c);
        t.freq[i] = static_cast<std::uint16_t>(f[i]);
        c += f[i];
    }
    return true;
}

} // namespace volcl::entropy
