// Timing helpers for benchmarks: wall-clock stopwatch, medians, and the copy-kernel bandwidth ceiling.
#pragma once

#include <chrono>
#include <cstddef>
#include <functional>
#include <vector>

namespace volcl {

class ComputeContext;

class Stopwatch {
public:
    Stopwatch() : start_(Clock::now()) {}
    void restart() { start_ = Clock::now(); }
    double milliseconds() const {
        return std::chrono::duration<double, std::milli>(Clock::now() - start_).count();
    }

private:
    using Clock = std::chrono::steady_clock;
    Clock::time_point start_;
};

/// CPU time of the whole process (all its threads, OpenCL CPU-device workers included) since construction:
/// on a machine shared with other jobs it measures the work done, where wall time also measures the wait.
class ProcessCpuStopwatch {
public:
    ProcessCpuStopwatch() : start_(now()) {}
    double milliseconds() const { return now() - start_; }

private:
    static double now();
    double start_;
};

/// Median of the samples (mean of the middle two for even counts); 0 for an empty list.
double median(std::vector<double> samples);

/// Runs `fn` once as a warm-up, then `runs` times; returns the median wall time in milliseconds.
double medianMilliseconds(int runs, const std::function<void()>& fn);

/// Bandwidth of a plain float copy kernel (GB/s counting bytes read + written) on `bytes` of data:
/// the ceiling every streaming kernel is reported against. Median of `runs` launches, build excluded.
double copyKernelBandwidthGBs(ComputeContext& cc, std::size_t bytes, int runs = 7);

} // namespace volcl
