// The rate strategies, one per mode (made by makeRateStrategy).
#pragma once

#include "wavelet/rate/RateStrategy.hpp"

namespace volcl::codec {

std::unique_ptr<RateStrategy> makeLosslessIntegerStrategy(ComputeContext& cc, const CodecOptions& o);
std::unique_ptr<RateStrategy> makeLosslessRawStrategy(const CodecOptions& o);
std::unique_ptr<RateStrategy> makeBoundedStrategy(ComputeContext& cc, const CodecOptions& o,
                                                  ValueRangeCache& ranges);
std::unique_ptr<RateStrategy> makePsnrStrategy(ComputeContext& cc, const CodecOptions& o,
                                               ValueRangeCache& ranges);
std::unique_ptr<RateStrategy> makeBpvStrategy(ComputeContext& cc, const CodecOptions& o,
                                              ValueRangeCache& ranges);

} // namespace volcl::codec
