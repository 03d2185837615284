// The `field-log` subcommand of the `simulate` tool (docs/simulate.md#field-log): a thin CLI11
// wrapper around sim::RunFieldLogSimulation, in its own translation unit as `stereo` is.
#pragma once

#include <functional>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

namespace lunarnav::apps {

/// Adds `field-log` to `app`; as RegisterStereoCommand.
std::function<int(const nlohmann::json& invocation, bool quiet)> RegisterFieldLogCommand(CLI::App& app);

}  // namespace lunarnav::apps
