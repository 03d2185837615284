#include "util/run_main.h"

#include <gtest/gtest.h>

#include <stdexcept>

#include "util/check.h"
#include "util/errors.h"
#include "util/log.h"

namespace lunarnav::util {
namespace {

TEST(RunMain, MapsEachKindOfFailureToItsExitCode) {
  SetLogLevel(LogLevel::kError);
  EXPECT_EQ(RunMain([] { return kExitBatchPartial; }), 4);
  EXPECT_EQ(RunMain([]() -> int { LN_CHECK_INPUT(false) << "data.csv:3: not a number"; return 0; }), 3);
  EXPECT_EQ(RunMain([]() -> int { LN_CHECK_ARG(false) << "--window: bad"; return 0; }), 2);
  EXPECT_EQ(RunMain([]() -> int { LN_CHECK(1 + 1 == 3) << "arithmetic"; return 0; }), 1);
  EXPECT_EQ(RunMain([]() -> int { throw std::runtime_error("disk full"); }), 1);
}

// A NUL or newline from a file's contents must neither cut nor split the error line, and a
// library that repeats itself must not fill the terminal.
TEST(BoundedMessage, EscapesControlCharactersAndCapsTheLength) {
  EXPECT_EQ(BoundedMessage(std::string("a\0b\nc", 5)), "a\\x00b\\x0Ac");
  EXPECT_EQ(BoundedMessage("plain text"), "plain text");
  const std::string longer(5000, 'x');
  const std::string bounded = BoundedMessage(longer, 100);
  EXPECT_EQ(bounded, std::string(100, 'x') + " ... (4900 more bytes)");
}

TEST(Check, InternalChecksCarryTheSourceLocationUserChecksDoNot) {
  try {
    LN_CHECK(false) << "boom";
    ADD_FAILURE() << "LN_CHECK did not throw";
  } catch (const std::logic_error& e) {
    EXPECT_NE(std::string(e.what()).find("run_main_test.cc"), std::string::npos);
  }
  try {
    LN_CHECK_INPUT(false) << "f.png: truncated";
    ADD_FAILURE() << "LN_CHECK_INPUT did not throw";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "f.png: truncated");
  }
}

}  // namespace
}  // namespace lunarnav::util
