// Entropy coding of coefficient sections: the subband layout and the dispatch to the dense and fast coders.
//
// Dense mode is a hand-written rANS coder (one 32-bit state per subband of a section, up to 7, sharing one
// stream of 16-bit words) because the ratio comes from the coefficient model and no Debian library takes
// caller-defined contexts: zstd, xz and brotli model bytes, libzstd's FSE/huff0 are not public API, and
// htscodecs' rANS (libhtscodecs-dev) has order-0/1 byte models only. The model mixes two kinds of decisions
// in one stream: magnitude symbols from static per-section tables (chosen by a context of neighbour and
// parent magnitudes, tables sent with the section) and adaptive binary decisions (row "all zero" flags and
// signs, whose contexts are too many for sent tables). Fast mode uses libzstd.
#include "wavelet/entropy/EntropyCoder.hpp"

#include "wavelet/entropy/BitIo.hpp"
#include "wavelet/entropy/DenseModel.hpp"
#include "wavelet/entropy/FastCoder.hpp"
#include "wavelet/entropy/SpeckModel.hpp"
#include "wavelet/entropy/TestSwitches.hpp"

#include <atomic>

namespace volcl {

std::string_view entropyName(EntropyMode m) noexcept {
    switch (m) {
    case EntropyMode::Fast:
        return "fast";
    case EntropyMode::Dense:
        return "dense";
    }
    return "unknown";
}

EntropyMode parseEntropy(std::string_view name) {
    for (EntropyMode m : {EntropyMode::Fast, EntropyMode::Dense})
        if (name == entropyName(m)) return m;
    throw UsageError("unknown entropy coder '" + std::string(name) + "' (use fast or dense)");
}

namespace entropy {
namespace {
std::atomic<bool> gSetPartitioning{true}; // a test and measurement switch (TestSwitches.hpp)
} // namespace
void corrupt(const char* what, const char* why) {
    throw IoError(std::string(what) + ": " + why + " (corrupted data)");
}
} // namespace entropy

void setSetPartitioningEnabled(bool on) noexcept {
    entropy::gSetPartitioning.store(on, std::memory_order_relaxed);
}
bool setPartitioningEnabled() noexcept {
    return entropy::gSetPartitioning.load(std::memory_order_relaxed);
}

std::vector<std::vector<SubbandBox>> sectionLayout(Dims brick, int levels) {
    std::vector<std::vector<SubbandBox>> layout(static_cast<std::size_t>(levels) + 1);
    const Dims low = [&] {
        auto shrink = [levels](std::size_t n) { return ((n - 1) >> levels) + 1; };
        return Dims{shrink(brick.x), shrink(brick.y), shrink(brick.z)};
    }();
    layout[0].push_back({0, low.x, 0, low.y, 0, low.z, 0, 0});
    for (int l = levels; l >= 1; --l) {
        auto shrink = [](std::size_t n, int k) { return ((n - 1) >> k) + 1; };
        const Dims p{shrink(brick.x, l - 1), shrink(brick.y, l - 1), shrink(brick.z, l - 1)};
        const Dims q{shrink(brick.x, l), shrink(brick.y, l), shrink(brick.z, l)};
        auto& sec = layout[static_cast<std::size_t>(levels - l + 1)];
        for (int o = 1; o < 8; ++o) {
            SubbandBox b;
            b.level = l;
            b.orient = o;
            b.x0 = (o & 1) ? q.x : 0;
            b.x1 = (o & 1) ? p.x : q.x;
            b.y0 = (o & 2) ? q.y : 0;
            b.y1 = (o & 2) ? p.y : q.y;
            b.z0 = (o & 4) ? q.z : 0;
            b.z1 = (o & 4) ? p.z : q.z;
            if (b.count() > 0) sec.push_back(b);
        }
    }
    return layout;
}

void encodeSection(std::span<const std::int32_t> coeffs, Dims brick,
                   const std::vector<std::vector<SubbandBox>>& layout, std::size_t s, EntropyMode mode,
                   std::vector<std::uint8_t>& out) {
    std::size_t count = 0;
    for (const SubbandBox& b : layout[s])
        count += b.count();
    if (count == 0) return;
    if (mode == EntropyMode::Dense) {
        entropy::encodeDense(coeffs, brick, layout, s, out);
    } else {
        entropy::encodeFast(coeffs, layout[s], brick, out);
    }
}

bool encodeSectionSmallest(std::span<const std::int32_t> coeffs, Dims brick,
                           const std::vector<std::vector<SubbandBox>>& layout, std::size_t s,
                           EntropyMode mode, std::vector<std::uint8_t>& out) {
    const std::size_t start = out.size();
    encodeSection(coeffs, brick, layout, s, mode, out);
    std::size_t count = 0;
    for (const SubbandBox& b : layout[s])
        count += b.count();
    const std::size_t dense = out.size() - start;
    if (mode != EntropyMode::Dense || count == 0 || !setPartitioningEnabled() ||
        double(dense) * 8.0 >= entropy::kSpeckTryBitsPerCoefficient * double(count))
        return false;
    std::vector<std::uint8_t> speck;
    entropy::encodeSpeck(coeffs, brick, layout[s], speck);
    if (speck.size() >= dense) return false;
    out.resize(start);
    out.insert(out.end(), speck.begin(), speck.end());
    return true;
}

void decodeSection(std::span<const std::uint8_t> in, std::span<std::int32_t> coeffs, Dims brick,
                   const std::vector<std::vector<SubbandBox>>& layout, std::size_t s, EntropyMode mode,
                   const char* what, bool setPartitioned) {
    std::size_t count = 0;
    for (const SubbandBox& b : layout[s])
        count += b.count();
    if (count == 0) {
        if (!in.empty()) entropy::corrupt(what, "unexpected data in an empty section");
        return;
    }
    if (setPartitioned) {
        if (mode != EntropyMode::Dense) entropy::corrupt(what, "set-partitioned section in a fast-mode file");
        entropy::decodeSpeck(in, coeffs, brick, layout[s], what);
    } else if (mode == EntropyMode::Dense) {
        entropy::decodeDense(in, coeffs, brick, layout, s, what);
    } else {
        entropy::decodeFast(in, coeffs, layout[s], brick, what, nullptr);
    }
}

void decodeSections(std::span<const std::span<const std::uint8_t>> sections, std::span<std::int32_t> coeffs,
                    Dims brick, const std::vector<std::vector<SubbandBox>>& layout, EntropyMode mode,
                    const char* what, const Dequantiser* dq, std::uint32_t setPartitioned) {
    for (std::size_t s = 0; s < sections.size(); ++s) {
        if (mode == EntropyMode::Fast && !(setPartitioned >> s & 1u))
            entropy::decodeFast(sections[s], coeffs, layout[s], brick, what,
                                dq); // checks empty sections itself
        else
            decodeSection(sections[s], coeffs, brick, layout, s, mode, what, setPartitioned >> s & 1u);
    }
    if (dq && mode == EntropyMode::Dense)
        for (std::size_t s = 0; s < sections.size(); ++s)
            entropy::forEachSectionRow(coeffs.data(), layout[s], brick,
                                       [&](std::int32_t* row, std::size_t len, const SubbandBox& b) {
                                           dequantiseRow(row, reinterpret_cast<float*>(row), len, dq->step(b),
                                                         dq->bias);
                                       });
}

} // namespace volcl
