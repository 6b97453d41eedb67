// Large zero-filled host memory: kernel-zeroed pages mapped on demand, 2 MiB aligned for huge pages.
#pragma once

#include <cstddef>
#include <span>

namespace volcl {

/// Size and alignment of a transparent huge page on x86-64 Linux.
inline constexpr std::size_t kHugePageBytes = std::size_t(2) << 20;

/// Maps `bytes` (a multiple of kHugePageBytes) of zero-filled memory aligned to kHugePageBytes and advised
/// for transparent huge pages; nullptr when out of memory. The pages are zero without being written:
/// a fresh page is cleared by the kernel when it is first touched, so whoever writes the memory first also
/// takes the page faults (on several threads, when it writes in parallel).
void* mapZeroedPages(std::size_t bytes) noexcept;
/// Unmaps a block from mapZeroedPages with the same size.
void unmapPages(void* block, std::size_t bytes) noexcept;

/// An owned, zero-initialised byte array. Blocks of kHugePageBytes or more come from mapZeroedPages, so
/// creating one costs no memset and no page faults until the owner writes it: a decoder that fills a large
/// volume on two threads pays the faults on both, where a zero-filled std::vector paid them all on one
/// thread first (35 MB: ~36 ms here). Example:
/// ```
/// volcl::ZeroedBytes b(64 << 20); // all zero
/// b.data()[0] = std::byte{1};
/// ```
class ZeroedBytes {
public:
    ZeroedBytes() noexcept = default;
    /// Throws std::bad_alloc when the memory is not available.
    explicit ZeroedBytes(std::size_t size);
    ZeroedBytes(const ZeroedBytes& o);
    ZeroedBytes(ZeroedBytes&& o) noexcept;
    ZeroedBytes& operator=(const ZeroedBytes& o);
    ZeroedBytes& operator=(ZeroedBytes&& o) noexcept;
    ~ZeroedBytes();

    std::byte* data() noexcept { return data_; }
    const std::byte* data() const noexcept { return data_; }
    std::size_t size() const noexcept { return size_; }
    bool empty() const noexcept { return size_ == 0; }
    operator std::span<std::byte>() noexcept { return {data_, size_}; }
    operator std::span<const std::byte>() const noexcept { return {data_, size_}; }

private:
    void release() noexcept;
    std::byte* data_ = nullptr;
    std::size_t size_ = 0;
    std::size_t mapped_ = 0; ///< bytes mapped with mapZeroedPages, 0 for small heap blocks
};

bool operator==(const ZeroedBytes& a, const ZeroedBytes& b) noexcept;

} // namespace volcl
