// Motion-compensated prediction of P and B frames from reconstructed references, and its reconstruction.
#include "wavelet/predict/MotionPredictor.hpp"

#include "core/Error.hpp"
#include "wavelet/predict/Compensation.hpp"
#include "wavelet/predict/GlobalShift.hpp"
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
// Returns the estimated bits of the frame's residual and side data under the chosen modes.
double chooseModesByRate(MotionField& field, const std::vector<ModeCosts>& costs, double step) {
    const double noise = step * step / 4;
    const Dims nb = field.grid.blocks();
    const std::size_t s = field.grid.size;
    double total = 0;
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
        total += bits[int(field.modes[b])];
    }
    return total;
}

// The aux block's first byte: log2 of the block size (1..5). Bit 0x80 marks a frame predicted from its
// reference moved by a global sub-voxel translation (cubicShifted); the translation's three int16
// components (x, y, z, little-endian, 1/kGlobalShiftUnits voxel) follow before the motion field. Files
// without the bit decode as before; decoders that predate it refuse such a frame as an invalid block size.
constexpr std::uint8_t kGlobalShiftFlag = 0x80;
// Bit 0x40 marks a lossy frame of integer voxels whose prediction is kept in float instead of rounded to the
// voxel type: rounding adds white noise of variance 1/12 to the residual, as much as the whole error
// budget near 60 dB on 8-bit data. Lossless frames round (their residuals must be integers).
constexpr std::uint8_t kFloatPredictionFlag = 0x40;

void appendShift(std::vector<std::uint8_t>& side, const GlobalShift& g) {
    for (std::int16_t c : {g.x, g.y, g.z}) {
        const auto u = static_cast<std::uint16_t>(c);
        side.push_back(static_cast<std::uint8_t>(u & 0xff));
        side.push_back(static_cast<std::uint8_t>(u >> 8));
    }
}

GlobalShift readShift(std::span<const std::uint8_t> b) {
    auto c = [&](std::size_t i) {
        return static_cast<std::int16_t>(static_cast<std::uint16_t>(b[i] | (b[i + 1] << 8)));
    };
    const GlobalShift g{c(0), c(2), c(4)};
    const int m = kGlobalShiftMaxVoxels * kGlobalShiftUnits;
    for (int v : {int(g.x), int(g.y), int(g.z)})
        if (v < -m || v > m) throw IoError("motion data: invalid global shift");
    return g;
}

// The content translation the block vectors agree on: the component-wise median of -v/2 (vectors point into
// the reference, content moves the other way), the start of the global-shift fit.
std::array<double, 3> medianShift(const std::vector<MotionVector>& v) {
    std::array<double, 3> out{};
    if (v.empty()) return out;
    for (int c = 0; c < 3; ++c) {
        std::vector<int> comp(v.size());
        for (std::size_t i = 0; i < v.size(); ++i)
            comp[i] = c == 0 ? v[i].x : c == 1 ? v[i].y : v[i].z;
        std::nth_element(comp.begin(), comp.begin() + std::ptrdiff_t(comp.size() / 2), comp.end());
        out[std::size_t(c)] = -0.5 * comp[comp.size() / 2];
    }
    return out;
}

class MotionPredictor final : public Predictor {
public:
    MotionPredictor(const MotionSearchOptions& search, bool globalShift, unsigned threads)
        : search_(search), globalShift_(globalShift), threads_(threads) {
        validate(search_);
    }

    Prediction predict(ComputeContext& cc, const Volume& frame, std::size_t,
                       const ReferenceFrames& refs) override {
        const bool bidirectional = refs.reference1 >= 0;
        const Volume& r0 = referenceAt(refs, refs.reference0, "forward");
        const Volume* r1 = bidirectional ? &referenceAt(refs, refs.reference1, "backward") : nullptr;
        if (!estimator_) estimator_.emplace(cc, search_);
        if (!compensator_) compensator_.emplace(cc);
        const MotionSearchResult fwd = estimator_->search(cc, frame, r0);
        std::optional<MotionSearchResult> bwd;
        if (r1) bwd = estimator_->search(cc, frame, *r1);
        Candidate best = decide(cc, frame, r0, r1, fwd, bwd ? &*bwd : nullptr, refs.step);
        // P frames may also predict from the reference moved by one global sub-voxel translation (rigid
        // motion that half-voxel vectors and trilinear samples only approximate); the block search then runs
        // again on the moved reference, and the cheaper estimate wins (the translation costs 6 bytes). Fits
        // under a quarter voxel on every axis are left out: there the translation gains only through the
        // cubic filter's smoothing, which the size estimate overrates (on viscous fingering such fits, 1/32
        // to 1/8 voxel, were estimated 5-30 % smaller and coded 7-12 % larger).
        std::optional<Volume> moved;
        GlobalShift shift;
        if (globalShift_ && !bidirectional) {
            const GlobalShift g = estimateGlobalShift(frame, r0, medianShift(fwd.vectors), threads_);
            constexpr int quarter = kGlobalShiftUnits / 4;
            if (std::abs(g.x) >= quarter || std::abs(g.y) >= quarter || std::abs(g.z) >= quarter) {
                Volume m = cubicShifted(r0, g.voxels(), threads_);
                const Volume searchRef = m.convertedTo(frame.type());
                const MotionSearchResult f2 = estimator_->search(cc, frame, searchRef);
                Candidate c = decide(cc, frame, m, nullptr, f2, nullptr, refs.step);
                if (c.bits + 48 < best.bits) {
                    best = std::move(c);
                    moved = std::move(m);
                    shift = g;
                }
            }
        }
        Prediction p;
        p.type = bidirectional ? FrameType::B : FrameType::P;
        p.reference0 = refs.reference0;
        p.reference1 = refs.reference1;
        const auto log2Block = static_cast<std::uint8_t>(std::countr_zero(search_.blockSize));
        const bool floatPrediction = !refs.lossless && frame.type() != ScalarType::Float32;
        p.side.push_back(std::uint8_t(log2Block | (moved ? kGlobalShiftFlag : 0) |
                                      (floatPrediction ? kFloatPredictionFlag : 0)));
        if (moved) appendShift(p.side, shift);
        const std::vector<std::uint8_t> coded = encodeMotionField(best.field);
        p.side.insert(p.side.end(), coded.begin(), coded.end());
        // Compensates with the field as the decoder reads it back, so both sides predict the same bits.
        const MotionField stored = decodeMotionField(coded, best.field.grid, "encoder");
        p.prediction = quantisedPrediction(compensator_->compensate(cc, stored, moved ? *moved : r0, r1),
                                           floatPrediction ? ScalarType::Float32 : frame.type());
        p.ownedResidual = residualOf(frame, *p.prediction);
        p.signal = &*p.ownedResidual;
        return p;
    }

    void reconstruct(ComputeContext& cc, Volume& signal, const VczFrame& entry,
                     std::span<const std::uint8_t> side, const ReferenceFrames& refs) override {
        const Volume& r0 = referenceAt(refs, entry.reference0, "forward");
        const Volume* r1 =
            entry.type == FrameType::B ? &referenceAt(refs, entry.reference1, "backward") : nullptr;
        if (side.empty()) throw IoError("motion data: invalid block size");
        const bool shifted = (side[0] & kGlobalShiftFlag) != 0;
        const bool floatPrediction = (side[0] & kFloatPredictionFlag) != 0;
        const std::uint8_t log2Block = side[0] & std::uint8_t(~(kGlobalShiftFlag | kFloatPredictionFlag));
        if (log2Block < 1 || log2Block > 5) throw IoError("motion data: invalid block size");
        if (shifted && (r1 || side.size() < 7)) throw IoError("motion data: invalid global shift");
        std::optional<Volume> moved;
        if (shifted) moved = cubicShifted(r0, readShift(side.subspan(1, 6)).voxels(), threads_);
        const BlockGrid grid{signal.dims(), std::size_t(1) << log2Block};
        const MotionField field = decodeMotionField(side.subspan(shifted ? 7 : 1), grid, "motion data");
        if (!compensator_) compensator_.emplace(cc);
        // One kernel pass: the references read as stored (a shifted one as Float32), the prediction rounded
        // to the frame's type unless it is a float prediction, the residual added, voxels written.
        signal = compensator_->reconstruct(cc, field, moved ? *moved : r0, r1, signal, r0.type(),
                                           !floatPrediction);
    }

    bool usesReferences() const noexcept override { return true; }

private:
    struct Candidate {
        MotionField field;
        double bits = 0;
    };

    // Mode costs of the searched vectors against `r0` (and `r1`) and the per-block choice by estimated size.
    Candidate decide(ComputeContext& cc, const Volume& frame, const Volume& r0, const Volume* r1,
                     const MotionSearchResult& fwd, const MotionSearchResult* bwd, double step) {
        ModeChoice choice;
        choice.backward = choice.bidirectional = r1 != nullptr;
        std::vector<ModeCosts> costs;
        Candidate c;
        c.field = compensator_->decideModes(cc, frame, r0, r1, BlockGrid{frame.dims(), search_.blockSize},
                                            fwd.vectors, bwd ? &bwd->vectors : nullptr, choice, &costs);
        c.bits = chooseModesByRate(c.field, costs, step);
        return c;
    }

    MotionSearchOptions search_;
    bool globalShift_ = true;
    unsigned threads_ = 2;
    std::optional<MotionEstimator> estimator_;
    std::optional<MotionCompensator> compensator_;
};

} // namespace

std::unique_ptr<Predictor> makeMotionPredictor(const MotionSearchOptions& search, bool globalShift,
                                               unsigned threads) {
    return std::make_unique<MotionPredictor>(search, globalShift, threads);
}

std::unique_ptr<Predictor> makeMotionReconstructor(unsigned threads) {
    return std::make_unique<MotionPredictor>(MotionSearchOptions{}, false, threads);
}

} // namespace volcl::codec
