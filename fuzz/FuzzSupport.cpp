// Scratch directory of a fuzz target process (created with mkdtemp, removed when the process exits) and
// the fork handler that keeps the engine's crash reporting out of children of the code under test.
#include "fuzz/FuzzSupport.hpp"

#include <csignal>
#include <cstdlib>
#include <fstream>
#include <stdexcept>
#include <string>

#include <pthread.h>
#include <unistd.h>

extern "C" void __sanitizer_set_death_callback(void (*callback)()) __attribute__((weak));

namespace volcl::fuzz {

namespace {

class ScratchDirectory {
public:
    ScratchDirectory() {
        std::error_code ec;
        const std::filesystem::path shm("/dev/shm");
        const std::filesystem::path base =
            std::filesystem::is_directory(shm, ec) && ::access(shm.c_str(), W_OK) == 0
                ? shm
                : std::filesystem::temp_directory_path();
        std::string pattern = (base / "volcl-fuzz-XXXXXX").string();
        if (!::mkdtemp(pattern.data())) throw std::runtime_error("fuzz: cannot create a scratch directory");
        path_ = pattern;
        owner_ = ::getpid();
    }
    ~ScratchDirectory() {
        if (::getpid() != owner_) return; // a forked reader (OpenVDB) must not remove the parent's files
        std::error_code ec;
        std::filesystem::remove_all(path_, ec);
    }
    ScratchDirectory(const ScratchDirectory&) = delete;
    ScratchDirectory& operator=(const ScratchDirectory&) = delete;
    const std::filesystem::path& path() const noexcept { return path_; }

private:
    std::filesystem::path path_;
    pid_t owner_ = 0;
};

} // namespace

const std::filesystem::path& scratchDirectory() {
    static const ScratchDirectory directory;
    return directory.path();
}

void quietForkedChildren() {
    static const bool once = [] {
        ::pthread_atfork(nullptr, nullptr, [] {
            // In the child: the engine's death callback (libFuzzer's writes crash-<sha1>) and its fatal-signal
            // handlers belong to the parent. The child still prints the sanitizer's report and exits non-zero.
            if (__sanitizer_set_death_callback) __sanitizer_set_death_callback(nullptr);
            for (int sig : {SIGSEGV, SIGBUS, SIGABRT, SIGFPE, SIGILL})
                std::signal(sig, SIG_DFL);
        });
        return true;
    }();
    (void)once;
}

std::filesystem::path writeScratchFile(std::string_view name, std::span<const std::uint8_t> bytes) {
    const std::filesystem::path path = scratchDirectory() / std::string(name);
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    out.close();
    if (!out) throw std::runtime_error("fuzz: cannot write " + path.string());
    return path;
}

} // namespace volcl::fuzz
