// The frame structure of a motion-compensated series: which frames are I, P and B, what each references,
// and the order in which the encoder codes them.
#pragma once

#include "wavelet/container/VczFormat.hpp"

#include <cstddef>
#include <cstdint>
#include <vector>

namespace volcl::codec {

struct PlannedFrame {
    std::size_t frame = 0;
    FrameType type = FrameType::I;
    std::int32_t reference0 = -1, reference1 = -1;
};

/// Coding order of `frames` frames in closed groups of `gop` frames (each starts with an I frame; 1: I
/// frames only). Inside a group, I/P anchors are `bFrames` + 1 frames apart and each P frame predicts from
/// the previous anchor; the frames between two anchors are B frames predicted from both, coded after the
/// later anchor. Where a group's end leaves too little room for a full step, its last frames are P frames.
/// Throws UsageError for gop == 0.
std::vector<PlannedFrame> planGop(std::size_t frames, std::size_t gop, std::size_t bFrames);

} // namespace volcl::codec
