#include "io/shard_merge.h"

#include <algorithm>
#include <cinttypes>
#include <cstdint>
#include <cstdio>
#include <map>
#include <regex>
#include <set>
#include <sstream>

#include "io/atomic_file.h"
#include "io/json_io.h"
#include "io/stereo_pairs.h"
#include "util/check.h"
#include "util/errors.h"
#include "util/log.h"
#include "util/parallel.h"
#include "util/summary.h"

namespace lunarnav::io {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// The most items a batch's listing may declare: what the merge allocates a slot for (a shard
// summary holds at most about 60,000 pairs, so this is 67 shards of them or more).
constexpr std::int64_t kMaxListedItems = 4'000'000;
// Error lines printed for missing shards and undone items; summary.json lists them all.
constexpr std::size_t kMaxErrorLines = 20;

// One shard's summary file.
struct ShardFile {
  fs::path path;
  int index = 0, count = 1;
  json summary;
  std::string Name() const { return path.filename().string(); }
  std::string Shard() const { return std::to_string(index) + "/" + std::to_string(count); }
};

// Keys of a summary that describe the run itself rather than the batch; every other key
// (tool, version, input_dir, options, rig, geometry, ...) must be the same in every shard.
const std::set<std::string> kRunKeys = {"invocation", "output_dir",      "shard",  "threads", "kernel",    "counts",
                                        "timings_s",  "peak_memory_mib", "failed", "listing", "bit_depths"};

// The first difference between two JSON values, as "at /path (a vs b)".
std::string FirstDifference(const json& a, const json& b) {
  const json patch = json::diff(a, b);
  if (patch.empty()) return "";
  const std::string path = patch[0].value("path", "");
  const json::json_pointer pointer(path);
  std::ostringstream s;
  s << "at " << (path.empty() ? "/" : path) << " (";
  s << (a.contains(pointer) ? a.at(pointer).dump() : "absent") << " vs ";
  s << (b.contains(pointer) ? b.at(pointer).dump() : "absent") << ")";
  const std::string text = s.str();
  return text.size() > 300 ? text.substr(0, 300) + "...)" : text;
}

// The summary.shard-K-of-N.json files of `dir`, ordered by N, then K.
std::vector<ShardFile> FindShardFiles(const fs::path& dir) {
  static const std::regex kName(R"(summary\.shard-(\d+)-of-(\d+)\.json)");
  std::error_code ec;
  CheckInputDirectory(dir);
  std::vector<ShardFile> files;
  for (auto it = fs::directory_iterator(dir, ec); !ec && it != fs::directory_iterator(); it.increment(ec)) {
    const std::string name = it->path().filename().string();
    std::smatch m;
    if (!std::regex_match(name, m, kName)) continue;
    ShardFile f;
    f.path = it->path();
    try {
      f.index = std::stoi(m[1]);
      f.count = std::stoi(m[2]);
    } catch (const std::exception&) {
      throw InputError(f.path.string() + ": shard number out of range");
    }
    // Shard K of N is 0 <= K < N (N = 0 once divided by zero), and a summary is a file.
    LN_CHECK_INPUT(f.count >= 1 && f.index < f.count)
        << f.path.string() << ": shard " << f.index << " of " << f.count << " is no shard (K < N, N >= 1)";
    std::error_code file_ec;
    LN_CHECK_INPUT(fs::is_regular_file(f.path, file_ec)) << f.path.string() << ": not a file";
    files.push_back(std::move(f));
  }
  LN_CHECK_INPUT(!ec) << dir.string() << ": cannot list (" << ec.message() << ")";
  LN_CHECK_INPUT(!files.empty()) << dir.string()
                                 << ": no shard summaries (summary.shard-K-of-N.json, written by --shard runs)";
  std::sort(files.begin(), files.end(), [](const ShardFile& a, const ShardFile& b) {
    return std::tie(a.count, a.index) < std::tie(b.count, b.index);
  });
  return files;
}

// Checks that a shard summary has what the merge reads.
void CheckShardSummary(const ShardFile& f) {
  const json& s = f.summary;
  const std::string file = f.path.string();
  LN_CHECK_INPUT(s.is_object() && s.contains("tool") && s["tool"].is_string()) << file << ": not a tool's summary";
  LN_CHECK_INPUT(s.contains("listing") && s["listing"].is_object() && s["listing"].contains("entries") &&
                 s["listing"].contains("items") && s["listing"].contains("digest"))
      << file << ": no input listing (a summary written before shard-merge existed?); rerun this shard";
  // What the merge reads of the listing, of the types it reads them as, before any message
  // quotes them (a message built from a value of another type would throw in turn).
  const json& listing = s["listing"];
  LN_CHECK_INPUT(listing["entries"].is_string() && !listing["entries"].get<std::string>().empty() &&
                 listing["digest"].is_string() && listing["items"].is_number_integer() &&
                 (!listing.contains("kind") || listing["kind"].is_string()))
      << file << ": its listing is malformed (entries and digest are texts, items a whole number)";
  const auto items = listing["items"].get<std::int64_t>();
  LN_CHECK_INPUT(items >= 0 && items <= kMaxListedItems)
      << file << ": its listing declares " << items << " items; a batch lists 0 to " << kMaxListedItems;
  LN_CHECK_INPUT(s.value("shard", json()) == json({f.index, f.count}))
      << file << ": its shard " << s.value("shard", json()).dump() << " is not the one its name says";
  const std::string entries = s["listing"]["entries"].get<std::string>();
  LN_CHECK_INPUT(s.contains(entries) && s[entries].is_array())
      << file << ": no '" << entries << "' array";
  for (const json& e : s[entries]) {
    LN_CHECK_INPUT(e.is_object() && e.contains("stem") && e["stem"].is_string() && e.contains("status"))
        << file << ": an entry of '" << entries << "' without stem or status";
  }
}

// Checks that a shard summary holds as many items as its shard of the listing has.
void CheckShardSize(const ShardFile& f) {
  const json& s = f.summary;
  const std::string entries = s["listing"]["entries"].get<std::string>();
  const long listed = s["listing"]["items"].get<long>();
  const long expected = f.index < listed ? (listed - f.index + f.count - 1) / f.count : 0;
  LN_CHECK_INPUT(static_cast<long>(s[entries].size()) == expected)
      << f.path.string() << ": holds " << s[entries].size() << " " << entries << " where shard " << f.Shard()
      << " of " << listed << " has " << expected;
}

// Checks that `f` belongs to the batch of `first` (same tool, listing, input, options, ...).
void CheckSameBatch(const ShardFile& first, const ShardFile& f) {
  const json& a = first.summary;
  const json& b = f.summary;
  const std::string both = f.path.string() + " and " + first.Name();
  LN_CHECK_INPUT(a["tool"] == b["tool"]) << both << ": written by different tools (" << b["tool"].get<std::string>()
                                          << ", " << a["tool"].get<std::string>() << ")";
  const auto listing = [](const json& s) {
    return std::to_string(s["listing"]["items"].get<long>()) + " " + s["listing"]["entries"].get<std::string>() +
           ", " + s["listing"]["digest"].get<std::string>();
  };
  LN_CHECK_INPUT(a.value("input_dir", json()) == b.value("input_dir", json()) && a["listing"] == b["listing"])
      << both << ": two different batches were sharded into this directory: inputs "
      << b.value("input_dir", json()).dump() << " (" << listing(b) << ") and " << a.value("input_dir", json()).dump()
      << " (" << listing(a) << "); give each batch its own output directory, or remove one batch's shard summaries";
  std::set<std::string> keys;
  for (const auto& [k, v] : a.items()) keys.insert(k);
  for (const auto& [k, v] : b.items()) keys.insert(k);
  for (const std::string& key : keys) {
    if (kRunKeys.count(key) > 0 || key == a["listing"]["entries"]) continue;
    const json va = a.value(key, json()), vb = b.value(key, json());
    LN_CHECK_INPUT(va == vb) << both << ": the shards differ in '" << key << "' " << FirstDifference(vb, va)
                             << "; the shards of one batch must run the same version with the same options: "
                                "rerun the odd shard with the others' (or remove its files)";
  }
}

// A numeric JSON value as a double (0 for anything else).
double Number(const json& v) { return v.is_number() ? v.get<double>() : 0.0; }

// Per-stage timings ([{"stage", "seconds"}, ...], stereo-batch's stages_sum) summed stage by
// stage, in the order the stages first appear; entries of another shape are left out, and at
// most kMaxStages stages are kept (a summary is input: its arrays are bounded here).
json MergeStageTimes(const json& sum, const json& add) {
  constexpr std::size_t kMaxStages = 64;
  json out = sum.is_array() ? sum : json::array();
  for (const json& entry : add) {
    if (!entry.is_object() || !entry.contains("stage") || !entry["stage"].is_string()) continue;
    const std::string stage = entry["stage"].get<std::string>();
    const double seconds = Number(entry.value("seconds", json()));
    auto at = std::find_if(out.begin(), out.end(), [&](const json& e) { return e["stage"] == stage; });
    if (at != out.end()) {
      (*at)["seconds"] = Number((*at)["seconds"]) + seconds;
    } else if (out.size() < kMaxStages) {
      out.push_back({{"stage", stage}, {"seconds", seconds}});
    }
  }
  return out;
}

}  // namespace

std::string ListingDigest(const std::vector<std::string>& names) {
  std::uint64_t hash = 14695981039346656037ULL;  // FNV-1a 64-bit offset basis and prime
  auto add = [&](unsigned char c) {
    hash ^= c;
    hash *= 1099511628211ULL;
  };
  for (const std::string& name : names) {
    for (const char c : name) add(static_cast<unsigned char>(c));
    add('\n');
  }
  char text[32];
  std::snprintf(text, sizeof text, "%016" PRIx64, hash);
  return std::string("fnv1a64:") + text;
}

json ListingRecord(const std::string& kind, const std::string& entries, const std::vector<std::string>& names) {
  return {{"kind", kind}, {"entries", entries}, {"items", names.size()}, {"digest", ListingDigest(names)}};
}

std::optional<std::vector<std::string>> RelistItems(const std::string& kind, const fs::path& input_dir) {
  if (kind != "stereo-pairs") return std::nullopt;
  try {
    return PairStems(ListStereoPairs(input_dir));
  } catch (const InputError&) {
    return std::nullopt;
  }
}

void ShardMergeOptions::Validate() const {
  LN_CHECK_ARG(num_threads >= 0) << "threads: must be >= 0";
  LN_CHECK_ARG(static_cast<bool>(relist)) << "shard merge: no listing function";
}

std::string ShardMergeResult::BriefReport() const {
  std::ostringstream s;
  s << shard_files << " shard" << (shard_files == 1 ? "" : "s") << " of " << tool << ": " << items_done << " of "
    << items_listed << " " << entries << " done, " << items_failed << " failed, " << items_never << " never done";
  if (!missing_shards.empty()) s << "; " << missing_shards.size() << " shard(s) missing";
  if (!done_twice.empty()) s << "; " << done_twice.size() << " done twice";
  return s.str();
}

ShardMergeResult MergeShardSummaries(const fs::path& output_dir, const ShardMergeOptions& options,
                                     const json& invocation) {
  options.Validate();
  std::vector<ShardFile> files = FindShardFiles(output_dir);
  util::ParallelForEachItem(files.size(), options.num_threads,
                            [&](std::size_t i) {
                              // At most io::kMaxJsonBytes and kMaxJsonValues (about 60,000
                              // pairs a shard; a larger batch takes more shards).
                              files[i].summary = ReadJson(files[i].path);
                            });
  for (const ShardFile& f : files) CheckShardSummary(f);
  const ShardFile& first = files.front();
  for (const ShardFile& f : files) CheckSameBatch(first, f);
  for (const ShardFile& f : files) CheckShardSize(f);

  ShardMergeResult result;
  result.tool = first.summary["tool"].get<std::string>();
  result.shard_files = static_cast<int>(files.size());
  const json& listing = first.summary["listing"];
  result.entries = listing["entries"].get<std::string>();
  const std::string& entries = result.entries;
  result.items_listed = listing["items"].get<long>();

  // Each item's entry by its position in the listing: shard K of N holds items K, K+N, ...
  struct Slot {
    const json* entry = nullptr;
    std::vector<std::string> shards;  // the shard files that listed it
  };
  std::vector<Slot> slots(static_cast<std::size_t>(result.items_listed));
  std::map<int, std::set<int>> present;  // N -> the K present
  for (const ShardFile& f : files) {
    present[f.count].insert(f.index);
    const json& items = f.summary[entries];
    for (std::size_t i = 0; i < items.size(); ++i) {
      const std::size_t position = static_cast<std::size_t>(f.index) + i * static_cast<std::size_t>(f.count);
      Slot& slot = slots[position];
      const json& entry = items[i];
      if (slot.entry != nullptr) {
        LN_CHECK_INPUT((*slot.entry)["stem"] == entry["stem"])
            << f.path.string() << ": lists '" << entry["stem"].get<std::string>() << "' where " << slot.shards.front()
            << " lists '" << (*slot.entry)["stem"].get<std::string>() << "' (item " << position
            << " of the listing): the summaries do not describe one listing";
        if ((*slot.entry)["status"] == "failed" && entry["status"] != "failed") slot.entry = &entry;
      } else {
        slot.entry = &entry;
      }
      slot.shards.push_back(f.Name());
    }
  }
  for (const auto& [count, indices] : present) {
    // Shards K >= the items listed hold none: missing or not, nothing is lost with them.
    const auto holding = static_cast<int>(std::min<std::int64_t>(count, result.items_listed));
    for (int k = 0; k < holding; ++k) {
      if (indices.count(k) == 0) result.missing_shards.push_back(std::to_string(k) + "/" + std::to_string(count));
    }
  }

  // Names for the items no shard lists, from the input as it is now (if it is still the same).
  std::optional<std::vector<std::string>> relisted;
  const bool any_unlisted = std::any_of(slots.begin(), slots.end(), [](const Slot& s) { return s.entry == nullptr; });
  if (any_unlisted) {
    const fs::path input_dir = !options.input_dir.empty() ? options.input_dir
                                                          : fs::path(first.summary.value("input_dir", std::string()));
    relisted = options.relist(listing.value("kind", std::string()), input_dir);
    if (relisted && ListingDigest(*relisted) != listing["digest"]) {
      LN_LOG(Warning) << input_dir.string() << ": its " << entries << " are no longer those the shards listed; "
                      << "the " << entries << " never done are named by their position only";
      relisted.reset();
    }
  }

  json merged_items = json::array(), failed = json::array();
  std::vector<std::string> names;  // in listing order, when every item is known
  long ok = 0, resumed = 0;
  for (std::size_t position = 0; position < slots.size(); ++position) {
    const Slot& slot = slots[position];
    // The shard that should have done this item, for the first sharding present.
    const int n = present.begin()->first;
    const std::string shard = std::to_string(static_cast<int>(position % static_cast<std::size_t>(n))) + "/" +
                              std::to_string(n);
    if (slot.entry == nullptr) {
      ++result.items_never;
      result.undone.push_back({static_cast<long>(position), relisted ? (*relisted)[position] : "", shard,
                               "shard missing"});
      continue;
    }
    const json& entry = *slot.entry;
    const std::string stem = entry["stem"].get<std::string>();
    names.push_back(stem);
    if (slot.shards.size() > 1) result.done_twice.push_back(stem);
    const std::string status = entry["status"].get<std::string>();
    if (status == "failed") {
      ++result.items_failed;
      const std::string error = entry.value("error", std::string());
      failed.push_back({{"stem", stem}, {"error", error}});
      result.undone.push_back({static_cast<long>(position), stem, shard, error});
    } else {
      ++result.items_done;
      (status == "resumed" ? resumed : ok) += 1;
    }
    merged_items.push_back(entry);
  }
  if (result.items_never == 0) {
    LN_CHECK_INPUT(ListingDigest(names) == listing["digest"])
        << output_dir.string() << ": the " << entries << " of the shard summaries are not the listing they record ("
        << listing["digest"].get<std::string>() << "); the summaries were edited or mixed";
  }

  // The merged summary: the batch's keys, then the run's keys made from every shard.
  json merged = json::object();
  for (const auto& [key, value] : first.summary.items()) {
    if (kRunKeys.count(key) == 0 && key != entries) merged[key] = value;
  }
  merged["invocation"] = first.summary.value("invocation", json());
  merged["listing"] = listing;
  auto common = [&](const std::string& key) -> json {
    const json v = first.summary.value(key, json());
    for (const ShardFile& f : files) {
      if (f.summary.value(key, json()) != v) return json();
    }
    return v;
  };
  merged["output_dir"] = common("output_dir").is_null() ? json(output_dir.string()) : common("output_dir");
  merged["shard"] = {0, 1};
  for (const char* key : {"threads", "kernel"}) {
    if (!common(key).is_null()) merged[key] = common(key);
  }
  // Counts: the item counts from the merged items; any other count (pixels, points) summed
  // over the merged items' results when they all hold it, else over the shards.
  json counts = json::object();
  const std::string p = entries + "_";
  counts[p + "listed"] = result.items_listed;
  counts[p + "in_shard"] = static_cast<long>(merged_items.size());
  counts[p + "ok"] = ok;
  counts[p + "resumed"] = resumed;
  counts[p + "failed"] = result.items_failed;
  const json first_counts = first.summary.value("counts", json::object());
  for (const auto& [key, value] : first_counts.items()) {
    if (counts.contains(key) || !value.is_number()) continue;
    bool from_items = true;
    long long sum = 0;
    for (const json& e : merged_items) {
      if (e["status"] == "failed") continue;
      const json r = e.value("result", json());
      if (!r.is_object() || !r.contains(key) || !r[key].is_number_integer()) {
        from_items = false;
        break;
      }
      sum += r[key].get<long long>();
    }
    if (from_items) {
      counts[key] = sum;
    } else {
      double total = 0;
      for (const ShardFile& f : files) total += Number(f.summary.value("counts", json::object()).value(key, json()));
      counts[key] = total;
    }
  }
  merged["counts"] = counts;
  if (first.summary.contains("bit_depths")) {
    // stereo-batch's pairs per grey-level depth, from the merged pairs' results.
    std::map<std::string, long> depths;
    for (const json& e : merged_items) {
      const json r = e.value("result", json());
      if (e["status"] != "failed" && r.is_object() && r.contains("bit_depth") && r["bit_depth"].is_number_integer()) {
        ++depths[std::to_string(r["bit_depth"].get<int>())];
      }
    }
    merged["bit_depths"] = depths;
  }
  json timings = json::object();
  double peak_mib = 0;
  json shards = json::array();
  for (const ShardFile& f : files) {
    const json shard_timings = f.summary.value("timings_s", json::object());
    for (const auto& [key, value] : shard_timings.items()) {
      if (value.is_array()) {
        timings[key] = MergeStageTimes(timings.value(key, json::array()), value);
      } else {
        timings[key] = Number(timings.value(key, json(0.0))) + Number(value);
      }
    }
    peak_mib = std::max(peak_mib, Number(f.summary.value("peak_memory_mib", json())));
    json shard = {{"file", f.Name()}, {"shard", {f.index, f.count}}};
    for (const char* key : {"invocation", "output_dir", "threads", "kernel", "counts", "timings_s", "peak_memory_mib"}) {
      if (f.summary.contains(key)) shard[key] = f.summary[key];
    }
    shards.push_back(std::move(shard));
  }
  merged["timings_s"] = timings;
  merged["peak_memory_mib"] = peak_mib;
  merged["failed"] = failed;
  merged[entries] = merged_items;
  json undone = json::array();
  for (const UndoneItem& u : result.undone) {
    undone.push_back({{"index", u.index}, {"stem", u.name.empty() ? json() : json(u.name)}, {"shard", u.shard},
                      {"reason", u.reason}});
  }
  merged["merge"] = util::SummaryHead("shard-merge", invocation);
  merged["merge"].update(json{{"note", "timings_s: summed over the shards (machine time, not the wall time of the set); "
                              "peak_memory_mib: the largest shard's; invocation: the first shard's"},
                     {"complete", result.Complete()},
                     {"shards", shards},
                     {"missing_shards", result.missing_shards},
                     {entries + "_never_done", result.items_never},
                     {entries + "_not_done", undone},
                     {entries + "_done_twice", result.done_twice}});
  result.summary_path = output_dir / "summary.json";
  WriteJsonAtomic(result.summary_path, merged);

  for (std::size_t i = 0; i < result.missing_shards.size() && i < kMaxErrorLines; ++i) {
    const std::string& shard = result.missing_shards[i];
    const std::size_t slash = shard.find('/');
    LN_LOG(Error) << output_dir.string() << ": shard " << shard << " missing (no "
                  << SummaryFileName(std::stoi(shard.substr(0, slash)), std::stoi(shard.substr(slash + 1)))
                  << "); rerun it with --resume";
  }
  if (result.missing_shards.size() > kMaxErrorLines) {
    LN_LOG(Error) << output_dir.string() << ": " << result.missing_shards.size() - kMaxErrorLines
                  << " more shards missing (summary.json lists them all)";
  }
  // "pair" for "pairs": the word stereo-batch's own error lines use.
  const std::string entry = entries.size() > 1 && entries.back() == 's' ? entries.substr(0, entries.size() - 1) : entries;
  for (std::size_t i = 0; i < result.undone.size() && i < kMaxErrorLines; ++i) {
    const UndoneItem& item = result.undone[i];
    LN_LOG(Error) << entry << " " << (item.name.empty() ? "#" + std::to_string(item.index) : item.name)
                  << " (shard " << item.shard << "): not done: " << item.reason;
  }
  if (result.undone.size() > kMaxErrorLines) {
    LN_LOG(Error) << result.undone.size() - kMaxErrorLines << " more " << entries
                  << " not done (summary.json lists them all)";
  }
  if (!result.done_twice.empty()) {
    LN_LOG(Warning) << result.done_twice.size() << " " << entries << " done by several shards (e.g. '"
                    << result.done_twice.front() << "'), counted once";
  }
  return result;
}

}  // namespace lunarnav::io
