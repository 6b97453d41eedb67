// Timing helpers: process CPU time, medians and the copy-kernel bandwidth ceiling.
#include "core/runtime/Timing.hpp"

#include "core/runtime/ClRuntime.hpp"

#include <algorithm>
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
