// Command-line flags that build or override a Scene: shared by `volcl render`, `bench render` and `view`.
#pragma once

#include "host/cli/CliParsing.hpp"
#include "host/render/Scene.hpp"

#include <CLI/CLI.hpp>

#include <optional>
#include <string>
#include <vector>

namespace volcl::cli {

/// Comma-separated numbers; `count` 0 accepts any number of them. Throws UsageError naming `what`.
std::vector<double> parseNumbers(const std::string& text, std::size_t count, const std::string& what);
/// "x,y,z" -> Vec3; throws UsageError naming `what`.
Vec3 parseVec3(const std::string& text, const std::string& what);

/// Scene fields a command line may override; empty means "keep the scene's value".
struct SceneFlags {
    std::string scene, volume, tf, mode, preint, projection, eye, target, up, background;
    std::optional<double> step, viewHeight, fov, earlyTermination, shadowStep;
    std::optional<int> width, height, tableSize, tableLengths;
    bool noSkipping = false, sobel = false, shadows = false;
    std::string shading, scattering;
    std::vector<std::string> isos, lights, clips;
    RawReadFlags raw;

    /// Registers every scene flag on `cmd`.
    void add(CLI::App* cmd);
    /// The scene file (if any) with the flags applied, validated. Throws UsageError. `requireTf` false lets
    /// a scene without a transfer function through (the viewer then starts on a preset).
    Scene build(bool requireTf = true) const;
};

} // namespace volcl::cli
