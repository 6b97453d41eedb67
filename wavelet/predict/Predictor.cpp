// The `none` predictor (every frame an I frame) and the choice of decoder-side predictor by frame type.
#include "wavelet/predict/Predictor.hpp"

#include "wavelet/predict/MotionPredictor.hpp"

namespace volcl::codec {

namespace {

class NonePredictor final : public Predictor {
public:
    Prediction predict(ComputeContext&, const Volume& frame, std::size_t, const ReferenceFrames&) override {
        Prediction p;
        p.signal = &frame;
        return p;
    }
    void reconstruct(ComputeContext&, Volume&, const VczFrame&, std::span<const std::uint8_t>,
                     const ReferenceFrames&) override {}
    bool usesReferences() const noexcept override { return false; }
};

} // namespace

std::unique_ptr<Predictor> makeNonePredictor() {
    return std::make_unique<NonePredictor>();
}

std::unique_ptr<Predictor> predictorFor(const VczFrame& entry) {
    if (entry.type != FrameType::I) return makeMotionReconstructor();
    return makeNonePredictor();
}

} // namespace volcl::codec
