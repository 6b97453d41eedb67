// The set-partitioning section encoder (model and layout in SpeckModel.hpp).
#include "wavelet/entropy/SpeckModel.hpp"

#include "wavelet/entropy/BitIo.hpp"
#include "wavelet/entropy/DenseModel.hpp"

namespace volcl::entropy {

namespace {

class SpeckEncoder {
public:
    SpeckEncoder(const std::int32_t* c, Dims brick) : c_(c), pitch_(brick.x), slice_(brick.x * brick.y) {}

    /// Codes the members of a set of bit length `top` >= 1 whose own bit lengths are `bits`.
    void members(const SpeckSet* sets, const int* bits, int n, int top) {
        int atTop = 0;
        for (int i = 0; i < n; ++i) {
            const int b = bits[i];
            const int size = speckSizeClass(sets[i].count());
            if (i + 1 < n || atTop > 0) // else the last member must reach `top`: implied
                for (int plane = top - 1;; --plane) {
                    const unsigned significant = b > plane ? 1u : 0u;
                    emit(m_.significance[speckContext(size, top - 1 - plane, atTop)], significant);
                    if (significant || plane == 0) break;
                }
            descend(*this, sets[i], b, top, atTop);
        }
    }

    /// Codes the children of a set of bit length `top` >= 1 with more than one coefficient.
    void children(const SpeckSet& s, int top) {
        SpeckSet kids[8];
        int slot[8];
        const int n = splitSet(s, kids, slot);
        // One scan of the parent gives every child's magnitude OR (its bit length).
        std::uint32_t ors[8] = {};
        const std::uint32_t hx = (s.nx + 1) / 2, hy = (s.ny + 1) / 2, hz = (s.nz + 1) / 2;
        for (std::uint32_t z = 0; z < s.nz; ++z)
            for (std::uint32_t y = 0; y < s.ny; ++y) {
                const std::int32_t* row = c_ + (s.x0 + pitch_ * (s.y0 + y) + slice_ * (s.z0 + z));
                std::uint32_t low = 0, high = 0;
                for (std::uint32_t x = 0; x < hx; ++x)
                    low |= magnitude(row[x]);
                for (std::uint32_t x = hx; x < s.nx; ++x)
                    high |= magnitude(row[x]);
                const int o = (s.ny > 1 && y >= hy ? 2 : 0) + (s.nz > 1 && z >= hz ? 4 : 0);
                ors[o] |= low;
                ors[o + 1] |= high;
            }
        int bits[8];
        for (int i = 0; i < n; ++i)
            bits[i] = std::bit_width(ors[slot[i]]);
        members(kids, bits, n, top);
    }

    void coefficient(const SpeckSet& s, int b) {
        const std::int32_t v = c_[s.x0 + pitch_ * s.y0 + slice_ * s.z0];
        emit(m_.sign, v < 0 ? 1u : 0u);
        const std::uint32_t u = magnitude(v);
        for (int k = b - 2; k >= 0; --k)
            emit(m_.refine[std::min(b - 2 - k, kSpeckRefineContexts - 1)], (u >> k) & 1u);
    }

    std::vector<RansEvent> events;

private:
    void emit(BitModel& m, unsigned bit) { events.push_back(binaryEvent(m, bit, 0)); }

    const std::int32_t* c_;
    std::size_t pitch_, slice_;
    SpeckModels m_;
};

} // namespace

void encodeSpeck(std::span<const std::int32_t> coeffs, Dims brick, const std::vector<SubbandBox>& bands,
                 std::vector<std::uint8_t>& out) {
    SpeckEncoder enc(coeffs.data(), brick);
    std::vector<SpeckSet> sets;
    std::vector<int> bits;
    std::uint32_t all = 0;
    for (const SubbandBox& b : bands) {
        std::uint32_t o = 0;
        for (std::size_t z = b.z0; z < b.z1; ++z)
            for (std::size_t y = b.y0; y < b.y1; ++y) {
                const std::int32_t* row = coeffs.data() + brick.x * (y + brick.y * z);
                for (std::size_t x = b.x0; x < b.x1; ++x)
                    o |= magnitude(row[x]);
            }
        if (o >> kMaxBitLength) throw Error("internal: wavelet coefficient magnitude out of range");
        sets.push_back(setOf(b));
        bits.push_back(std::bit_width(o));
        all |= o;
    }
    const int top = std::bit_width(all);
    out.push_back(static_cast<std::uint8_t>(top));
    if (top == 0) return;
    enc.members(sets.data(), bits.data(), static_cast<int>(sets.size()), top);
    ransEncode(enc.events, 1, nullptr, out);
}

} // namespace volcl::entropy
