// Motion-compensated prediction of P and B frames from reconstructed references, and its reconstruction.
#include "wavelet/predict/MotionPredictor.hpp"

#include "host/Error.hpp"
#include "wavelet/predict/Compensation.hpp"
#include "wavelet/predict/MotionVectorCoding.hpp"
#include "wavelet/predict/Residual.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdlib>
#include <optional>
#include <string>

namespace volcl::codec {

namespace {

const Volume& referenceAt(const ReferenceFrames& refs, std::int32_t index, const char* which) {
    if (index < 0 || std::size_t(index) >= refs.frames.size() || !refs.frames[std::size_t(index)])
        throw Error(std::string("internal: the ") + which + " reference frame is not reconstructed");
    return *refs.frames[std::size_t(index)];
}

// Estimated bits of coding a residual of energy `ssd` over `n` voxels with quantisation noise `noise` per
// voxel (high-rate Gaussian model; energy under the noise costs nearly nothing).
double residualBits(double ssd, double n, double noise) {
    return 0.5 * n * std::log2(1.0 + ssd / (n * noise));
}

// Side bits of a vector in the motion payload: about 1 bit for a zero component, else sign and magnitude.
double vectorBits(const MotionVector& v) {
    double bits = 0;
    for (int c : {int(v.x), int(v.y), int(v.z)})
        bits += c == 0 ? 1.0 : 3.0 + 2.0 * std::log2(double(std::abs(c)));
    return bits;
}

// The per-block mode decision by estimated coded size: residual bits of each mode's prediction plus the
// side bits it needs (the mode itself, vectors, a float32 intra value), so a vector or an intra block is
// kept only where it saves more residual bits than it costs. `step` is the voxel-domain quantiser step.
void chooseModesByRate(MotionField& field, const std::vector<ModeCosts>& costs, double step) {
    const double noise = step * step / 4;
    const Dims nb = field.grid.blocks();
    const std::size_t s = field.grid.size;
    for (std::size_t b = 0; b < field.modes.size(); ++b) {
        const std::size_t bx = b % nb.x, by = b / nb.x % nb.y, bz = b / (nb.x * nb.y);
        const double n =
            double(std::min(s, field.grid.volume.x - bx * s) * std::min(s, field.grid.volume.y - by * s) *
                   std::min(s, field.grid.volume.z - bz * s));
        const MotionVector fwd = field.forward[b];
        const MotionVector bwd = field.bidirectional() ? field.backward[b] : MotionVector{};
        double side[kBlockModeCount];
        side[int(BlockMode::Zero)] = 1;
        side[int(BlockMode::Forward)] = 2 + vectorBits(fwd);
        side[int(BlockMode::Backward)] = 3 + vectorBits(bwd);
        side[int(BlockMode::Bidirectional)] = 3 + vectorBits(fwd) + vectorBits(bwd);
        side[int(BlockMode::Intra)] = 3 + 32;
        ModeCosts bits;
        for (int m = 0; m < kBlockModeCount; ++m)
            bits[m] = std::isinf(costs[b][m]) ? costs[b][m] : residualBits(costs[b][m], n, noise) + side[m];
        field.modes[b] = cheapestMode(bits);
    }
}

class MotionPredictor final : public Predictor {
public:
    explicit MotionPredictor(const MotionSearchOptions& search) : search_(search) { validate(search_); }

    Prediction predict(ComputeContext& cc, const Volume& frame, std::size_t,
                       const ReferenceFrames& refs) override {
        const bool bidirectional = refs.reference1 >= 0;
        const Volume& r0 = referenceAt(refs, refs.reference0, "forward");
        const Volume* r1 = bidirectional ? &referenceAt(refs, refs.reference1, "backward") : nullptr;
        if (!estimator_) estimator_.emplace(cc, search_);
        if (!compensator_) compensator_.emplace(cc);
        const BlockGrid grid{frame.dims(), search_.blockSize};
        const MotionSearchResult fwd = estimator_->search(cc, frame, r0);
        std::optional<MotionSearchResult> bwd;
        if (r1) bwd = estimator_->search(cc, frame, *r1);
        ModeChoice choice;
        choice.backward = choice.bidirectional = bidirectional;
        std::vector<ModeCosts> costs;
        MotionField field = compensator_->decideModes(cc, frame, r0, r1, grid, fwd.vectors,
                                                      bwd ? &bwd->vectors : nullptr, choice, &costs);
        chooseModesByRate(field, costs, refs.step);
        Prediction p;
        p.type = bidirectional ? FrameType::B : FrameType::P;
        p.reference0 = refs.reference0;
        p.reference1 = refs.reference1;
        p.side.push_back(static_cast<std::uint8_t>(std::countr_zero(search_.blockSize)));
        const std::vector<std::uint8_t> coded = encodeMotionField(field);
        p.side.insert(p.side.end(), coded.begin(), coded.end());
        // Compensates with the field as the decoder reads it back, so both sides predict the same bits.
        const MotionField stored = decodeMotionField(coded, grid, "encoder");
        p.prediction = quantisedPrediction(compensator_->compensate(cc, stored, r0, r1), frame.type());
        p.ownedResidual = residualOf(frame, *p.prediction);
        p.signal = &*p.ownedResidual;
        return p;
    }

    void reconstruct(ComputeContext& cc, Volume& signal, const VczFrame& entry,
                     std::span<const std::uint8_t> side, const ReferenceFrames& refs) override {
        const Volume& r0 = referenceAt(refs, entry.reference0, "forward");
        const Volume* r1 =
            entry.type == FrameType::B ? &referenceAt(refs, entry.reference1, "backward") : nullptr;
        if (side.empty() || side[0] < 1 || side[0] > 5) throw IoError("motion data: invalid block size");
        const BlockGrid grid{signal.dims(), std::size_t(1) << side[0]};
        const MotionField field = decodeMotionField(side.subspan(1), grid, "motion data");
        if (!compensator_) compensator_.emplace(cc);
        signal = compensator_->reconstruct(cc, field, r0, r1, signal);
    }

    bool usesReferences() const noexcept override { return true; }

private:
    MotionSearchOptions search_;
    std::optional<MotionEstimator> estimator_;
    std::optional<MotionCompensator> compensator_;
};

} // namespace

std::unique_ptr<Predictor> makeMotionPredictor(const MotionSearchOptions& search) {
    return std::make_unique<MotionPredictor>(search);
}

std::unique_ptr<Predictor> makeMotionReconstructor() {
    return std::make_unique<MotionPredictor>(MotionSearchOptions{});
}

} // namespace volcl::codec
