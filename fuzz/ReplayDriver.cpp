// Plain fuzz driver for compilers without libFuzzer (GCC): replays a corpus, then runs a fixed number of
// mutated inputs from a fixed seed. Same entry point and flags as libFuzzer (-runs=N -seed=S -max_len=L
// -timeout=T, then corpus files or directories), so scripts drive either engine alike. No coverage
// feedback: it finds what random mutations of the seeds reach, under the sanitizers of the build.
#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include <fcntl.h>
#include <unistd.h>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);
extern "C" int LLVMFuzzerInitialize(int* argc, char*** argv) __attribute__((weak));
extern "C" void __sanitizer_set_death_callback(void (*callback)()) __attribute__((weak));

namespace {

using Bytes = std::vector<std::uint8_t>;

// The input being executed, for the crash handlers (plain pointers: they run in signal context).
const std::uint8_t* gCurrent = nullptr;
std::size_t gCurrentSize = 0;

// Saves the input that crashed or hung as ./crash-<pid> so it can become a regression file.
void dumpCurrentInput() {
    if (gCurrent == nullptr) {
        static const char msg[] =
            "replay: the failure came after the inputs ran (e.g. a leak found at exit)\n";
        (void)!::write(2, msg, sizeof(msg) - 1);
        return;
    }
    char name[64];
    std::snprintf(name, sizeof(name), "crash-%d", static_cast<int>(::getpid()));
    const int fd = ::open(name, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd >= 0) {
        std::size_t done = 0;
        while (done < gCurrentSize) {
            const ssize_t n = ::write(fd, gCurrent + done, gCurrentSize - done);
            if (n <= 0) break;
            done += static_cast<std::size_t>(n);
        }
        ::close(fd);
    }
    static const char msg[] = "replay: the failing input is saved as ./crash-<pid>\n";
    (void)!::write(2, msg, sizeof(msg) - 1);
}

void onFatalSignal(int sig) {
    if (sig == SIGALRM) {
        static const char msg[] = "replay: timeout (an input ran longer than -timeout)\n";
        (void)!::write(2, msg, sizeof(msg) - 1);
    }
    dumpCurrentInput();
    std::signal(sig == SIGALRM ? SIGABRT : sig, SIG_DFL);
    std::raise(sig == SIGALRM ? SIGABRT : sig);
}

void onTerminate() {
    static const char msg[] = "replay: uncaught exception escaped the target\n";
    (void)!::write(2, msg, sizeof(msg) - 1);
    if (auto e = std::current_exception()) {
        try {
            std::rethrow_exception(e);
        } catch (const std::exception& x) {
            std::cerr << "replay: " << x.what() << '\n';
        } catch (...) {
        }
    }
    dumpCurrentInput();
    std::abort();
}

Bytes readWhole(const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    return Bytes(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// One random edit of the kinds that break parsers: bit flips, boundary values, inserted, removed and
// duplicated ranges, truncation and splices with another corpus input.
void mutate(Bytes& b, const std::vector<Bytes>& corpus, std::mt19937_64& rng, std::size_t maxLen) {
    auto pick = [&](std::size_t n) { return n == 0 ? std::size_t{0} : static_cast<std::size_t>(rng() % n); };
    static const std::uint8_t kInteresting[] = {0,   1,   0x7f, 0x80, 0xff, '0', '9',
                                                '-', ' ', '\n', ':',  '%',  'e'};
    switch (rng() % 9) {
    case 0:
        if (!b.empty()) b[pick(b.size())] ^= static_cast<std::uint8_t>(1u << (rng() % 8));
        break;
    case 1:
        if (!b.empty()) b[pick(b.size())] = kInteresting[pick(sizeof(kInteresting))];
        break;
    case 2:
        if (!b.empty()) b[pick(b.size())] = static_cast<std::uint8_t>(rng());
        break;
    case 3: { // insert random bytes
        const std::size_t at = pick(b.size() + 1), n = 1 + pick(8);
        for (std::size_t i = 0; i < n; ++i)
            b.insert(b.begin() + static_cast<std::ptrdiff_t>(at), static_cast<std::uint8_t>(rng()));
        break;
    }
    case 4: { // erase a range
        if (b.empty()) break;
        const std::size_t at = pick(b.size()), n = 1 + pick(std::min<std::size_t>(16, b.size() - at));
        b.erase(b.begin() + static_cast<std::ptrdiff_t>(at), b.begin() + static_cast<std::ptrdiff_t>(at + n));
        break;
    }
    case 5: { // duplicate a range
        if (b.empty()) break;
        const std::size_t at = pick(b.size()), n = 1 + pick(std::min<std::size_t>(64, b.size() - at));
        Bytes piece(b.begin() + static_cast<std::ptrdiff_t>(at),
                    b.begin() + static_cast<std::ptrdiff_t>(at + n));
        b.insert(b.begin() + static_cast<std::ptrdiff_t>(pick(b.size() + 1)), piece.begin(), piece.end());
        break;
    }
    case 6:
        b.resize(pick(b.size() + 1)); // truncate
        break;
    case 7: { // a 32-bit boundary value at a random position
        if (b.size() < 4) break;
        static const std::uint32_t kWords[] = {0u, 1u, 0x7fffffffu, 0x80000000u, 0xffffffffu, 0x10000u, 348u};
        const std::uint32_t w = kWords[pick(std::size(kWords))];
        std::memcpy(b.data() + pick(b.size() - 3), &w, 4);
        break;
    }
    default: { // splice: the head of this input, the tail of another
        const Bytes& other = corpus[pick(corpus.size())];
        const std::size_t cut = pick(b.size() + 1), from = pick(other.size() + 1);
        b.resize(cut);
        b.insert(b.end(), other.begin() + static_cast<std::ptrdiff_t>(from), other.end());
        break;
    }
    }
    if (b.size() > maxLen) b.resize(maxLen);
}

void execute(const Bytes& input, unsigned timeoutSeconds) {
    gCurrent = input.data();
    gCurrentSize = input.size();
    ::alarm(timeoutSeconds);
    LLVMFuzzerTestOneInput(input.data(), input.size());
    ::alarm(0);
    // The input is freed after this: a sanitizer death outside a run (LeakSanitizer at exit) must not read
    // it.
    gCurrent = nullptr;
    gCurrentSize = 0;
}

} // namespace

int main(int argc, char** argv) {
    unsigned long long runs = 0, seed = 1, maxSeconds = 0;
    std::size_t maxLen = 1 << 16;
    unsigned timeout = 10;
    std::vector<std::filesystem::path> paths;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        auto value = [&](const char* flag) {
            return std::strtoull(a.c_str() + std::strlen(flag), nullptr, 10);
        };
        if (a.rfind("-runs=", 0) == 0)
            runs = value("-runs=");
        else if (a.rfind("-seed=", 0) == 0)
            seed = value("-seed=");
        else if (a.rfind("-max_len=", 0) == 0)
            maxLen = static_cast<std::size_t>(value("-max_len="));
        else if (a.rfind("-max_total_time=", 0) == 0)
            maxSeconds = value("-max_total_time=");
        else if (a.rfind("-timeout=", 0) == 0)
            timeout = static_cast<unsigned>(value("-timeout="));
        else if (a.rfind("-help=", 0) == 0) {
            std::cout << "ReplayDriver: replays corpus files/directories, then -runs=N mutations (-seed=S "
                         "-max_len=L -timeout=T -max_total_time=T)\n";
            return 0;
        } else if (!a.empty() && a[0] == '-')
            std::cerr << "replay: ignoring libFuzzer flag " << a << '\n';
        else
            paths.emplace_back(a);
    }
    std::signal(SIGALRM, onFatalSignal);
    std::signal(SIGSEGV, onFatalSignal);
    std::signal(SIGBUS, onFatalSignal);
    std::signal(SIGFPE, onFatalSignal);
    std::set_terminate(onTerminate);
    if (__sanitizer_set_death_callback) __sanitizer_set_death_callback(dumpCurrentInput);

    if (LLVMFuzzerInitialize) LLVMFuzzerInitialize(&argc, &argv);
    std::vector<Bytes> corpus;
    for (const auto& p : paths) {
        std::error_code ec;
        if (std::filesystem::is_directory(p, ec)) {
            std::vector<std::filesystem::path> files;
            for (const auto& e : std::filesystem::recursive_directory_iterator(p, ec))
                if (e.is_regular_file()) files.push_back(e.path());
            std::sort(files.begin(), files.end()); // the same order on every machine: runs are repeatable
            for (const auto& f : files)
                corpus.push_back(readWhole(f));
        } else if (std::filesystem::is_regular_file(p, ec)) {
            corpus.push_back(readWhole(p));
        } else {
            std::cerr << "replay: " << p.string() << " does not exist\n";
            return 2;
        }
    }
    const auto start = std::chrono::steady_clock::now();
    // Corpus inputs also pay one-time costs: loading the image module, and OpenCL kernel builds (each seed
    // may need kernel variants no earlier one built; on a cold kernel cache under the sanitizers one build
    // took longer than the 10 s default). Mutated inputs then mostly reuse them.
    for (const Bytes& input : corpus)
        execute(input, std::max(timeout, 120u));
    if (corpus.empty()) corpus.emplace_back();
    std::mt19937_64 rng(seed);
    // -max_total_time without -runs: mutate until the time is up, like libFuzzer.
    if (maxSeconds > 0 && runs == 0) runs = ~0ULL;
    unsigned long long done = 0;
    for (unsigned long long r = 0; r < runs; ++r, ++done) {
        if (maxSeconds > 0 && (r & 63) == 0 &&
            std::chrono::steady_clock::now() - start > std::chrono::seconds(maxSeconds))
            break;
        Bytes input = corpus[static_cast<std::size_t>(rng() % corpus.size())];
        const unsigned edits = 1 + static_cast<unsigned>(rng() % 4);
        for (unsigned e = 0; e < edits; ++e)
            mutate(input, corpus, rng, maxLen);
        execute(input, timeout);
    }
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::cerr << "replay: " << corpus.size() << " corpus inputs and " << done << " mutated executions in "
              << seconds << " s, no crash\n";
    return 0;
}
