// Integration tests of sharded batches and shard-merge (issue 20): shards taken from the
// scheduler's variables, merged into the single run's summary, a killed shard completed with
// --resume, and the merges that must be refused.
#include <gtest/gtest.h>

#include <signal.h>
#include <stdlib.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "integration/compare_outputs.h"
#include "integration/run_tool.h"
#include "io/json_io.h"
#include "util/testing.h"

namespace lunarnav {
namespace {
namespace fs = std::filesystem;
using testing::CompareOutputDirs;
using testing::RunTool;
using util::ScopedTempDir;
using util::TestDataPath;

// The stereo-batch options of every run here: subsampled, so that a pair takes little time.
const std::vector<std::string> kOptions = {"--step", "4x4", "-q"};

// `count` pairs made of the three testdata pairs, stems p100, p101, ... (with `prefix`).
fs::path MakePairs(const fs::path& dir, int count, const std::string& prefix = "p") {
  const char* stems[] = {"frame0000", "frame0001", "frame0002"};
  for (const char* side : {"left", "right"}) {
    fs::create_directories(dir / side);
    for (int i = 0; i < count; ++i) {
      fs::copy_file(TestDataPath("stereo_pairs") / side / (std::string(stems[i % 3]) + ".png"),
                    dir / side / (prefix + std::to_string(100 + i) + ".png"));
    }
  }
  return dir;
}

// Sets environment variables for its lifetime (the tools inherit them), and clears the
// scheduler's own, so that a test run under Slurm or GNU parallel sees only these.
class ScopedEnvironment {
 public:
  explicit ScopedEnvironment(const std::map<std::string, std::string>& vars) {
    for (const char* name : {"SLURM_ARRAY_TASK_ID", "SLURM_ARRAY_TASK_MIN", "SLURM_ARRAY_TASK_MAX",
                             "SLURM_ARRAY_TASK_STEP", "SLURM_ARRAY_TASK_COUNT", "SLURM_ARRAY_JOB_ID",
                             "PARALLEL_SEQ"}) {
      unsetenv(name);
    }
    for (const auto& [name, value] : vars) {
      setenv(name.c_str(), value.c_str(), 1);
      names_.push_back(name);
    }
  }
  ~ScopedEnvironment() {
    for (const std::string& name : names_) unsetenv(name.c_str());
  }
  ScopedEnvironment(const ScopedEnvironment&) = delete;
  ScopedEnvironment& operator=(const ScopedEnvironment&) = delete;

 private:
  std::vector<std::string> names_;
};

testing::ToolRun StereoBatch(const fs::path& in, const fs::path& out, const fs::path& scratch,
                             std::vector<std::string> extra = {}) {
  std::vector<std::string> args = {in.string(), "-o", out.string()};
  args.insert(args.end(), kOptions.begin(), kOptions.end());
  args.insert(args.end(), extra.begin(), extra.end());
  return RunTool("stereo-batch", args, scratch);
}

// Task `task` of a Slurm array of `count` tasks numbered from 1 (--array=1-count).
std::map<std::string, std::string> SlurmTask(int task, int count) {
  return {{"SLURM_ARRAY_TASK_ID", std::to_string(1 + task)}, {"SLURM_ARRAY_TASK_MIN", "1"},
          {"SLURM_ARRAY_TASK_MAX", std::to_string(count)},   {"SLURM_ARRAY_TASK_COUNT", std::to_string(count)},
          {"SLURM_ARRAY_TASK_STEP", "1"},                     {"SLURM_ARRAY_JOB_ID", "4242"}};
}

TEST(ShardMerge, ShardsFromASlurmArrayMergeIntoTheSingleRun) {
  ScopedTempDir tmp;
  const fs::path in = MakePairs(tmp.path() / "pairs", 10);
  const fs::path single = tmp.path() / "single", sharded = tmp.path() / "sharded";
  ASSERT_EQ(StereoBatch(in, single, tmp.path()).exit_code, 0);
  for (int task = 0; task < 4; ++task) {
    ScopedEnvironment env(SlurmTask(task, 4));
    const auto run = StereoBatch(in, sharded, tmp.path(), {"--shard", "auto", "-j", "1"});
    ASSERT_EQ(run.exit_code, 0) << run.stderr_text;
    ASSERT_TRUE(fs::exists(sharded / ("summary.shard-" + std::to_string(task) + "-of-4.json")));
  }
  // 10 pairs over 4 shards: 3, 3, 2, 2.
  EXPECT_EQ(io::ReadJson(sharded / "summary.shard-3-of-4.json")["counts"]["pairs_in_shard"], 2);
  const auto merge = RunTool("shard-merge", {sharded.string(), "-q"}, tmp.path());
  ASSERT_EQ(merge.exit_code, 0) << merge.stderr_text;
  EXPECT_EQ(merge.ErrorLines(), 0);
  // Every output, summary.json included, as the single run's (timings and the like aside).
  const std::vector<std::string> differences = CompareOutputDirs(single, sharded);
  EXPECT_TRUE(differences.empty()) << differences.front();
  const nlohmann::json summary = io::ReadJson(sharded / "summary.json");
  EXPECT_EQ(summary["merge"]["complete"], true);
  EXPECT_EQ(summary["merge"]["shards"].size(), 4u);
  EXPECT_EQ(summary["counts"]["pairs_ok"], 10);
  EXPECT_EQ(summary["merge"]["shards"][1]["invocation"].back(), "1");  // -j 1 of shard 1's command line
}

TEST(ShardMerge, AKilledShardIsReportedAndResumeCompletesTheSet) {
  ScopedTempDir tmp;
  const fs::path in = MakePairs(tmp.path() / "pairs", 10);
  const fs::path single = tmp.path() / "single", out = tmp.path() / "out";
  ASSERT_EQ(StereoBatch(in, single, tmp.path()).exit_code, 0);
  {
    ScopedEnvironment env(std::map<std::string, std::string>{{"PARALLEL_SEQ", "1"}});  // GNU parallel's job 1: shard 0 of 2
    ASSERT_EQ(StereoBatch(in, out, tmp.path(), {"--shard", "auto/2"}).exit_code, 0);
  }
  // Shard 1 (p101, p103, ... p109) killed once its first pair is written: no shard summary,
  // some pairs done. One thread, so that the other pairs are still to do.
  const std::string tool = util::ToolPath("stereo-batch").string();
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    execl(tool.c_str(), tool.c_str(), in.c_str(), "-o", out.c_str(), "--step", "4x4", "-q", "--shard", "1/2", "-j",
          "1", static_cast<char*>(nullptr));
    _exit(127);
  }
  const fs::path first_sidecar = out / "disparity" / "p101.json";
  for (int i = 0; i < 30000 && !fs::exists(first_sidecar); ++i) {  // at most 60 s
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  kill(pid, SIGKILL);
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(fs::exists(first_sidecar));
  if (fs::exists(out / "summary.shard-1-of-2.json")) GTEST_SKIP() << "the shard finished before it was killed";

  const auto incomplete = RunTool("shard-merge", {out.string()}, tmp.path());
  EXPECT_EQ(incomplete.exit_code, 4) << incomplete.stderr_text;
  EXPECT_NE(incomplete.stderr_text.find("shard 1/2 missing"), std::string::npos) << incomplete.stderr_text;
  EXPECT_NE(incomplete.stderr_text.find("pair p109 (shard 1/2): not done"), std::string::npos)
      << incomplete.stderr_text;  // named from the input directory
  nlohmann::json summary = io::ReadJson(out / "summary.json");
  EXPECT_EQ(summary["merge"]["complete"], false);
  EXPECT_EQ(summary["merge"]["pairs_never_done"], 5);
  EXPECT_EQ(summary["merge"]["missing_shards"], nlohmann::json({"1/2"}));

  ASSERT_EQ(StereoBatch(in, out, tmp.path(), {"--shard", "1/2", "--resume"}).exit_code, 0);
  const auto merged = RunTool("shard-merge", {out.string(), "-q"}, tmp.path());
  ASSERT_EQ(merged.exit_code, 0) << merged.stderr_text;
  summary = io::ReadJson(out / "summary.json");
  EXPECT_EQ(summary["merge"]["complete"], true);
  EXPECT_GE(summary["counts"]["pairs_resumed"], 1);  // the killed shard's finished pairs
  EXPECT_EQ(summary["counts"]["pairs_ok"].get<int>() + summary["counts"]["pairs_resumed"].get<int>(), 10);
  // The pairs' files are the single run's; only the summary differs (pairs resumed).
  for (const std::string& d : CompareOutputDirs(single, out)) EXPECT_EQ(d.rfind("summary.json", 0), 0u) << d;
}

TEST(ShardMerge, RefusesShardsRunWithOtherOptions) {
  ScopedTempDir tmp;
  const fs::path in = MakePairs(tmp.path() / "pairs", 4);
  const fs::path out = tmp.path() / "out";
  ASSERT_EQ(StereoBatch(in, out, tmp.path(), {"--shard", "0/2"}).exit_code, 0);
  ASSERT_EQ(StereoBatch(in, out, tmp.path(), {"--shard", "1/2", "--median", "5"}).exit_code, 0);
  const auto merge = RunTool("shard-merge", {out.string()}, tmp.path());
  EXPECT_EQ(merge.exit_code, 3) << merge.stderr_text;
  EXPECT_EQ(merge.ErrorLines(), 1) << merge.stderr_text;
  EXPECT_NE(merge.stderr_text.find("summary.shard-1-of-2.json"), std::string::npos) << merge.stderr_text;
  EXPECT_NE(merge.stderr_text.find("'options'"), std::string::npos) << merge.stderr_text;
  EXPECT_NE(merge.stderr_text.find("median"), std::string::npos) << merge.stderr_text;
  EXPECT_FALSE(fs::exists(out / "summary.json"));
}

TEST(ShardMerge, RefusesTwoBatchesShardedIntoOneDirectory) {
  ScopedTempDir tmp;
  const fs::path a = MakePairs(tmp.path() / "a", 4), b = MakePairs(tmp.path() / "b", 4, "q");
  const fs::path out = tmp.path() / "out";
  ASSERT_EQ(StereoBatch(a, out, tmp.path(), {"--shard", "0/2"}).exit_code, 0);
  ASSERT_EQ(StereoBatch(b, out, tmp.path(), {"--shard", "1/2"}).exit_code, 0);
  const auto merge = RunTool("shard-merge", {out.string()}, tmp.path());
  EXPECT_EQ(merge.exit_code, 3) << merge.stderr_text;
  EXPECT_EQ(merge.ErrorLines(), 1) << merge.stderr_text;
  EXPECT_NE(merge.stderr_text.find("two different batches"), std::string::npos) << merge.stderr_text;
  EXPECT_FALSE(fs::exists(out / "summary.json"));
}

TEST(ShardMerge, ShardAutoOutsideASchedulerIsAUsageError) {
  ScopedTempDir tmp;
  const fs::path in = MakePairs(tmp.path() / "pairs", 1);
  ScopedEnvironment env(std::map<std::string, std::string>{});
  const auto run = StereoBatch(in, tmp.path() / "out", tmp.path(), {"--shard", "auto"});
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_EQ(run.ErrorLines(), 1) << run.stderr_text;
  EXPECT_NE(run.stderr_text.find("SLURM_ARRAY_TASK_ID"), std::string::npos) << run.stderr_text;
  EXPECT_FALSE(fs::exists(tmp.path() / "out"));  // refused before anything was written
  fs::create_directories(tmp.path() / "out");
  const auto merge = RunTool("shard-merge", {(tmp.path() / "out").string()}, tmp.path());
  EXPECT_EQ(merge.exit_code, 3);  // nothing to merge
  EXPECT_NE(merge.stderr_text.find("no shard summaries"), std::string::npos) << merge.stderr_text;
}

}  // namespace
}  // namespace lunarnav
