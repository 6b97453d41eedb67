// Atomic file output (unique temporary + fsync + rename) and whole-file reading.
#include "host/io/AtomicFile.hpp"

#include "host/Error.hpp"

#include <atomic>
#include <cerrno>
#include <cstring>
#include <random>
#include <string>

#include <fcntl.h>
#include <unistd.h>

namespace volcl {

namespace fs = std::filesystem;

namespace {

std::string systemError(int err) {
    return std::strerror(err);
}

// Creates an empty file with a name nobody else holds (O_EXCL), so two writers never share a temporary.
fs::path createUniqueTemp(const fs::path& target) {
    static std::atomic<unsigned> counter{0};
    std::random_device rd;
    const fs::path dir = target.parent_path().empty() ? fs::path(".") : target.parent_path();
    for (int attempt = 0; attempt < 64; ++attempt) {
        std::string name(".");
        name.append(target.filename().string()).append(".tmp-").append(std::to_string(::getpid()));
        name.append("-")
            .append(std::to_string(counter.fetch_add(1)))
            .append("-")
            .append(std::to_string(rd() & 0xffffff));
        const fs::path candidate = dir / name;
        const int fd = ::open(candidate.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        if (fd >= 0) {
            ::close(fd);
            return candidate;
        }
        if (errno != EEXIST)
            throw IoError(target.string() + ": cannot create a temporary file in " + dir.string() + ": " +
                          systemError(errno));
    }
    throw IoError(target.string() + ": cannot find a free temporary file name in " + dir.string());
}

} // namespace

AtomicFile::AtomicFile(fs::path target) : target_(std::move(target)) {
    if (target_.empty()) throw IoError("output path is empty");
    const fs::path dir = target_.parent_path().empty() ? fs::path(".") : target_.parent_path();
    std::error_code ec;
    if (!fs::is_directory(dir, ec))
        throw IoError(target_.string() + ": output directory " + dir.string() + " does not exist");
    if (fs::is_directory(target_, ec)) throw IoError(target_.string() + ": is a directory, not a file");
    temp_ = createUniqueTemp(target_);
}

AtomicFile::~AtomicFile() {
    if (committed_) return;
    try {
        if (stream_.is_open()) stream_.close();
    } catch (...) {
    }
    std::error_code ec;
    fs::remove(temp_, ec);
}

std::ofstream& AtomicFile::stream() {
    if (committed_) throw IoError(target_.string() + ": already committed");
    if (!stream_.is_open()) {
        stream_.open(temp_, std::ios::binary | std::ios::trunc);
        if (!stream_)
            throw IoError(target_.string() + ": cannot open temporary " + temp_.string() + " for writing");
    }
    return stream_;
}

void AtomicFile::write(std::span<const std::byte> bytes) {
    std::ofstream& s = stream();
    s.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    if (!s) throw IoError(target_.string() + ": write failed (disk full?)");
}

void AtomicFile::write(std::string_view text) {
    write(std::span<const std::byte>(reinterpret_cast<const std::byte*>(text.data()), text.size()));
}

void AtomicFile::commit() {
    if (committed_) throw IoError(target_.string() + ": already committed");
    if (stream_.is_open()) {
        stream_.flush();
        const bool good = static_cast<bool>(stream_);
        stream_.close();
        if (!good || stream_.fail()) throw IoError(target_.string() + ": write failed (disk full?)");
    }
    // Data must be on disk before the rename makes it visible, or a crash could expose an empty file.
    const int fd = ::open(temp_.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) throw IoError(target_.string() + ": temporary file vanished: " + systemError(errno));
    const int syncRc = ::fsync(fd);
    const int syncErr = errno;
    ::close(fd);
    if (syncRc != 0) throw IoError(target_.string() + ": cannot flush to disk: " + systemError(syncErr));
    std::error_code ec;
    fs::rename(temp_, target_, ec);
    if (ec) throw IoError(target_.string() + ": cannot move the finished file into place: " + ec.message());
    committed_ = true;
}

std::vector<std::byte> readFileBytes(const fs::path& path) {
    std::error_code ec;
    if (!fs::exists(path, ec)) throw IoError(path.string() + ": file does not exist");
    if (fs::is_directory(path, ec)) throw IoError(path.string() + ": is a directory, not a file");
    std::ifstream in(path, std::ios::binary);
    if (!in) throw IoError(path.string() + ": cannot open for reading: " + systemError(errno));
    in.seekg(0, std::ios::end);
    const std::streamoff size = in.tellg();
    if (size < 0) throw IoError(path.string() + ": cannot determine the file size");
    in.seekg(0, std::ios::beg);
    std::vector<std::byte> bytes(static_cast<std::size_t>(size));
    in.read(reinterpret_cast<char*>(bytes.data()), size);
    if (in.gcount() != size) throw IoError(path.string() + ": read error (file changed while reading?)");
    return bytes;
}

void checkNotSameFile(const fs::path& input, const fs::path& output) {
    std::error_code ec;
    bool same = false;
    if (fs::exists(output, ec) && fs::exists(input, ec)) {
        same = fs::equivalent(input, output, ec);
    } else {
        const fs::path a = fs::weakly_canonical(input, ec);
        const fs::path b = fs::weakly_canonical(output, ec);
        same = !ec && a == b;
    }
    if (same) throw UsageError("output " + output.string() + " is the same file as input " + input.string());
}

} // namespace volcl
