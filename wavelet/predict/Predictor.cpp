// The `none` predictor (every frame an I frame) and the choice of decoder-side predictor by frame type.
#include "wavelet/predict/Predictor.hpp"

#include "host/Error.hpp"

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

std::unique_ptr<Predictor> predictorFor(const VczFrame& entry, std::size_t frame, const std::string& name) {
    if (entry.type != FrameType::I)
        throw DataError(name + ": frame " + std::to_string(frame) +
                        " is a motion-compensated frame; this decoder reads I frames");
    return makeNonePredictor();
}

} // namespace volcl::codec
