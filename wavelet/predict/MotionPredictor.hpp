// The motion-compensated predictor: block matching against the reconstructed reference, per-block mode
// decision, overlapped block motion compensation, and the residual the coding stages code.
#pragma once

#include "wavelet/predict/MotionSearch.hpp"
#include "wavelet/predict/Predictor.hpp"

#include <memory>

namespace volcl::codec {

/// P frames (from ReferenceFrames::reference0) and B frames (both references). The side information is
/// one byte holding log2 of the block size followed by encodeMotionField's bytes. With `globalShift`, a P
/// frame may instead predict from its reference moved by a global sub-voxel translation (Keys cubic), when
/// the estimated size says it pays: the byte then has bit 0x80 set and the translation (3 x int16) follows
/// it. The OBMC kernel predicts in float on the device: a file decodes to the encoder's bits on the device
/// type that encoded it. `threads` host threads run the translation.
std::unique_ptr<Predictor> makeMotionPredictor(const MotionSearchOptions& search, bool globalShift = true,
                                               unsigned threads = 2);

/// The decoder-side motion predictor (its search options are not used).
std::unique_ptr<Predictor> makeMotionReconstructor(unsigned threads = 2);

} // namespace volcl::codec
