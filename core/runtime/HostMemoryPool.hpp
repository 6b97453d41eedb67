// Pooled host memory for buffers on CPU devices, and the block lease that hands it back.
#pragma once

#include <cstddef>
#include <map>
#include <memory>
#include <mutex>
#include <utility>

namespace volcl {

/// Host memory for buffers on CPU devices: blocks of whole huge pages, 2 MiB aligned and advised for
/// transparent huge pages, kept after their buffer is released and handed out again for a request of up to
/// their size. Codec batches are allocated per call and written right away, and fresh memory costs a page
/// fault and a zeroed page on first touch (28 MB of page clearing per BrainWeb decode). Idle blocks beyond
/// kKeepBytes are freed. Thread-safe: blocks come back from OpenCL callbacks.
class HostMemoryPool {
public:
    static constexpr std::size_t kKeepBytes = std::size_t(512) << 20;
    HostMemoryPool() = default;
    HostMemoryPool(const HostMemoryPool&) = delete;
    HostMemoryPool& operator=(const HostMemoryPool&) = delete;
    ~HostMemoryPool();

    /// A block of at least `bytes` (a multiple of kHugePageBytes) and its size, or {nullptr, 0} when out of
    /// memory. An idle block up to twice the size is reused rather than fresh pages touched: a short
    /// process's batches come in a few sizes, and fresh memory is the costliest part of its run.
    std::pair<void*, std::size_t> take(std::size_t bytes);
    /// Returns a block from take(); never throws.
    void give(void* mem, std::size_t bytes) noexcept;

private:
    std::mutex mutex_;
    std::multimap<std::size_t, void*> idle_;
    std::size_t idleBytes_ = 0;
};

/// One block of a pool, returned to it when the lease ends (or when a buffer created over it is
/// released; see ComputeContext::adoptHost).
class HostBlock {
public:
    HostBlock() noexcept = default;
    /// A block of at least `bytes` rounded up to whole huge pages; throws std::bad_alloc when out of memory.
    HostBlock(std::shared_ptr<HostMemoryPool> pool, std::size_t bytes);
    HostBlock(HostBlock&& o) noexcept { *this = std::move(o); }
    HostBlock& operator=(HostBlock&& o) noexcept;
    HostBlock(const HostBlock&) = delete;
    HostBlock& operator=(const HostBlock&) = delete;
    ~HostBlock() { reset(); }

    void* data() const noexcept { return mem_; }
    std::size_t size() const noexcept { return bytes_; }
    const std::shared_ptr<HostMemoryPool>& pool() const noexcept { return pool_; }
    /// Gives the block back now.
    void reset() noexcept;

private:
    std::shared_ptr<HostMemoryPool> pool_;
    void* mem_ = nullptr;
    std::size_t bytes_ = 0;
};

} // namespace volcl
