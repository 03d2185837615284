#include "util/shard.h"

#include <gtest/gtest.h>

#include <map>
#include <stdexcept>
#include <string>

namespace lunarnav::util {
namespace {

// An environment holding exactly `vars`.
EnvironmentLookup Env(std::map<std::string, std::string> vars) {
  return [vars = std::move(vars)](const std::string& name) -> std::optional<std::string> {
    const auto it = vars.find(name);
    if (it == vars.end()) return std::nullopt;
    return it->second;
  };
}

// The message of the std::invalid_argument `f` throws ("" when it throws none).
template <typename F>
std::string InvalidArgumentMessage(F f) {
  try {
    f();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(ParseShard, ExplicitShardIgnoresTheEnvironment) {
  const ShardSpec spec = ParseShard("2/5", Env({{"SLURM_ARRAY_TASK_ID", "0"}}));
  EXPECT_EQ(spec.index, 2);
  EXPECT_EQ(spec.count, 5);
  EXPECT_EQ(spec.source, "--shard 2/5");
  const ShardSpec none = ParseShard("", Env({}));
  EXPECT_EQ(none.index, 0);
  EXPECT_EQ(none.count, 1);
  EXPECT_NE(InvalidArgumentMessage([] { ParseShard("5/5", Env({})); }), "");
  EXPECT_NE(InvalidArgumentMessage([] { ParseShard("1-4", Env({})); }), "");
}

TEST(ParseShard, SlurmArrayGivesEveryShardOnceWhateverItsFirstIndex) {
  // --array=0-3, --array=1-4 and --array=10-16:2 are each four shards 0..3.
  for (const auto& [min, step] : {std::pair{0, 1}, {1, 1}, {10, 2}}) {
    for (int task = 0; task < 4; ++task) {
      const int id = min + task * step;
      const ShardSpec spec = ParseShard(
          "auto", Env({{"SLURM_ARRAY_TASK_ID", std::to_string(id)}, {"SLURM_ARRAY_TASK_MIN", std::to_string(min)},
                       {"SLURM_ARRAY_TASK_MAX", std::to_string(min + 3 * step)},
                       {"SLURM_ARRAY_TASK_STEP", std::to_string(step)}, {"SLURM_ARRAY_TASK_COUNT", "4"},
                       {"SLURM_ARRAY_JOB_ID", "57"}}));
      EXPECT_EQ(spec.index, task) << "array from " << min << " step " << step;
      EXPECT_EQ(spec.count, 4);
      EXPECT_NE(spec.source.find("Slurm array job 57, task " + std::to_string(id)), std::string::npos) << spec.source;
    }
  }
}

TEST(ParseShard, SlurmWithAGivenCountTakesTheTaskIdAsTheShard) {
  // A failed shard resubmitted alone (--array=2) is shard 2 of the original 4.
  const auto env = Env({{"SLURM_ARRAY_TASK_ID", "2"}, {"SLURM_ARRAY_TASK_MIN", "2"}, {"SLURM_ARRAY_TASK_COUNT", "1"}});
  const ShardSpec spec = ParseShard("auto/4", env);
  EXPECT_EQ(spec.index, 2);
  EXPECT_EQ(spec.count, 4);
  EXPECT_EQ(ParseShard("auto", env).count, 1);  // what plain auto would make of it
  EXPECT_NE(InvalidArgumentMessage([&] { ParseShard("auto/2", env); }).find("SLURM_ARRAY_TASK_ID=2"),
            std::string::npos);
}

TEST(ParseShard, GnuParallelNeedsTheCount) {
  const ShardSpec spec = ParseShard("auto/3", Env({{"PARALLEL_SEQ", "3"}}));
  EXPECT_EQ(spec.index, 2);  // PARALLEL_SEQ counts from 1
  EXPECT_EQ(spec.count, 3);
  EXPECT_NE(InvalidArgumentMessage([] { ParseShard("auto", Env({{"PARALLEL_SEQ", "1"}})); }).find("auto/N"),
            std::string::npos);
  EXPECT_NE(InvalidArgumentMessage([] { ParseShard("auto/3", Env({{"PARALLEL_SEQ", "4"}})); }), "");
}

TEST(ParseShard, ClearErrorsWhenNoSchedulerOrAnAmbiguousOne) {
  const std::string none = InvalidArgumentMessage([] { ParseShard("auto", Env({})); });
  EXPECT_NE(none.find("not started by a scheduler"), std::string::npos) << none;
  EXPECT_NE(none.find("SLURM_ARRAY_TASK_ID"), std::string::npos) << none;
  const std::string both = InvalidArgumentMessage(
      [] { ParseShard("auto/2", Env({{"SLURM_ARRAY_TASK_ID", "0"}, {"PARALLEL_SEQ", "1"}})); });
  EXPECT_NE(both.find("both"), std::string::npos) << both;
  EXPECT_NE(InvalidArgumentMessage([] { ParseShard("auto", Env({{"SLURM_ARRAY_TASK_ID", "x"}})); }), "");
  EXPECT_NE(InvalidArgumentMessage([] { ParseShard("auto/0", Env({{"PARALLEL_SEQ", "1"}})); }), "");
  // A list of tasks (--array=0,5,9) is not a range of shards.
  const std::string list = InvalidArgumentMessage([] {
    ParseShard("auto", Env({{"SLURM_ARRAY_TASK_ID", "5"}, {"SLURM_ARRAY_TASK_MIN", "0"}, {"SLURM_ARRAY_TASK_MAX", "9"},
                            {"SLURM_ARRAY_TASK_COUNT", "3"}}));
  });
  EXPECT_NE(list.find("evenly stepped"), std::string::npos) << list;
}

}  // namespace
}  // namespace lunarnav::util
