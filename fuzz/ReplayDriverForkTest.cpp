// Test of the replay driver (fuzz/ReplayDriver.cpp) against a target that forks, as the OpenVDB reader does:
// a child that dies of a fatal signal is the target's business, so the driver's crash hook, inherited by
// the child, must not save a crash-<pid> file for it. Runs as a ctest on one input; exits non-zero if the
// child's death left a crash file or the child did not die of the signal.
#include <csignal>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include <sys/wait.h>
#include <unistd.h>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t*, std::size_t) {
    const pid_t child = ::fork();
    if (child < 0) {
        std::perror("fork");
        std::exit(1);
    }
    if (child == 0) {
        std::raise(SIGSEGV); // reaches the driver's SIGSEGV handler, inherited across fork
        ::_exit(0);
    }
    int status = 0;
    while (::waitpid(child, &status, 0) < 0) {
    }
    if (!WIFSIGNALED(status) || WTERMSIG(status) != SIGSEGV) {
        std::fprintf(stderr, "forked child did not die of SIGSEGV (status %d)\n", status);
        std::exit(1);
    }
    const std::string crashFile = "crash-" + std::to_string(child);
    if (::access(crashFile.c_str(), F_OK) == 0) {
        std::fprintf(stderr, "the driver saved %s for the forked child's death\n", crashFile.c_str());
        std::remove(crashFile.c_str());
        std::exit(1);
    }
    return 0;
}
