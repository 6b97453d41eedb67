// Pooled host memory: blocks of zeroed huge pages kept for reuse, and their leases.
#include "core/runtime/HostMemoryPool.hpp"

#include "core/ZeroedBytes.hpp"

#include <new>

namespace volcl {

HostMemoryPool::~HostMemoryPool() {
    for (auto& [bytes, mem] : idle_)
        unmapPages(mem, bytes);
}

std::pair<void*, std::size_t> HostMemoryPool::take(std::size_t bytes) {
    {
        std::lock_guard lock(mutex_);
        if (auto it = idle_.lower_bound(bytes); it != idle_.end() && it->first <= 2 * bytes) {
            const std::pair<void*, std::size_t> block{it->second, it->first};
            idle_.erase(it);
            idleBytes_ -= block.second;
            return block;
        }
    }
    void* mem = mapZeroedPages(bytes);
    return {mem, mem ? bytes : 0};
}

void HostMemoryPool::give(void* mem, std::size_t bytes) noexcept {
    try {
        std::lock_guard lock(mutex_);
        if (idleBytes_ + bytes <= kKeepBytes) {
            idle_.emplace(bytes, mem);
            idleBytes_ += bytes;
            return;
        }
    } catch (...) {
    }
    unmapPages(mem, bytes);
}

HostBlock::HostBlock(std::shared_ptr<HostMemoryPool> pool, std::size_t bytes) : pool_(std::move(pool)) {
    const std::size_t rounded = (bytes + kHugePageBytes - 1) / kHugePageBytes * kHugePageBytes;
    const auto [mem, size] = pool_->take(rounded == 0 ? kHugePageBytes : rounded);
    if (!mem) {
        pool_.reset();
        throw std::bad_alloc();
    }
    mem_ = mem;
    bytes_ = size;
}

HostBlock& HostBlock::operator=(HostBlock&& o) noexcept {
    if (this != &o) {
        reset();
        pool_ = std::move(o.pool_);
        mem_ = o.mem_;
        bytes_ = o.bytes_;
        o.mem_ = nullptr;
        o.bytes_ = 0;
    }
    return *this;
}

void HostBlock::reset() noexcept {
    if (mem_ && pool_) pool_->give(mem_, bytes_);
    pool_.reset();
    mem_ = nullptr;
    bytes_ = 0;
}

} // namespace volcl
