// The motion-compensated predictor: block matching against the reconstructed reference, per-block mode
// decision, overlapped block motion compensation, and the residual the coding stages code.
#pragma once

#include "wavelet/predict/MotionSearch.hpp"
#include "wavelet/predict/Predictor.hpp"

#include <memory>

namespace volcl::codec {

/// P frames (from ReferenceFrames::reference0) and B frames (both references). The side information is
/// one byte holding log2 of the block size followed by encodeMotionField's bytes. The OBMC kernel predicts
/// in float on the device: a file decodes to the encoder's bits on the device type that encoded it.
std::unique_ptr<Predictor> makeMotionPredictor(const MotionSearchOptions& search);

/// The decoder-side motion predictor (its search options are not used).
std::unique_ptr<Predictor> makeMotionReconstructor();

} // namespace volcl::codec
