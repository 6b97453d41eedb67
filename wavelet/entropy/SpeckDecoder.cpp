// The set-partitioning section decoder (model and layout in SpeckModel.hpp).
#include "wavelet/entropy/SpeckModel.hpp"

#include "wavelet/entropy/BitIo.hpp"
#include "wavelet/entropy/DenseModel.hpp"

namespace volcl::entropy {

namespace {

class SpeckDecoder {
public:
    SpeckDecoder(std::int32_t* c, Dims brick, RansDecoder& rans)
        : c_(c), pitch_(brick.x), slice_(brick.x * brick.y), rans_(rans) {}

    /// Decodes the members of a set of bit length `top` >= 1 (the mirror of SpeckEncoder::members).
    void members(const SpeckSet* sets, int n, int top) {
        int atTop = 0;
        for (int i = 0; i < n; ++i) {
            const int size = speckSizeClass(sets[i].count());
            int b = 0;
            if (i + 1 < n || atTop > 0) {
                for (int plane = top - 1;; --plane) {
                    if (read(m_.significance[speckContext(size, top - 1 - plane, atTop)])) {
                        b = plane + 1;
                        break;
                    }
                    if (plane == 0) break;
                }
            } else {
                b = top;
            }
            descend(*this, sets[i], b, top, atTop);
        }
    }

    void children(const SpeckSet& s, int top) {
        SpeckSet kids[8];
        int slot[8];
        const int n = splitSet(s, kids, slot);
        members(kids, n, top);
    }

    void coefficient(const SpeckSet& s, int b) {
        const unsigned negative = read(m_.sign);
        std::uint32_t u = 1;
        for (int k = b - 2; k >= 0; --k)
            u = u << 1 | read(m_.refine[std::min(b - 2 - k, kSpeckRefineContexts - 1)]);
        const auto v = static_cast<std::int32_t>(u); // b <= 30: below 2^30
        c_[s.x0 + pitch_ * s.y0 + slice_ * s.z0] = negative ? -v : v;
    }

private:
    unsigned read(BitModel& m) { return rans_.in.bit(rans_.x[0], m); }

    std::int32_t* c_;
    std::size_t pitch_, slice_;
    RansDecoder& rans_;
    SpeckModels m_;
};

} // namespace

void decodeSpeck(std::span<const std::uint8_t> in, std::span<std::int32_t> coeffs, Dims brick,
                 const std::vector<SubbandBox>& bands, const char* what) {
    if (in.empty()) corrupt(what, "empty set-partitioning section");
    const int top = in[0];
    if (top > kMaxBitLength) corrupt(what, "set-partitioning section magnitude out of range");
    // Insignificant sets are never visited: their coefficients are zero.
    for (const SubbandBox& b : bands)
        for (std::size_t z = b.z0; z < b.z1; ++z)
            for (std::size_t y = b.y0; y < b.y1; ++y) {
                std::int32_t* row = coeffs.data() + brick.x * (y + brick.y * z);
                std::fill(row + b.x0, row + b.x1, 0);
            }
    if (top == 0) {
        if (in.size() != 1) corrupt(what, "unexpected bytes after an all-zero set-partitioning section");
        return;
    }
    const auto stream = in.subspan(1);
    const std::vector<std::uint8_t> bytes = RansDecoder::padded(stream);
    RansDecoder rans(bytes, stream.size(), 1);
    std::vector<SpeckSet> sets;
    for (const SubbandBox& b : bands)
        sets.push_back(setOf(b));
    SpeckDecoder dec(coeffs.data(), brick, rans);
    dec.members(sets.data(), static_cast<int>(sets.size()), top);
    if (!rans.exact()) corrupt(what, "set-partitioning stream does not end where its decisions do");
}

} // namespace volcl::entropy
