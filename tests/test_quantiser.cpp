// The dead-zone quantiser: the plain floor, and the encoder's movable dead-zone edge (narrower keeps
// coefficients near one step as +-1, wider drops them), whatever the decoder reconstructs stays its rule.
#include "wavelet/quantise/Quantiser.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

using namespace volcl::codec;

namespace {

std::vector<std::int32_t> quantised(const std::vector<float>& in, double edge) {
    std::vector<std::int32_t> q(in.size());
    quantiseRow(in.data(), q.data(), in.size(), 0.5, edge);
    return q;
}

} // namespace

TEST(Quantiser, PlainEdgeIsTheFloor) {
    // In steps of 0.5: 0.2 -> 0.4 steps, 0.45 -> 0.9, 0.5 -> 1, 0.99 -> 1.98, 1.6 -> 3.2.
    const std::vector<float> in{0.0f, 0.2f, -0.45f, 0.5f, -0.99f, 1.6f};
    EXPECT_EQ(quantised(in, 1), (std::vector<std::int32_t>{0, 0, 0, 1, -1, 3}));
}

TEST(Quantiser, NarrowEdgeKeepsCoefficientsJustBelowOneStep) {
    const std::vector<float> in{0.2f, -0.45f, 0.37f, 0.5f, -0.99f, 1.6f};
    // 0.9 and 0.74 steps: only 0.9 reaches the 0.75 edge; larger magnitudes keep their floor.
    EXPECT_EQ(quantised(in, 0.75), (std::vector<std::int32_t>{0, -1, 0, 1, -1, 3}));
}

TEST(Quantiser, WideEdgeDropsSmallIndices) {
    const std::vector<float> in{0.45f, 0.5f, -0.99f, 1.2f, -1.6f};
    // Edge 2.5 steps: 0.9, 1, 1.98 and 2.4 steps code 0; 3.2 steps keeps its floor 3.
    EXPECT_EQ(quantised(in, 2.5), (std::vector<std::int32_t>{0, 0, 0, 0, -3}));
}
