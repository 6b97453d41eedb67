// Runs the volcl executable (VOLCL_EXE) for the command-line tests and reads back what it printed.
#pragma once

#include "../TestUtil.hpp"

#include <sys/wait.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <string>

namespace volcl::test {

struct RunResult {
    int exitCode;
    std::string out, err;
};

/// `EXE ARGS` with stdout and stderr captured in `dir` (stdout.txt, stderr.txt) and no stdin; with `inDir`
/// the command also runs in `dir`, so relative names in ARGS are files there.
inline RunResult runProgram(const std::string& exe, const std::string& args, const std::filesystem::path& dir,
                            bool inDir = false) {
    const auto out = dir / "stdout.txt", err = dir / "stderr.txt";
    const std::string cmd = (inDir ? "cd " + dir.string() + " && " : std::string()) + exe + " " + args +
                            " >" + out.string() + " 2>" + err.string() + " </dev/null";
    const int status = std::system(cmd.c_str());
    const int code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    return {code, readFile(out), readFile(err)};
}

/// `volcl ARGS`, as runProgram.
inline RunResult runVolcl(const std::string& args, const std::filesystem::path& dir, bool inDir = false) {
    return runProgram(VOLCL_EXE, args, dir, inDir);
}

inline bool has(const std::string& text, const std::string& what) {
    return text.find(what) != std::string::npos;
}

/// Lines printed (newlines counted): a refusal prints exactly one.
inline std::size_t lineCount(const std::string& s) {
    return static_cast<std::size_t>(std::count(s.begin(), s.end(), '\n'));
}

/// A path in single quotes for the shell command line.
inline std::string quoted(const std::filesystem::path& p) {
    return "'" + p.string() + "'";
}

} // namespace volcl::test
