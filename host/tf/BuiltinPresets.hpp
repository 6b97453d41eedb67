// Built-in colour-map presets, embedded as ParaView colour-map JSON normalised to [0, 1].
#pragma once

#include <string_view>
#include <vector>

namespace volcl {

/// The preset's ParaView JSON, or an empty view for an unknown name.
std::string_view builtinPresetJson(std::string_view name);
/// Every built-in preset's name, in the order `--help` lists them.
std::vector<std::string_view> builtinPresetNames();

} // namespace volcl
