// The project's one host-thread loop: parallelFor(n, threads, fn) runs fn(i) for i in [0, n).
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace volcl {

/// Runs fn(i) for every i in [0, n) on up to `threads` host threads (0: the hardware concurrency), the
/// calling thread one of them; indices are handed out one at a time, so uneven items balance. The first
/// exception thrown by fn stops the hand-out and is rethrown here once every thread has finished. With one
/// thread (or one item) fn runs inline, in order.
template <class Fn> void parallelFor(std::size_t n, unsigned threads, Fn&& fn) {
    if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());
    threads = std::max(1u, std::min<unsigned>(threads, static_cast<unsigned>(std::max<std::size_t>(n, 1))));
    if (threads == 1) {
        for (std::size_t i = 0; i < n; ++i)
            fn(i);
        return;
    }
    std::atomic<std::size_t> next{0};
    std::exception_ptr error;
    std::mutex m;
    auto work = [&] {
        for (;;) {
            const std::size_t i = next.fetch_add(1);
            if (i >= n) return;
            try {
                fn(i);
            } catch (...) {
                std::lock_guard lock(m);
                if (!error) error = std::current_exception();
                next = n;
                return;
            }
        }
    };
    std::vector<std::thread> pool;
    for (unsigned t = 1; t < threads; ++t)
        pool.emplace_back(work);
    work();
    for (auto& t : pool)
        t.join();
    if (error) std::rethrow_exception(error);
}

/// A signed thread-count option as parallelFor's count: 0 or less means the hardware concurrency.
inline unsigned hostThreads(int threads) noexcept {
    return threads > 0 ? static_cast<unsigned>(threads) : 0u;
}

} // namespace volcl
