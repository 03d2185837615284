// The common head of every tool's summary.json.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

namespace lunarnav::util {

/// The keys every tool's summary.json starts with: `tool` (e.g. "stereo-batch"), `version`,
/// `git_revision` and `invocation` (the command line, as util::CommandLineJson gives it).
nlohmann::json SummaryHead(const std::string& tool, const nlohmann::json& invocation);

}  // namespace lunarnav::util
