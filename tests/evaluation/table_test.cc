#include "evaluation/table.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <string>

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

// The text of a file, or "" when it cannot be read.
std::string FileText(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

TEST(Table, WriteTableWritesThreeFiles) {
  util::ScopedTempDir tmp;
  WriteTable(tmp.path(), "example", Example());
  // The files hold the texts above, byte for byte (the JSON pretty-printed, a final newline).
  EXPECT_EQ(FileText(tmp.path() / "example.csv"), "trial,error_pct\n\"A, straight\",17.0\nB,n/a (no trajectory)\n");
  EXPECT_EQ(FileText(tmp.path() / "example.md"),
            "### Example\n\n| Trial | Error (%) |\n|---|---:|\n| A, straight | 17.0 |\n"
            "| B | n/a (no trajectory) |\n\na note\n");
  const nlohmann::json j = io::ReadJson(tmp.path() / "example.json");
  EXPECT_EQ(j["title"], "Example");
  EXPECT_EQ(j["rows"][0]["trial"], "A, straight");
  EXPECT_EQ(j["rows"][0]["error"], 17.04);  // the JSON keeps every digit; CSV and Markdown round
  EXPECT_EQ(j["rows"][1]["error"]["n/a"], "no trajectory");
  EXPECT_EQ(j["notes"][0], "a note");
  EXPECT_EQ(FileText(tmp.path() / "example.json").back(), '\n');
}

}  // namespace
}  // namespace lunarnav::evaluation
