#include "evaluation/table.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "io/json_io.h"
#include "util/testing.h"

namespace lunarnav::evaluation {
namespace {

Table Example() {
  Table t;
  t.title = "Example";
  t.columns = {{"trial", "", "Trial", 0}, {"error", "pct", "Error (%)", 1}};
  t.AddRow({Cell::Text("A, straight"), Cell::Number(17.04)});
  t.AddRow({Cell::Text("B"), Cell::NumberOr(NAN, "no trajectory")});
  t.notes = {"a note"};
  return t;
}

TEST(Table, WritesTheSameCellsAsCsvMarkdownAndJson) {
  const Table t = Example();
  EXPECT_EQ(t.ToCsv(), "trial,error_pct\n\"A, straight\",17.0\nB,n/a (no trajectory)\n");
  EXPECT_EQ(t.ToMarkdown(),
            "### Example\n\n| Trial | Error (%) |\n|---|---:|\n| A, straight | 17.0 |\n"
            "| B | n/a (no trajectory) |\n\na note\n");
  const nlohmann::json j = t.ToJson();
  EXPECT_EQ(j["rows"][0]["error"], 17.04);
  EXPECT_EQ(j["rows"][1]["error"]["n/a"], "no trajectory");
  EXPECT_THROW(Example().AddRow({Cell::Text("too short")}), std::logic_error);
}

TEST(Table, WriteTableWritesThreeFiles) {
  util::ScopedTempDir tmp;
  WriteTable(tmp.path(), "example", Example());
  for (const char* ext : {".csv", ".md", ".json"}) {
    EXPECT_TRUE(std::filesystem::exists(tmp.path() / (std::string("example") + ext))) << ext;
  }
  EXPECT_EQ(io::ReadJson(tmp.path() / "example.json")["title"], "Example");
}

}  // namespace
}  // namespace lunarnav::evaluation
