// Integration tests of the evaluate tool.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "integration/run_tool.h"
#include "io/json_io.h"
#include "util/testing.h"

namespace lunarnav {
namespace {
namespace fs = std::filesystem;
using testing::RunTool;
using util::ScopedTempDir;
using util::TestDataPath;

TEST(EvaluateDisparity, ScoresStereoBatchOutputAgainstTheTestdataTruth) {
  ScopedTempDir tmp;
  const fs::path run = tmp.path() / "run", eval = tmp.path() / "eval";
  ASSERT_EQ(RunTool("stereo-batch", {TestDataPath("stereo_pairs").string(), "-o", run.string(), "-q"}, tmp.path())
                .exit_code, 0);
  const auto result = RunTool("evaluate", {"disparity", run.string(), "--truth",
                                           (TestDataPath("stereo_pairs") / "truth").string(), "-o", eval.string()},
                              tmp.path());
  ASSERT_EQ(result.exit_code, 0) << result.stderr_text;
  for (const char* ext : {".csv", ".json", ".md"}) EXPECT_TRUE(fs::exists(eval / (std::string("disparity") + ext)));
  const nlohmann::json summary = io::ReadJson(eval / "summary.json");
  EXPECT_EQ(summary["subcommand"], "disparity");
  EXPECT_EQ(summary["counts"]["scored"], 3);
  const nlohmann::json& all = summary["table"]["rows"][3];
  EXPECT_GT(all["density"].get<double>(), 60.0);
  EXPECT_LT(all["bad_1"].get<double>(), 5.0);  // the matcher on the fixture (see stereo_batch_test)

  // The truth scored against itself (stereo-batch maps of one run as truth of the same run).
  const auto self = RunTool("evaluate", {"disparity", run.string(), "--truth", run.string(), "-o",
                                         (tmp.path() / "self").string(), "-q"}, tmp.path());
  ASSERT_EQ(self.exit_code, 0) << self.stderr_text;
  const nlohmann::json self_all = io::ReadJson(tmp.path() / "self" / "summary.json")["table"]["rows"][3];
  EXPECT_EQ(self_all["bad_0.5"].get<double>(), 0.0);
  EXPECT_EQ(self_all["density"].get<double>(), 100.0);

  // A stem without truth: reported, n/a in the table, exit 4. No truth at all: exit 3.
  fs::copy_file(run / "disparity" / "frame0000.pfm", run / "disparity" / "extra.pfm");
  const auto partial = RunTool("evaluate", {"disparity", run.string(), "--truth",
                                            (TestDataPath("stereo_pairs") / "truth").string(), "-o", eval.string(),
                                            "-q"},
                               tmp.path());
  EXPECT_EQ(partial.exit_code, 4);
  EXPECT_EQ(partial.ErrorLines(), 1) << partial.stderr_text;
  EXPECT_NE(partial.stderr_text.find("extra"), std::string::npos);
  EXPECT_EQ(RunTool("evaluate", {"disparity", run.string(), "--truth", (tmp.path() / "none").string(), "-o",
                                 eval.string()}, tmp.path()).exit_code, 3);
  EXPECT_EQ(RunTool("evaluate", {"disparity", run.string(), "-o", eval.string()}, tmp.path()).exit_code, 2);
  EXPECT_EQ(RunTool("evaluate", {}, tmp.path()).exit_code, 2);
}

}  // namespace
}  // namespace lunarnav
