#include "io/json_io.h"

#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "util/errors.h"
#include "util/testing.h"

namespace lunarnav::io {
namespace {

// Whatever is wrong with a JSON file is bad input naming the file: its syntax, and numbers
// beyond a double's range ("1e999", which the parser reports as another kind of error).
TEST(ReadJson, BadSyntaxAndOverflowingNumbersAreInputErrorsNamingTheFile) {
  util::ScopedTempDir tmp;
  const auto path = tmp.path() / "rig.json";
  for (const std::string text : {"{\"focal_px\": 1e999}", "{\"focal_px\": }", "[1, 2"}) {
    std::ofstream(path, std::ios::trunc) << text;
    try {
      ReadJson(path);
      ADD_FAILURE() << "no error for " << text;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(path.string()), std::string::npos) << e.what();
    }
  }
  std::ofstream(path, std::ios::trunc) << "{\"focal_px\": 1e300}";
  EXPECT_DOUBLE_EQ(ReadJson(path)["focal_px"].get<double>(), 1e300);
}

}  // namespace
}  // namespace lunarnav::io
