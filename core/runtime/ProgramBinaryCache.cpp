// On-disk cache of OpenCL program binaries, keyed on device, driver, build options and expanded source.
#include "core/runtime/ProgramBinaryCache.hpp"

#include "core/AtomicFile.hpp"
#include "core/runtime/KernelSources.hpp"

#include <xxhash.h>

#include <cstdlib>
#include <cstring>

namespace volcl {

namespace {

constexpr char kMagic[8] = {'V', 'O', 'L', 'C', 'L', 'P', 'B', '1'};

void put64(std::vector<std::byte>& out, std::uint64_t v) {
    for (int i = 0; i < 8; ++i)
        out.push_back(static_cast<std::byte>(v >> (8 * i)));
}

// Reads the fields of an entry in order; any read past the end marks the entry unusable.
struct EntryReader {
    const std::vector<std::byte>& bytes;
    std::size_t pos = 0;
    bool ok = true;
    std::uint64_t u64() {
        if (bytes.size() - pos < 8) {
            ok = false;
            return 0;
        }
        std::uint64_t v = 0;
        for (int i = 0; i < 8; ++i)
            v |= std::uint64_t(bytes[pos + std::size_t(i)]) << (8 * i);
        pos += 8;
        return v;
    }
    const std::byte* take(std::uint64_t n) {
        if (!ok || bytes.size() - pos < n) {
            ok = false;
            return nullptr;
        }
        const std::byte* p = bytes.data() + pos;
        pos += std::size_t(n);
        return p;
    }
};

std::string hex(std::uint64_t v) {
    static const char* digits = "0123456789abcdef";
    std::string s(16, '0');
    for (int i = 15; i >= 0; --i, v >>= 4)
        s[std::size_t(i)] = digits[v & 15];
    return s;
}

} // namespace

std::optional<std::filesystem::path> ProgramBinaryCache::directory() {
    if (const char* dir = std::getenv("VOLCL_CACHE_DIR")) {
        if (std::strcmp(dir, "off") == 0 || *dir == '\0') return std::nullopt;
        return std::filesystem::path(dir);
    }
    if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg)
        return std::filesystem::path(xdg) / "volcl";
    if (const char* home = std::getenv("HOME"); home && *home)
        return std::filesystem::path(home) / ".cache" / "volcl";
    return std::nullopt;
}

ProgramBinaryCache::ProgramBinaryCache(const DeviceInfo& device, std::string_view options,
                                       std::string_view source)
    : device_(device.device) {
    identity_.append(device.platform).append("\n").append(device.name).append("\n").append(device.version);
    identity_.append("\n").append(device.driver).append("\n").append(options);
    sourceHash_ = fnv1a64(source);
    sourceCheck_ = XXH3_64bits(source.data(), source.size());
    sourceSize_ = source.size();
    if (auto dir = directory()) file_ = *dir / "programs" / (hex(fnv1a64(identity_, sourceHash_)) + ".bin");
}

std::optional<std::vector<unsigned char>> ProgramBinaryCache::load() const noexcept {
    if (!file_) return std::nullopt;
    try {
        std::error_code ec;
        if (!std::filesystem::is_regular_file(*file_, ec)) return std::nullopt;
        const std::vector<std::byte> bytes = readFileBytes(*file_);
        EntryReader r{bytes};
        const std::byte* magic = r.take(sizeof kMagic);
        if (!magic || std::memcmp(magic, kMagic, sizeof kMagic) != 0) return std::nullopt;
        const std::uint64_t idSize = r.u64();
        const std::byte* id = r.take(idSize);
        if (!id || idSize != identity_.size() || std::memcmp(id, identity_.data(), idSize) != 0)
            return std::nullopt;
        if (r.u64() != sourceHash_ || r.u64() != sourceCheck_ || r.u64() != sourceSize_) return std::nullopt;
        const std::uint64_t size = r.u64(), check = r.u64();
        const std::byte* binary = r.take(size);
        if (!r.ok || size == 0 || r.pos != bytes.size() || XXH3_64bits(binary, size) != check)
            return std::nullopt;
        const auto* b = reinterpret_cast<const unsigned char*>(binary);
        return std::vector<unsigned char>(b, b + size);
    } catch (...) {
        return std::nullopt;
    }
}

void ProgramBinaryCache::store(const cl::Program& program) const noexcept {
    if (!file_) return;
    try {
        std::size_t size = 0;
        if (clGetProgramInfo(program(), CL_PROGRAM_BINARY_SIZES, sizeof size, &size, nullptr) != CL_SUCCESS ||
            size == 0)
            return; // one device per program (our contexts hold one)
        std::vector<unsigned char> binary(size);
        unsigned char* ptr = binary.data();
        if (clGetProgramInfo(program(), CL_PROGRAM_BINARIES, sizeof ptr, &ptr, nullptr) != CL_SUCCESS) return;
        std::vector<std::byte> out;
        for (char c : kMagic)
            out.push_back(static_cast<std::byte>(c));
        put64(out, identity_.size());
        for (char c : identity_)
            out.push_back(static_cast<std::byte>(c));
        put64(out, sourceHash_);
        put64(out, sourceCheck_);
        put64(out, sourceSize_);
        put64(out, size);
        put64(out, XXH3_64bits(binary.data(), size));
        const auto* b = reinterpret_cast<const std::byte*>(binary.data());
        out.insert(out.end(), b, b + size);
        std::filesystem::create_directories(file_->parent_path());
        AtomicFile f(*file_);
        f.write(out);
        f.commit();
    } catch (...) {
        // The cache only saves time: a failure here leaves the next run to build from source again.
    }
}

} // namespace volcl
