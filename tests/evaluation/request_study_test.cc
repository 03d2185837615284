#include "evaluation/request_study.h"

#include <gtest/gtest.h>

#include <fstream>

#include "io/json_io.h"
#include "util/errors.h"
#include "util/testing.h"

namespace lunarnav::evaluation {
namespace {
namespace fs = std::filesystem;

RequestWindow Window(const std::string& stem, double y0, double y1, int r0, int r1, int d0, int d1) {
  RequestWindow w;
  w.stem = stem;
  w.source = "requests";
  w.y_min_m = y0;
  w.y_max_m = y1;
  w.row_min = r0;
  w.row_max = r1;
  w.d_min_px = d0;
  w.d_max_px = d1;
  return w;
}

// An adjustment phase (the first pair, far off) then three steady requests.
std::vector<RequestWindow> ExampleRun() {
  return {Window("f0", 2.0, 3.0, 200, 239, 100, 140), Window("f1", 4.0, 7.0, 120, 220, 40, 110),
          Window("f2", 4.4, 7.4, 124, 230, 44, 118), Window("f3", 4.2, 7.6, 128, 231, 48, 120)};
}

TEST(WithinTolerance, InclusiveRelativeBand) {
  EXPECT_TRUE(WithinTolerance(110, 100, 0.1));
  EXPECT_TRUE(WithinTolerance(90, 100, 0.1));
  EXPECT_FALSE(WithinTolerance(110.5, 100, 0.1));
  EXPECT_TRUE(WithinTolerance(-4.4, -4, 0.1));
  EXPECT_TRUE(WithinTolerance(0, 0, 0.1));
}

TEST(SummarizeRequests, MeansRangesAndTheSteadyTail) {
  const RequestStudy s = SummarizeRequests(ExampleRun(), 0.10);
  ASSERT_EQ(s.quantities.size(), 3u);
  const QuantityStats& y = s.quantities[0];
  EXPECT_EQ(y.name, "y");
  EXPECT_DOUBLE_EQ(y.lower.mean, (200 + 120 + 124 + 128) / 4.0);  // 143
  EXPECT_DOUBLE_EQ(y.lower.min, 120);
  EXPECT_DOUBLE_EQ(y.lower.max, 200);
  EXPECT_DOUBLE_EQ(y.upper.mean, (239 + 220 + 230 + 231) / 4.0);  // 230
  const QuantityStats& d = s.quantities[1];
  EXPECT_DOUBLE_EQ(d.lower.mean, 58);
  EXPECT_DOUBLE_EQ(d.upper.mean, 122);
  const QuantityStats& Y = s.quantities[2];
  EXPECT_EQ(Y.unit, "m");
  EXPECT_DOUBLE_EQ(Y.lower.mean, 3.65);
  EXPECT_DOUBLE_EQ(Y.upper.max, 7.6);
  // Within 10 % of the means: y_min in [128.7, 157.3] (none of 200, 120, 124, 128), d_min in
  // [52.2, 63.8] (none of 100, 40, 44, 48): no pair is within on every bound.
  EXPECT_EQ(y.within, 0);
  EXPECT_EQ(d.within, 0);
  EXPECT_EQ(s.within_count, 0);
  EXPECT_EQ(s.steady_from, -1);

  // Without the adjustment phase the three steady pairs are all within.
  std::vector<RequestWindow> steady = ExampleRun();
  steady.erase(steady.begin());
  const RequestStudy t = SummarizeRequests(steady, 0.10);
  EXPECT_EQ(t.within_count, 3);
  EXPECT_EQ(t.steady_from, 0);
  EXPECT_EQ(t.quantities[0].within, 3);

  // With 25 %: y_min in [107.25, 178.75] (f0's 200 out), d_min in [43.5, 72.5] (f0's 100 and
  // f1's 40 out), every other bound of f1..f3 in: a steady tail from f2.
  const RequestStudy u = SummarizeRequests(ExampleRun(), 0.25);
  EXPECT_FALSE(u.within[0]);
  EXPECT_FALSE(u.within[1]);
  EXPECT_TRUE(u.within[2]);
  EXPECT_TRUE(u.within[3]);
  EXPECT_EQ(u.steady_from, 2);
  EXPECT_EQ(u.within_count, 2);

  EXPECT_THROW(SummarizeRequests({}, 0.1), std::invalid_argument);
  EXPECT_THROW(SummarizeRequests(ExampleRun(), 1.5), std::invalid_argument);
}

TEST(RequestsTable, ThePaperLayoutWithThePapersValues) {
  const Table t = RequestsTable(SummarizeRequests(ExampleRun(), 0.25));
  ASSERT_EQ(t.rows.size(), 3u);
  const nlohmann::json j = t.ToJson();
  EXPECT_EQ(j["rows"][0]["mean_min"], 143.0);
  EXPECT_EQ(j["rows"][0]["mean_max"], 230.0);
  EXPECT_EQ(j["rows"][0]["mean_delta"], 87.0);
  EXPECT_EQ(j["rows"][1]["min_lowest"], 40.0);
  EXPECT_EQ(j["rows"][1]["max_highest"], 140.0);
  EXPECT_EQ(j["rows"][0]["within"], 75.0);  // y: f1, f2, f3
  EXPECT_EQ(j["rows"][1]["within"], 50.0);  // d: f2, f3
  EXPECT_EQ(j["rows"][2]["paper_min"], 4.2);
  EXPECT_EQ(j["rows"][2]["paper_delta"], 7.5 - 4.2);
  EXPECT_EQ(j["rows"][1]["paper_max"], 118.0);
  const Table pairs = RequestPairsTable(SummarizeRequests(ExampleRun(), 0.25));
  ASSERT_EQ(pairs.rows.size(), 4u);
  EXPECT_EQ(pairs.ToCsv().substr(0, pairs.ToCsv().find('\n')),
            "index,stem,source,y_min_px,y_max_px,d_min_px,d_max_px,Y_min_m,Y_max_m,within");
}

void WriteSidecar(const fs::path& path, const nlohmann::json& window) {
  nlohmann::json j = {{"format", "lunarnav.disparity/1"}, {"stem", path.stem().string()}, {"result", nlohmann::json::object()}};
  if (!window.is_null()) j["result"]["window"] = window;
  io::WriteJsonAtomic(path, j);
}

TEST(ReadRequestWindows, ReadsTheSidecarsOfARun) {
  util::ScopedTempDir tmp;
  const fs::path run = tmp.path() / "run";
  EXPECT_THROW(ReadRequestWindows(run), InputError);  // no such directory
  fs::create_directories(run / "disparity");
  EXPECT_THROW(ReadRequestWindows(run), InputError);  // nothing in it
  WriteSidecar(run / "disparity" / "b.json",
               {{"source", "requests"}, {"request_line", 3}, {"region", {{"y_m", {4.5, 7.0}}, {"z_m", {-0.5, 1.0}}}},
                {"rows", {10, 50}}, {"disparity_px", {12, 40}}, {"visible", true}});
  WriteSidecar(run / "disparity" / "a.json",
               {{"source", "range-y"}, {"region", {{"y_m", {4.0, 8.0}}, {"z_m", {-0.5, 1.0}}}},
                {"rows", {5, 55}}, {"disparity_px", {10, 44}}, {"visible", true}});
  WriteSidecar(run / "disparity" / "c.json", nullptr);  // matched without window selection
  int without = -1;
  const std::vector<RequestWindow> w = ReadRequestWindows(run, &without);
  ASSERT_EQ(w.size(), 2u);
  EXPECT_EQ(without, 1);
  EXPECT_EQ(w[0].stem, "a");  // stem order
  EXPECT_EQ(w[0].source, "range-y");
  EXPECT_EQ(w[1].request_line, 3);
  EXPECT_DOUBLE_EQ(w[1].y_min_m, 4.5);
  EXPECT_DOUBLE_EQ(w[1].y_max_m, 7.0);
  EXPECT_EQ(w[1].row_min, 10);
  EXPECT_EQ(w[1].row_max, 50);
  EXPECT_EQ(w[1].d_min_px, 12);
  EXPECT_EQ(w[1].d_max_px, 40);

  // A sidecar of another tool, or a window without its rows: bad input naming the file.
  std::ofstream(run / "disparity" / "d.json") << R"({"format": "other"})";
  try {
    ReadRequestWindows(run);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("d.json"), std::string::npos) << e.what();
  }
  fs::remove(run / "disparity" / "d.json");
  WriteSidecar(run / "disparity" / "e.json", {{"region", {{"y_m", {4.0, 8.0}}}}});
  EXPECT_THROW(ReadRequestWindows(run), InputError);
}

}  // namespace
}  // namespace lunarnav::evaluation
