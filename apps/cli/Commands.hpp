// Subcommand registration for the volcl executable; each group lives in its own file.
#pragma once

#include "core/Volume.hpp"

#include <CLI/CLI.hpp>

#include <ostream>

#include <functional>
#include <string>

namespace volcl::cli {

/// Options shared by every subcommand (set before the subcommand callback runs).
struct GlobalOptions {
    std::string device; ///< --device, else $VOLCL_DEVICE, else the first device
    bool quiet = false; ///< --quiet: no progress bar
};

/// Each add* function adds its subcommands to `app`; `volcl bench` is a module of its own (apps/bench).
/// Callbacks throw volcl::Error subclasses; main() turns them into exit codes and one-line messages.
void addInfoCommands(CLI::App& app, GlobalOptions& global);    // info, devices, convert
void addDemoCommand(CLI::App& app, GlobalOptions& global);     // demo
void addGenerateCommand(CLI::App& app, GlobalOptions& global); // generate cloud
void addPreintCommands(CLI::App& app, GlobalOptions& global);  // preint
void addCodecCommands(CLI::App& app, GlobalOptions& global);   // encode, decode, compare
void addViewCommand(CLI::App& app, GlobalOptions& global);     // view
void addRenderCommands(CLI::App& app, GlobalOptions& global);  // render

/// Puts a worked example at the foot of every subcommand's --help (after all subcommands are added).
void addHelpExamples(CLI::App& app);

/// Prints `volcl info` for a series (text, or JSON when `json`); used by info and demo.
void printVolumeInfo(std::ostream& out, const std::string& path, const TimeSeries& ts, bool json, bool quiet);

} // namespace volcl::cli
