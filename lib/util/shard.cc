#include "util/shard.h"

#include <cstdlib>
#include <stdexcept>
#include <tuple>

#include "util/check.h"
#include "util/parse.h"

namespace lunarnav::util {
namespace {

constexpr const char* kAutoHelp =
    " (--shard auto reads a Slurm job array's SLURM_ARRAY_TASK_ID, SLURM_ARRAY_TASK_MIN and "
    "SLURM_ARRAY_TASK_COUNT; --shard auto/N reads SLURM_ARRAY_TASK_ID or GNU parallel's PARALLEL_SEQ)";

// The integer value of an environment variable, or nullopt when it is unset.
std::optional<int> IntVariable(const EnvironmentLookup& env, const std::string& name) {
  const std::optional<std::string> value = env(name);
  if (!value) return std::nullopt;
  return ParseInt(*value, "--shard auto: " + name);
}

void CheckInRange(int index, int count, const std::string& from) {
  LN_CHECK_ARG(count >= 1 && index >= 0 && index < count)
      << "--shard: " << from << " gives shard " << index << " of " << count << ", need 0 <= K < N";
}

}  // namespace

std::optional<std::string> GetEnvironmentVariable(const std::string& name) {
  const char* value = std::getenv(name.c_str());
  if (value == nullptr) return std::nullopt;
  return std::string(value);
}

ShardSpec ParseShard(const std::string& text, const EnvironmentLookup& env) {
  ShardSpec spec;
  if (text.empty()) return spec;
  if (text != "auto" && text.rfind("auto/", 0) != 0) {
    std::tie(spec.index, spec.count) = ParseIntPair(text, '/', "--shard");
    CheckInRange(spec.index, spec.count, "--shard " + text);
    spec.source = "--shard " + text;
    return spec;
  }
  std::optional<int> given_count;
  if (text != "auto") {
    given_count = ParseInt(text.substr(5), "--shard auto/N: N");
    LN_CHECK_ARG(*given_count >= 1) << "--shard auto/N: N must be >= 1, got " << *given_count;
  }
  const std::optional<int> task_id = IntVariable(env, "SLURM_ARRAY_TASK_ID");
  const std::optional<int> parallel_seq = IntVariable(env, "PARALLEL_SEQ");
  LN_CHECK_ARG(!(task_id && parallel_seq))
      << "--shard " << text << ": both SLURM_ARRAY_TASK_ID (" << *task_id << ") and PARALLEL_SEQ ("
      << *parallel_seq << ") are set; give the shard explicitly with --shard K/N";
  const std::string job = env("SLURM_ARRAY_JOB_ID").value_or("?");
  if (task_id && given_count) {
    spec.index = *task_id;
    spec.count = *given_count;
    CheckInRange(spec.index, spec.count, "SLURM_ARRAY_TASK_ID=" + std::to_string(*task_id));
    spec.source = "Slurm array job " + job + ", task " + std::to_string(*task_id) + " (--shard " + text + ")";
    return spec;
  }
  if (task_id) {
    const std::optional<int> min = IntVariable(env, "SLURM_ARRAY_TASK_MIN");
    const std::optional<int> count = IntVariable(env, "SLURM_ARRAY_TASK_COUNT");
    const int step = IntVariable(env, "SLURM_ARRAY_TASK_STEP").value_or(1);
    LN_CHECK_ARG(min && count)
        << "--shard auto: SLURM_ARRAY_TASK_ID is set but SLURM_ARRAY_TASK_"
        << (min ? "COUNT" : "MIN") << " is not (Slurm 17.02 or later sets both); give --shard auto/N";
    LN_CHECK_ARG(step >= 1 && (*task_id - *min) % step == 0)
        << "--shard auto: task " << *task_id << " of an array from " << *min << " in steps of " << step
        << " is not on the array's steps; give --shard auto/N";
    spec.index = (*task_id - *min) / step;
    spec.count = *count;
    // An array given as a list ("--array=0,5,9") is not a range: its last task would fall outside.
    const std::optional<int> max = IntVariable(env, "SLURM_ARRAY_TASK_MAX");
    LN_CHECK_ARG(!max || *min + (*count - 1) * step == *max)
        << "--shard auto: the array " << *min << "-" << *max << " (" << *count
        << " tasks) is not an evenly stepped range; submit --array=0-" << *count - 1
        << " or give --shard auto/N";
    CheckInRange(spec.index, spec.count,
                 "SLURM_ARRAY_TASK_ID=" + std::to_string(*task_id) + " (array from " + std::to_string(*min) +
                     ", " + std::to_string(*count) + " tasks)");
    spec.source = "Slurm array job " + job + ", task " + std::to_string(*task_id) + " (tasks " +
                  std::to_string(*min) + "-" + std::to_string(*min + (*count - 1) * step) + ")";
    return spec;
  }
  if (parallel_seq) {
    LN_CHECK_ARG(given_count) << "--shard auto: GNU parallel (PARALLEL_SEQ=" << *parallel_seq
                              << ") does not tell the number of jobs; give it with --shard auto/N";
    spec.index = *parallel_seq - 1;
    spec.count = *given_count;
    CheckInRange(spec.index, spec.count, "PARALLEL_SEQ=" + std::to_string(*parallel_seq) + " (minus 1)");
    spec.source = "GNU parallel job " + std::to_string(*parallel_seq) + " (--shard " + text + ")";
    return spec;
  }
  throw std::invalid_argument("--shard " + text + ": not started by a scheduler: no SLURM_ARRAY_TASK_ID" +
                              (given_count ? " or PARALLEL_SEQ" : "") + " in the environment" + kAutoHelp);
}

}  // namespace lunarnav::util
