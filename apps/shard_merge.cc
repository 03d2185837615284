// shard-merge: the shard summaries of a batch's output directory (summary.shard-K-of-N.json
// from stereo-batch, rectify, ... run with --shard) merged into summary.json, with the checks
// that the shards are one batch and did every item once. docs/cluster.md describes it.
#include <filesystem>
#include <string>

#include "io/shard_merge.h"
#include "util/cli.h"
#include "util/errors.h"
#include "util/log.h"
#include "util/run_main.h"

namespace fs = std::filesystem;
using namespace lunarnav;

int main(int argc, char** argv) {
  CLI::App app{
      "Merges the shard summaries (summary.shard-K-of-N.json) that a batch tool run with --shard\n"
      "wrote into OUT_DIR into OUT_DIR/summary.json: counts, timings, failed items; checks that\n"
      "every shard ran the same tool, version, options and input listing (else exit 3) and lists\n"
      "missing shards and items done twice or never.\n"
      "Exit codes: 0 complete, 1 internal error, 2 usage, 3 shards of different batches or\n"
      "unreadable, 4 incomplete (shards missing or items failed; summary.json still written)."};
  io::ShardMergeOptions opt;
  fs::path output_dir;
  bool quiet = false;
  app.add_option("OUT_DIR", output_dir, "the batch's output directory, holding summary.shard-K-of-N.json")
      ->required();
  app.add_option("--input", opt.input_dir,
                 "the batch's input directory, to name the items of missing shards (default: the input_dir "
                 "the shards recorded)");
  app.add_option("-j,--threads", opt.num_threads, "threads reading the shard summaries (0 = all cores)")
      ->capture_default_str();
  util::AddCommonFlags(&app, &quiet);
  if (const auto exit_code = util::ParseCommandLine(&app, argc, argv, quiet)) return *exit_code;

  return util::RunMain([&] {
    const io::ShardMergeResult result = io::MergeShardSummaries(output_dir, opt, util::CommandLineJson(argc, argv));
    LN_LOG(Info) << "shard-merge: " << result.BriefReport() << "; summary in " << result.summary_path.string();
    return result.Complete() ? kExitOk : kExitBatchPartial;
  });
}
