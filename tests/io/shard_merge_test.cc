#include "io/shard_merge.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "io/json_io.h"
#include "util/errors.h"
#include "util/testing.h"

namespace lunarnav::io {
namespace {
namespace fs = std::filesystem;
using nlohmann::json;

const std::vector<std::string> kNames = {"a", "b", "c", "d", "e"};

// The summary shard K of N of a batch over kNames would write, its items with `status`.
json ShardSummary(int k, int n, const json& options = {{"window", 3}}, const std::string& status = "ok") {
  json items = json::array();
  for (std::size_t i = k; i < kNames.size(); i += n) {
    json item = {{"stem", kNames[i]}, {"status", status}};
    if (status == "failed") {
      item["error"] = kNames[i] + ".png: truncated";
    } else {
      item["result"] = {{"pixels", 10 + static_cast<int>(i)}};
    }
    items.push_back(item);
  }
  return {{"tool", "stereo-batch"},
          {"version", "1"},
          {"input_dir", "in"},
          {"listing", ListingRecord("stereo-pairs", "pairs", kNames)},
          {"options", options},
          {"shard", {k, n}},
          {"threads", 2},
          {"invocation", {"stereo-batch", "--shard", std::to_string(k) + "/" + std::to_string(n)}},
          {"counts", {{"pairs_listed", 5}, {"pairs_in_shard", items.size()}, {"pixels", 0}}},
          {"timings_s", {{"total", 1.5}}},
          {"peak_memory_mib", 10.0 + k},
          {"failed", json::array()},
          {"pairs", items}};
}

void Write(const fs::path& dir, int k, int n, const json& summary) {
  WriteJsonAtomic(dir / ("summary.shard-" + std::to_string(k) + "-of-" + std::to_string(n) + ".json"), summary);
}

ShardMergeOptions NoRelisting() {
  ShardMergeOptions options;
  options.relist = [](const std::string&, const fs::path&) { return std::optional<std::vector<std::string>>(); };
  return options;
}

TEST(ListingDigest, DependsOnTheNamesAndTheirOrder) {
  EXPECT_EQ(ListingDigest({"a", "b"}), ListingDigest({"a", "b"}));
  EXPECT_NE(ListingDigest({"a", "b"}), ListingDigest({"b", "a"}));
  EXPECT_NE(ListingDigest({"ab"}), ListingDigest({"a", "b"}));  // names are delimited
  EXPECT_EQ(ListingDigest({}), "fnv1a64:cbf29ce484222325");     // the FNV-1a 64 offset basis
}

TEST(MergeShardSummaries, ACompleteSetIsTheSingleRunInListingOrder) {
  util::ScopedTempDir tmp;
  for (int k = 0; k < 3; ++k) Write(tmp.path(), k, 3, ShardSummary(k, 3));
  const ShardMergeResult r = MergeShardSummaries(tmp.path(), NoRelisting());
  EXPECT_TRUE(r.Complete());
  EXPECT_EQ(r.items_done, 5);
  EXPECT_TRUE(r.missing_shards.empty());
  const json s = ReadJson(tmp.path() / "summary.json");
  std::vector<std::string> order;
  for (const json& p : s["pairs"]) order.push_back(p["stem"]);
  EXPECT_EQ(order, kNames);
  EXPECT_EQ(s["shard"], json({0, 1}));
  EXPECT_EQ(s["counts"]["pairs_in_shard"], 5);
  EXPECT_EQ(s["counts"]["pixels"], 10 + 11 + 12 + 13 + 14);  // from the items' results
  EXPECT_DOUBLE_EQ(s["timings_s"]["total"].get<double>(), 4.5);
  EXPECT_DOUBLE_EQ(s["peak_memory_mib"].get<double>(), 12.0);
  EXPECT_EQ(s["threads"], 2);
  EXPECT_EQ(s["merge"]["shards"].size(), 3u);
}

// stereo-batch's per-stage timings (an array of {stage, seconds}) add up stage by stage, in
// the order the stages first appear; entries of another shape are left out.
TEST(MergeShardSummaries, SumsThePerStageTimingsStageByStage) {
  util::ScopedTempDir tmp;
  for (int k = 0; k < 2; ++k) {
    json summary = ShardSummary(k, 2);
    summary["timings_s"]["stages_sum"] = json::array({{{"stage", "decode"}, {"seconds", 1.0 + k}},
                                                      {{"stage", "match: census"}, {"seconds", 0.5}}});
    if (k == 1) {
      summary["timings_s"]["stages_sum"].push_back({{"stage", "write xyz (EXR)"}, {"seconds", 0.25}});
      summary["timings_s"]["stages_sum"].push_back(7);  // not a stage
    }
    Write(tmp.path(), k, 2, summary);
  }
  MergeShardSummaries(tmp.path(), NoRelisting());
  const json s = ReadJson(tmp.path() / "summary.json");
  const json expected = json::array({{{"stage", "decode"}, {"seconds", 3.0}},
                                     {{"stage", "match: census"}, {"seconds", 1.0}},
                                     {{"stage", "write xyz (EXR)"}, {"seconds", 0.25}}});
  EXPECT_EQ(s["timings_s"]["stages_sum"], expected);
  EXPECT_DOUBLE_EQ(s["timings_s"]["total"].get<double>(), 3.0);
}

TEST(MergeShardSummaries, NamesTheItemsOfAMissingShardFromTheInput) {
  util::ScopedTempDir tmp;
  Write(tmp.path(), 0, 2, ShardSummary(0, 2));
  ShardMergeOptions options;
  options.relist = [](const std::string& kind, const fs::path& dir) {
    EXPECT_EQ(kind, "stereo-pairs");
    EXPECT_EQ(dir, fs::path("in"));
    return std::optional<std::vector<std::string>>(kNames);
  };
  const ShardMergeResult r = MergeShardSummaries(tmp.path(), options);
  EXPECT_FALSE(r.Complete());
  EXPECT_EQ(r.missing_shards, std::vector<std::string>({"1/2"}));
  ASSERT_EQ(r.undone.size(), 2u);
  EXPECT_EQ(r.undone[0].name, "b");
  EXPECT_EQ(r.undone[1].name, "d");
  EXPECT_EQ(r.undone[1].index, 3);
  // Without the input, by position only.
  const ShardMergeResult unnamed = MergeShardSummaries(tmp.path(), NoRelisting());
  EXPECT_EQ(unnamed.undone[0].name, "");
  EXPECT_EQ(unnamed.undone[0].index, 1);
  EXPECT_EQ(ReadJson(tmp.path() / "summary.json")["merge"]["complete"], false);
}

TEST(MergeShardSummaries, TwoShardingsOfOneBatchCountEachItemOnceAndPreferSuccess) {
  util::ScopedTempDir tmp;
  // Shard 1 of 2 failed on its items; a later sharding in 5 redid them all.
  Write(tmp.path(), 0, 2, ShardSummary(0, 2));
  Write(tmp.path(), 1, 2, ShardSummary(1, 2, {{"window", 3}}, "failed"));
  for (int k = 0; k < 5; ++k) Write(tmp.path(), k, 5, ShardSummary(k, 5));
  const ShardMergeResult r = MergeShardSummaries(tmp.path(), NoRelisting());
  EXPECT_TRUE(r.Complete());
  EXPECT_EQ(r.items_failed, 0);
  EXPECT_EQ(r.done_twice.size(), 5u);
  const json s = ReadJson(tmp.path() / "summary.json");
  EXPECT_EQ(s["counts"]["pairs_ok"], 5);
  EXPECT_TRUE(s["failed"].empty());
}

TEST(MergeShardSummaries, FailedItemsMakeTheSetIncomplete) {
  util::ScopedTempDir tmp;
  Write(tmp.path(), 0, 2, ShardSummary(0, 2));
  Write(tmp.path(), 1, 2, ShardSummary(1, 2, {{"window", 3}}, "failed"));
  const ShardMergeResult r = MergeShardSummaries(tmp.path(), NoRelisting());
  EXPECT_FALSE(r.Complete());
  EXPECT_EQ(r.items_failed, 2);
  EXPECT_EQ(ReadJson(tmp.path() / "summary.json")["failed"][0]["error"], "b.png: truncated");
}

TEST(MergeShardSummaries, RefusesOtherOptionsOtherInputsAndEditedSummaries) {
  auto refusal = [](const std::function<void(const fs::path&)>& write) -> std::string {
    util::ScopedTempDir tmp;
    write(tmp.path());
    try {
      MergeShardSummaries(tmp.path(), NoRelisting());
    } catch (const InputError& e) {
      EXPECT_FALSE(fs::exists(tmp.path() / "summary.json"));
      return e.what();
    }
    return "";
  };
  EXPECT_NE(refusal([](const fs::path& d) {
              Write(d, 0, 2, ShardSummary(0, 2));
              Write(d, 1, 2, ShardSummary(1, 2, {{"window", 5}}));
            }).find("differ in 'options' at /window (5 vs 3)"),
            std::string::npos);
  EXPECT_NE(refusal([](const fs::path& d) {
              Write(d, 0, 2, ShardSummary(0, 2));
              json other = ShardSummary(1, 2);
              other["listing"] = ListingRecord("stereo-pairs", "pairs", {"a", "b", "c", "d", "e", "f"});
              Write(d, 1, 2, other);
            }).find("two different batches"),
            std::string::npos);
  EXPECT_NE(refusal([](const fs::path& d) {
              json edited = ShardSummary(0, 1);
              edited["pairs"][2]["stem"] = "x";
              Write(d, 0, 1, edited);
            }).find("not the listing they record"),
            std::string::npos);
  EXPECT_NE(refusal([](const fs::path& d) {
              json wrong = ShardSummary(0, 2);
              wrong["shard"] = {1, 2};
              Write(d, 0, 2, wrong);
            }).find("is not the one its name says"),
            std::string::npos);
  EXPECT_NE(refusal([](const fs::path&) {}).find("no shard summaries"), std::string::npos);
  // A shard of zero shards (once a division by zero) and a directory named like a summary.
  EXPECT_NE(refusal([](const fs::path& d) { Write(d, 0, 0, ShardSummary(0, 1)); }).find("is no shard"),
            std::string::npos);
  EXPECT_NE(refusal([](const fs::path& d) { Write(d, 3, 2, ShardSummary(0, 1)); }).find("is no shard"),
            std::string::npos);
  EXPECT_NE(refusal([](const fs::path& d) {
              Write(d, 0, 2, ShardSummary(0, 2));
              fs::create_directory(d / "summary.shard-1-of-2.json");
            }).find("summary.shard-1-of-2.json: not a file"),
            std::string::npos);
}

}  // namespace
}  // namespace lunarnav::io
