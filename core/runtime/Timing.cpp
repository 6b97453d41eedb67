// Timing helpers: process CPU time, medians and the copy-kernel bandwidth ceiling.
#include "core/runtime/Timing.hpp"

#include "core/runtime/ClRuntime.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>

namespace volcl {

double ProcessCpuStopwatch::now() {
    timespec t{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return double(t.tv_sec) * 1e3 + double(t.tv_nsec) * 1e-6;
}

double median(std::vector<double> samples) {
    if (samples.empty()) return 0.0;
    std::sort(samples.begin(), samples.end());
    std::size_t n = samples.size();
    return n % 2 ? samples[n / 2] : 0.5 * (samples[n / 2 - 1] + samples[n / 2]);
}

MedianInterval medianInterval(std::vector<double> samples, double confidence) {
    MedianInterval r;
    if (samples.empty()) return r;
    r.median = median(samples);
    std::sort(samples.begin(), samples.end());
    const std::size_t n = samples.size();
    // P(Bin(n, 1/2) <= j), accumulated: coverage of [x(k), x(n+1-k)] is 1 - 2 P(Bin <= k - 1).
    std::vector<double> cdf(n + 1);
    double term = std::pow(0.5, double(n)), sum = 0.0;
    for (std::size_t j = 0; j <= n; ++j) {
        sum += term;
        cdf[j] = sum;
        term = term * double(n - j) / double(j + 1);
    }
    std::size_t k = 1; // 1-based order statistic
    while (k + 1 <= (n + 1) / 2 && 1.0 - 2.0 * cdf[k] >= confidence)
        ++k;
    r.lo = samples[k - 1];
    r.hi = samples[n - k];
    r.level = 1.0 - 2.0 * cdf[k - 1];
    return r;
}

std::string loadAverageText() {
    double l[3] = {0, 0, 0};
    if (getloadavg(l, 3) != 3) return "unknown";
    char text[96];
    std::snprintf(text, sizeof text, "%.2f %.2f %.2f (1, 5, 15 min)", l[0], l[1], l[2]);
    return text;
}

double medianMilliseconds(int runs, const std::function<void()>& fn) {
    fn(); // warm-up: kernel builds, first-touch allocation
    std::vector<double> t;
    for (int i = 0; i < std::max(runs, 1); ++i) {
        Stopwatch sw;
        fn();
        t.push_back(sw.milliseconds());
    }
    return median(t);
}

double copyKernelBandwidthGBs(ComputeContext& cc, std::size_t bytes, int runs) {
    std::size_t n16 = std::max<std::size_t>(bytes / 64, 1);
    auto src = cc.allocate<cl_float16>(n16, CL_MEM_READ_ONLY);
    auto dst = cc.allocate<cl_float16>(n16, CL_MEM_WRITE_ONLY);
    cc.fill(src, cl_float16{});
    cl::Kernel k = cc.kernel("common/copy.cl", "copy_float16");
    setArgs(k, src, dst, static_cast<cl_uint>(n16));
    cc.launch1d(k, n16, cc.profile().copyLocal).wait();
    std::vector<double> ms;
    for (int i = 0; i < std::max(runs, 1); ++i)
        ms.push_back(eventMilliseconds(cc.launch1d(k, n16, cc.profile().copyLocal)));
    double t = median(ms);
    return t > 0 ? 2.0 * static_cast<double>(n16 * 64) / (t * 1e6) : 0.0;
}

} // namespace volcl
