// The `stereo` subcommand of the `simulate` tool (docs/simulate-stereo.md): a thin CLI11
// wrapper around sim::RunStereoSimulation, kept in its own translation unit so that the
// `simulate` app only registers it.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "sim/stereo_sim.h"

namespace lunarnav::apps {

/// The rig, scene and rendering options of a rendered sequence, as the command line gives them.
struct StereoRenderFlags {
  sim::StereoSimOptions options;
  std::vector<std::string> faults;
  bool no_distortion = false, no_rotation = false, no_exposure = false, no_quantize = false;
  /// The options with the flags applied. @throws std::invalid_argument for a bad --fault.
  sim::StereoSimOptions Resolved(bool quiet) const;
};

/// Adds the options `simulate stereo` and `simulate field-log` share: --fault, the rig
/// (--width ... --tilt), the realism switches, --noise, --rays, the terrain and truth cells,
/// --rock-density, --relief, --seed, -j.
void AddStereoRenderOptions(CLI::App* cmd, StereoRenderFlags* flags);

/// Adds `stereo` to `app` (options bound to state owned by the returned function). After
/// parsing, when the subcommand was given, call the returned function with the command line
/// (util::CommandLineJson) and the --quiet flag; it runs the simulation inside util::RunMain
/// and returns the exit code (0 ok, 1 internal error, 2 usage).
std::function<int(const nlohmann::json& invocation, bool quiet)> RegisterStereoCommand(CLI::App& app);

}  // namespace lunarnav::apps
