// A temporary driver for `simulate stereo` until the `simulate` tool registers the
// subcommand (RegisterStereoCommand): `simulate-stereo-dev stereo ... -o DIR` takes the same
// arguments as `simulate stereo ... -o DIR`.
#include "apps/simulate_stereo_cli.h"
#include "util/cli.h"

int main(int argc, char** argv) {
  CLI::App app{"simulate (stereo only): synthetic data with exact ground truth"};
  bool quiet = false;
  const auto run_stereo = lunarnav::apps::RegisterStereoCommand(app);
  app.require_subcommand(1);
  lunarnav::util::AddCommonFlags(&app, &quiet);
  if (const auto exit_code = lunarnav::util::ParseCommandLine(&app, argc, argv, quiet)) return *exit_code;
  return run_stereo(lunarnav::util::CommandLineJson(argc, argv), quiet);
}
