// Progress bar on stderr for long work; shown only when stderr is a terminal and --quiet is off.
#pragma once

#include <cstddef>
#include <string>

namespace volcl::cli {

/// Example: `Progress p("encode", bricks, global.quiet); for (...) { ...; p.advance(); }`
class Progress {
public:
    Progress(std::string label, std::size_t total, bool quiet);
    ~Progress(); ///< finishes the line; never throws
    Progress(const Progress&) = delete;
    Progress& operator=(const Progress&) = delete;
    void advance(std::size_t steps = 1);
    bool enabled() const noexcept { return enabled_; }

private:
    void draw();
    std::string label_;
    std::size_t total_, done_ = 0;
    int lastPercent_ = -1;
    bool enabled_;
};

} // namespace volcl::cli
