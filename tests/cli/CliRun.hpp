// Runs the volcl executable (VOLCL_EXE) for the command-line tests and reads back what it printed.
#pragma once

#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace volcl::test {

struct RunResult {
    int exitCode;
    std::string out, err;
};

inline std::string slurp(const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

/// `volcl ARGS` with stdout and stderr captured in `dir` (stdout.txt, stderr.txt) and no stdin; with
/// `inDir` the command also runs in `dir`, so relative names in ARGS are files there.
inline RunResult runVolcl(const std::string& args, const std::filesystem::path& dir, bool inDir = false) {
    const auto out = dir / "stdout.txt", err = dir / "stderr.txt";
    const std::string cmd = (inDir ? "cd " + dir.string() + " && " : std::string()) + std::string(VOLCL_EXE) +
                            " " + args + " >" + out.string() + " 2>" + err.string() + " </dev/null";
    const int status = std::system(cmd.c_str());
    const int code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    return {code, slurp(out), slurp(err)};
}

inline bool has(const std::string& text, const std::string& what) {
    return text.find(what) != std::string::npos;
}

} // namespace volcl::test
