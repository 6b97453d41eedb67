// Group-of-frames planning: I/P/B types, references and coding order.
#include "wavelet/predict/GopPlan.hpp"

#include "core/Error.hpp"

#include <algorithm>

namespace volcl::codec {

std::vector<PlannedFrame> planGop(std::size_t frames, std::size_t gop, std::size_t bFrames) {
    if (gop == 0) throw UsageError("--gop must be at least 1");
    if (bFrames > 64) throw UsageError("--b-frames must be between 0 and 64");
    std::vector<PlannedFrame> plan;
    plan.reserve(frames);
    auto ref = [](std::size_t f) { return static_cast<std::int32_t>(f); };
    for (std::size_t start = 0; start < frames; start += gop) {
        const std::size_t last = std::min(start + gop, frames) - 1;
        plan.push_back({start, FrameType::I, -1, -1});
        std::size_t anchor = start;
        while (anchor < last) {
            const std::size_t next = anchor + bFrames + 1;
            if (next > last) {
                for (std::size_t f = anchor + 1; f <= last; ++f)
                    plan.push_back({f, FrameType::P, ref(f - 1), -1});
                break;
            }
            plan.push_back({next, FrameType::P, ref(anchor), -1});
            for (std::size_t f = anchor + 1; f < next; ++f)
                plan.push_back({f, FrameType::B, ref(anchor), ref(next)});
            anchor = next;
        }
    }
    return plan;
}

} // namespace volcl::codec
