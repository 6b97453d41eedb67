// Timing helpers for benchmarks: wall-clock stopwatch, medians, and the copy-kernel bandwidth ceiling.
#pragma once

#include <chrono>
#include <cstddef>
#include <functional>
#include <string>
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

/// A median with a distribution-free confidence interval: order statistics lo = x(k), hi = x(n+1-k) for the
/// largest k whose binomial coverage 1 - 2 P(Bin(n, 1/2) < k) reaches `confidence` (no such k, n < 6 at
/// 95%: the whole range [min, max], whose coverage `level` then states).
struct MedianInterval {
    double median = 0.0, lo = 0.0, hi = 0.0;
    double level = 0.0; ///< the interval's actual coverage
    /// The interval holds 0: the sign of the median is not established.
    bool holdsZero() const noexcept { return lo <= 0.0 && hi >= 0.0; }
};
MedianInterval medianInterval(std::vector<double> samples, double confidence = 0.95);

/// The machine's load average as "1.23 0.98 0.75 (1, 5, 15 min)" (from /proc/loadavg), "unknown" when it
/// cannot be read: every timing printed on a shared machine states it.
std::string loadAverageText();

/// Runs `fn` once as a warm-up, then `runs` times; returns the median wall time in milliseconds.
double medianMilliseconds(int runs, const std::function<void()>& fn);

/// Bandwidth of a plain float copy kernel (GB/s counting bytes read + written) on `bytes` of data:
/// the ceiling every streaming kernel is reported against. Median of `runs` launches, build excluded.
double copyKernelBandwidthGBs(ComputeContext& cc, std::size_t bytes, int runs = 7);

} // namespace volcl
