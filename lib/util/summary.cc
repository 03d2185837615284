#include "util/summary.h"

#include "util/version.h"

namespace lunarnav::util {

nlohmann::json SummaryHead(const std::string& tool, const nlohmann::json& invocation) {
  return {{"tool", tool}, {"version", kVersion}, {"git_revision", kGitRevision}, {"invocation", invocation}};
}

}  // namespace lunarnav::util
