// The arithmetic shared by the encoder and the decoder of a predicted frame: prediction rounding, residual
// and reconstruction voxel by voxel, so both sides compute the same bits.
#pragma once

#include "core/Volume.hpp"
#include "wavelet/BrickVoxels.hpp"

namespace volcl::codec {

/// Reconstructed voxel of a predicted frame: prediction plus decoded residual, added in float and
/// converted like any decoded voxel (rounded and clamped for integer types).
template <class V> V predictedVoxel(float prediction, float residual) {
    return toVoxel<V>(prediction + residual);
}

/// The prediction as the codec uses it (Float32): for integer frame types every value is rounded and
/// clamped to the type's range, so lossless residuals are integers (one bit wider than the voxels).
Volume quantisedPrediction(const Volume& prediction, ScalarType frameType);

/// frame - prediction as Float32 (exact for integer frames, whose residuals need at most 17 bits).
Volume residualOf(const Volume& frame, const Volume& prediction);

/// The frame of type `frameType`: predictedVoxel of every voxel.
Volume addResidual(const Volume& prediction, const Volume& residual, ScalarType frameType);

} // namespace volcl::codec
