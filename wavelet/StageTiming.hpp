// Wall time of codec stages added to a CodecProfile.
#pragma once

#include "core/runtime/Timing.hpp"
#include "wavelet/CodecTypes.hpp"

namespace volcl::codec {

// Adds the wall time of fn() to one stage of the profile (when profiling).
template <class Fn> void timeStage(CodecProfile* p, double CodecProfile::*stage, Fn&& fn) {
    if (!p) {
        fn();
        return;
    }
    Stopwatch sw;
    fn();
    p->*stage += sw.milliseconds();
}

} // namespace volcl::codec
