// Large zero-filled host memory: kernel-zeroed pages mapped on demand, 2 MiB aligned for huge pages.
#include "core/ZeroedBytes.hpp"

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <new>
#include <utility>

#ifdef __linux__
#include <sys/mman.h>
#endif

namespace volcl {

void* mapZeroedPages(std::size_t bytes) noexcept {
#ifdef __linux__
    // Over-map by one huge page and trim both ends, since mmap only promises 4 KiB alignment.
    const std::size_t span = bytes + kHugePageBytes;
    void* raw = mmap(nullptr, span, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (raw == MAP_FAILED) return nullptr;
    const auto start = reinterpret_cast<std::uintptr_t>(raw);
    const std::uintptr_t aligned = (start + kHugePageBytes - 1) & ~(kHugePageBytes - 1);
    if (aligned > start) munmap(raw, aligned - start);
    const std::uintptr_t end = aligned + bytes, mappedEnd = start + span;
    if (mappedEnd > end) munmap(reinterpret_cast<void*>(end), mappedEnd - end);
#ifdef MADV_HUGEPAGE
    madvise(reinterpret_cast<void*>(aligned), bytes, MADV_HUGEPAGE); // advice only: else smaller pages
#endif
    return reinterpret_cast<void*>(aligned);
#else
    void* mem = std::aligned_alloc(kHugePageBytes, bytes);
    if (mem) std::memset(mem, 0, bytes);
    return mem;
#endif
}

void unmapPages(void* block, std::size_t bytes) noexcept {
    if (!block) return;
#ifdef __linux__
    munmap(block, bytes);
#else
    (void)bytes;
    std::free(block);
#endif
}

ZeroedBytes::ZeroedBytes(std::size_t size) : size_(size) {
    if (size == 0) return;
    if (size >= kHugePageBytes) {
        mapped_ = (size + kHugePageBytes - 1) / kHugePageBytes * kHugePageBytes;
        data_ = static_cast<std::byte*>(mapZeroedPages(mapped_));
        if (!data_) {
            size_ = mapped_ = 0;
            throw std::bad_alloc();
        }
    } else {
        data_ = new std::byte[size](); // value-initialised: zero
    }
}

ZeroedBytes::ZeroedBytes(const ZeroedBytes& o) : ZeroedBytes(o.size_) {
    if (size_) std::memcpy(data_, o.data_, size_);
}

ZeroedBytes::ZeroedBytes(ZeroedBytes&& o) noexcept
    : data_(std::exchange(o.data_, nullptr)), size_(std::exchange(o.size_, 0)),
      mapped_(std::exchange(o.mapped_, 0)) {}

ZeroedBytes& ZeroedBytes::operator=(const ZeroedBytes& o) {
    if (this != &o) *this = ZeroedBytes(o);
    return *this;
}

ZeroedBytes& ZeroedBytes::operator=(ZeroedBytes&& o) noexcept {
    if (this != &o) {
        release();
        data_ = std::exchange(o.data_, nullptr);
        size_ = std::exchange(o.size_, 0);
        mapped_ = std::exchange(o.mapped_, 0);
    }
    return *this;
}

ZeroedBytes::~ZeroedBytes() {
    release();
}

void ZeroedBytes::release() noexcept {
    if (mapped_)
        unmapPages(data_, mapped_);
    else
        delete[] data_;
    data_ = nullptr;
    size_ = mapped_ = 0;
}

bool operator==(const ZeroedBytes& a, const ZeroedBytes& b) noexcept {
    return a.size() == b.size() && (a.size() == 0 || std::memcmp(a.data(), b.data(), a.size()) == 0);
}

} // namespace volcl
