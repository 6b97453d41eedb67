// Progress bar implementation (carriage-return redraw, at most once per percent).
#include "apps/cli/Progress.hpp"

#include <algorithm>
#include <cstdio>
#include <unistd.h>

namespace volcl::cli {

Progress::Progress(std::string label, std::size_t total, bool quiet)
    : label_(std::move(label)), total_(total), enabled_(!quiet && total > 0 && isatty(STDERR_FILENO)) {
    if (enabled_) draw();
}

Progress::~Progress() {
    if (enabled_) std::fputc('\n', stderr);
}

void Progress::advance(std::size_t steps) {
    done_ += steps;
    if (enabled_) draw();
}

void Progress::draw() {
    int percent = total_ ? static_cast<int>(100.0 * double(std::min(done_, total_)) / double(total_)) : 100;
    if (percent == lastPercent_) return;
    lastPercent_ = percent;
    constexpr int kWidth = 30;
    int filled = percent * kWidth / 100;
    std::fprintf(stderr, "\r%s [%.*s%*s] %3d%%", label_.c_str(), filled, "##############################",
                 kWidth - filled, "", percent);
    std::fflush(stderr);
}

} // namespace volcl::cli
