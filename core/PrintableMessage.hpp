// Terminal-safe one-line messages: control characters from file headers escaped before printing.
#pragma once

#include <string>
#include <string_view>

namespace volcl {

/// `message` made safe for a terminal and kept on one line: control characters (CR, LF, TAB, ESC, ...)
/// and DEL, which a hostile header can smuggle into an error message, become `\r`, `\n`, `\t`, `\x1b`.
/// The CLI prints every error through it.
std::string printableMessage(std::string_view message);

} // namespace volcl
