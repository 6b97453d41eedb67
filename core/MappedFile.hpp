// A read-only memory mapping of a whole file, for readers that touch only parts of large files.
#pragma once

#include <cstddef>
#include <filesystem>
#include <span>

namespace volcl {

/// The bytes of a regular file mapped read-only: nothing is read until a page is touched, so a reader that
/// parses a header and then a few ranges keeps only those pages resident. Pages it is done with can be
/// handed back (release), keeping the resident set bounded by what is in use rather than by the file.
/// The file must not be truncated while mapped (the mapping would fault); volcl replaces files by rename
/// (AtomicFile), which leaves a mapping of the old file intact.
class MappedFile {
public:
    /// Maps `path`; throws IoError naming it when it does not exist, is not a regular file or cannot be
    /// mapped. An empty file maps to an empty span.
    explicit MappedFile(const std::filesystem::path& path);
    ~MappedFile();
    MappedFile(MappedFile&& other) noexcept;
    MappedFile& operator=(MappedFile&& other) noexcept;
    MappedFile(const MappedFile&) = delete;
    MappedFile& operator=(const MappedFile&) = delete;

    std::span<const std::byte> bytes() const noexcept { return {data_, size_}; }
    /// Drops the resident pages wholly inside [offset, offset + size) from this process (they are read
    /// again from the page cache or the file if touched later). Out-of-range parts are ignored.
    void release(std::size_t offset, std::size_t size) const noexcept;

private:
    const std::byte* data_ = nullptr;
    std::size_t size_ = 0;
};

} // namespace volcl
