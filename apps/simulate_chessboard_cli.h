// The `chessboard` subcommand of the `simulate` tool (docs/simulate.md): a thin CLI11 wrapper
// around sim::RunChessboardSimulation, kept in its own translation unit so that the
// `simulate` app only registers it.
#pragma once

#include <functional>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

namespace lunarnav::apps {

/// Adds `chessboard` to `app` (options bound to state owned by the returned function). After
/// parsing, when the subcommand was given, call the returned function with the command line
/// (util::CommandLineJson) and the --quiet flag; it runs the simulation inside util::RunMain
/// and returns the exit code (0 ok, 1 internal error, 2 usage).
std::function<int(const nlohmann::json& invocation, bool quiet)> RegisterChessboardCommand(CLI::App& app);

}  // namespace lunarnav::apps
