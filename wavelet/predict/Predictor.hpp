// The predict stage, the seam between a series' frames and the coding stages: an encoder-side predictor
// turns a frame into the signal the rate stage codes (the frame itself, or its residual against a
// prediction from reference frames, plus side information such as motion vectors), and the decoder-side
// reconstruction adds the same prediction back to the decoded residual.
//
// Contract for every predictor (the `none` one below and a motion-compensated one):
// - References are frames as the decoder reconstructs them, never the encoder's input frames (closed
//   loop): the encoder decodes each frame it codes that a later frame references and passes those
//   reconstructions in, so quantisation errors cannot drift along a chain of P/B frames.
// - predict() decides the frame's type and references (stored in the frame table) and returns the signal
//   to code. That signal is an ordinary Volume on the frame's grid, coded by the same transform, quantise,
//   entropy and payload stages as an I frame; its scalar type is the predictor's choice (a lossless
//   residual of 16-bit data needs 17 bits, so such a predictor codes a wider type, not the voxel type).
// - The side information is opaque to the other stages: the container stores it in the frame's auxiliary
//   block (with its checksum) and hands it back to reconstruct() unchanged.
// - reconstruct() must be exact: for a lossless frame, residual plus prediction gives the input bit for bit;
//   for a lossy one the error bound of the residual's rate mode holds on the frame's voxels.
#pragma once

#include "core/Volume.hpp"
#include "core/runtime/ClRuntime.hpp"
#include "wavelet/container/VczFormat.hpp"

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace volcl::codec {

/// Reconstructed frames a prediction may use, indexed by frame number (null where not decoded).
struct ReferenceFrames {
    std::span<const Volume* const> frames;
    /// The encoder's choice of references for the frame being predicted (-1: none); a predictor with
    /// references makes a P frame from reference0 alone and a B frame when reference1 is set too.
    std::int32_t reference0 = -1, reference1 = -1;
    /// Voxel-domain quantiser step the residual will be coded with (1 for lossless): a predictor weighs
    /// the side bits of its choices against the residual bits they save with it.
    double step = 1;
    /// Lossless coding: integer frames need integer residuals, so the prediction is rounded to the voxel
    /// type. A lossy residual need not be: the motion predictor then keeps its prediction in float.
    bool lossless = true;
};

/// What the encoder codes for one frame.
struct Prediction {
    FrameType type = FrameType::I;
    std::int32_t reference0 = -1, reference1 = -1; ///< frame numbers predicted from (-1: none)
    /// The signal the rate stage codes: the input frame itself (an I frame) or `ownedResidual`.
    const Volume* signal = nullptr;
    std::optional<Volume> ownedResidual;
    /// The prediction (Float32) the residual was taken against: the rate stage checks error bounds on
    /// prediction + decoded residual, the frame the decoder writes.
    std::optional<Volume> prediction;
    /// Side information for the frame's auxiliary block (empty for I frames).
    std::vector<std::uint8_t> side;
};

class Predictor {
public:
    virtual ~Predictor() = default;
    /// Encoder: the prediction of frame number `index` from `refs` (reconstructions of earlier coded frames).
    /// The returned signal may point into `frame`, which must outlive it.
    virtual Prediction predict(ComputeContext& cc, const Volume& frame, std::size_t index,
                               const ReferenceFrames& refs) = 0;
    /// Decoder: turns the decoded `signal` of a frame with table entry `entry` into the frame, in place,
    /// from the side information stored with it and the reconstructed references.
    virtual void reconstruct(ComputeContext& cc, Volume& signal, const VczFrame& entry,
                             std::span<const std::uint8_t> side, const ReferenceFrames& refs) = 0;
    /// Whether later frames may reference this predictor's frames, so that the encoder must reconstruct
    /// each coded frame (false for `none`: every frame stands alone).
    virtual bool usesReferences() const noexcept = 0;
};

/// Every frame an I frame, coded as it is; reconstruction leaves the decoded frame unchanged.
std::unique_ptr<Predictor> makeNonePredictor();

/// The decoder-side predictor of a frame as the file states it: `none` for I frames, motion
/// compensation for P and B frames.
std::unique_ptr<Predictor> predictorFor(const VczFrame& entry);

} // namespace volcl::codec
