#include "util/cli.h"

#include <filesystem>
#include <iostream>
#include <string>
#include <tuple>

#include "util/errors.h"
#include "util/log.h"
#include "util/parse.h"
#include "util/shard.h"
#include "util/version.h"

namespace lunarnav::util {

void AddCommonFlags(CLI::App* app, bool* quiet) {
  app->add_flag("-q,--quiet", *quiet, "no progress and no summary line (errors still print)");
  app->set_version_flag("--version", std::string(kVersion) + " (" + kGitRevision + ")");
}

void AddBatchFlags(CLI::App* app, const std::string& resume_help, bool* resume, std::string* shard,
                   int* threads) {
  app->add_flag("--resume", *resume, resume_help);
  app->add_option("--shard", *shard,
                  "K/N: process pairs K, K+N, K+2N, ... (0 <= K < N); auto: K and N from a Slurm job array; "
                  "auto/N: K from the Slurm array task id or GNU parallel's PARALLEL_SEQ (docs/cluster.md)");
  app->add_option("-j,--threads", *threads, "worker threads (0 = all cores)")->capture_default_str();
}

void AddMaxPixelsFlag(CLI::App* app, long long* max_pixels) {
  app->add_option("--max-pixels", *max_pixels,
                  "refuse images whose header claims more pixels than this (width x height), before reading them")
      ->capture_default_str();
}

void ApplyShard(const std::string& shard, int* index, int* count) {
  if (shard.empty()) return;
  const ShardSpec spec = ParseShard(shard);
  *index = spec.index;
  *count = spec.count;
  LN_LOG(Info) << "shard " << spec.index << " of " << spec.count << " (" << spec.source << ")";
}

std::optional<int> ParseCommandLine(CLI::App* app, int argc, char** argv, const bool& quiet) {
  try {
    app->parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app->exit(e) == 0 ? kExitOk : kExitUsage;  // --help, --version
    // One line with the prefix every other error has.
    std::cerr << "error: " << e.what() << " (" << std::filesystem::path(app->get_name()).filename().string()
              << " --help lists the options)\n";
    return kExitUsage;
  }
  if (quiet) SetLogLevel(LogLevel::kWarning);
  return std::nullopt;
}

nlohmann::json CommandLineJson(int argc, char** argv) {
  nlohmann::json args = nlohmann::json::array();
  for (int i = 0; i < argc; ++i) args.push_back(argv[i]);
  return args;
}

}  // namespace lunarnav::util
