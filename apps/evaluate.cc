// evaluate: results against ground truth -> the paper's tables and figures.
// docs/evaluate.md describes every subcommand, option and output.
#include <filesystem>
#include <string>
#include <vector>

#include "evaluation/disparity_eval.h"
#include "io/atomic_file.h"
#include "io/json_io.h"
#include "util/cli.h"
#include "util/errors.h"
#include "util/log.h"
#include "util/run_main.h"
#include "util/timer.h"
#include "util/version.h"

namespace fs = std::filesystem;
using namespace lunarnav;
using nlohmann::json;

namespace {

// The summary.json every subcommand writes next to its tables.
json SummaryHead(const std::string& subcommand, int argc, char** argv) {
  return {{"tool", "evaluate"},
          {"subcommand", subcommand},
          {"version", kVersion},
          {"git_revision", kGitRevision},
          {"invocation", util::CommandLineJson(argc, argv)}};
}

struct DisparityArgs {
  fs::path results, truth, masks, output_dir;
  std::vector<double> thresholds;
  evaluation::DisparityEvalOptions options;
};

int RunDisparity(const DisparityArgs& args, int argc, char** argv) {
  util::Timer timer;
  evaluation::DisparityEvalOptions options = args.options;
  if (!args.thresholds.empty()) options.bad_thresholds_px = args.thresholds;
  options.Validate();
  io::CreateOutputDirectory(args.output_dir);
  const auto items = evaluation::EvaluateDisparityDirectories(args.results, args.truth, args.masks, options);
  int failed = 0;
  json failed_json = json::array();
  for (const auto& item : items) {
    if (item.problem.empty()) continue;
    ++failed;
    LN_LOG(Error) << "pair " << item.stem << ": " << item.problem;
    failed_json.push_back({{"stem", item.stem}, {"error", item.problem}});
  }
  const evaluation::Table table = evaluation::DisparityTable(items, options);
  evaluation::WriteTable(args.output_dir, "disparity", table);
  json summary = SummaryHead("disparity", argc, argv);
  summary["inputs"] = {{"results", args.results.string()},
                       {"truth", args.truth.string()},
                       {"masks", args.masks.string()}};
  summary["options"] = {{"bad_thresholds_px", options.bad_thresholds_px},
                        {"png_truth_scale", options.png_truth_scale}};
  summary["counts"] = {{"stems", items.size()}, {"scored", items.size() - failed}, {"failed", failed}};
  summary["failed"] = failed_json;
  summary["table"] = table.ToJson();
  summary["timings_s"] = {{"total", timer.ElapsedSeconds()}};
  io::WriteJsonAtomic(args.output_dir / "summary.json", summary);
  LN_LOG(Info) << "evaluate disparity: " << items.size() - failed << " of " << items.size()
               << " pairs scored; " << (args.output_dir / "disparity.md").string();
  return failed > 0 ? kExitBatchPartial : kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "Scores lunarnav results against ground truth into the tables and figures of Krotkov &\n"
      "Hebert (1995). Each subcommand writes its table as CSV, JSON and Markdown, its figures\n"
      "as PNG with the data behind them as CSV, and summary.json, into OUT_DIR.\n"
      "Exit codes: 0 ok, 1 internal error, 2 usage, 3 bad input, 4 some items could not be scored."};
  app.require_subcommand(1);
  app.fallthrough();  // --quiet, --version also after the subcommand
  bool quiet = false;
  util::AddCommonFlags(&app, &quiet);

  DisparityArgs disparity;
  CLI::App* disparity_cmd = app.add_subcommand(
      "disparity", "disparity maps vs ground-truth disparity: density, bad-N %, mean and RMS error");
  disparity_cmd->add_option("RESULTS", disparity.results,
                            "stereo-batch output directory (disparity/<stem>.pfm) or a directory of .pfm files")
      ->required();
  disparity_cmd->add_option("--truth", disparity.truth,
                            "truth directory: <stem>.pfm or 16-bit <stem>.png (also under disparity/)")
      ->required();
  disparity_cmd->add_option("--masks", disparity.masks, "directory of <stem>.png masks (nonzero = evaluate)");
  disparity_cmd->add_option("--bad", disparity.thresholds, "bad-pixel thresholds, px (default 0.5 1 2 4)")
      ->delimiter(',');
  disparity_cmd->add_option("--png-scale", disparity.options.png_truth_scale,
                            "16-bit PNG truth holds disparity x this (KITTI: 256)")
      ->capture_default_str();
  disparity_cmd->add_option("-o,--output", disparity.output_dir, "output directory (created)")->required();

  if (const auto exit_code = util::ParseCommandLine(&app, argc, argv, quiet)) return *exit_code;
  return util::RunMain([&]() -> int {
    if (disparity_cmd->parsed()) return RunDisparity(disparity, argc, argv);
    return kExitUsage;
  });
}
