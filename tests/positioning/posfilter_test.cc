#include "positioning/posfilter.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

namespace lunarnav::positioning {
namespace {

// A straight drive at 0.5 m/s with a single inclinometer, `pitch_column`, reading a step
// from 0 to 114 counts (10.02 deg) halfway; 10 Hz.
telemetry::TelemetryLog OneInclinometerLog(const telemetry::SensorModel& model, telemetry::Channel pitch) {
  telemetry::TelemetryLog log;
  log.source = "log.csv";
  const int n = 400;
  const double counts_per_m = 1.0 / model[telemetry::Channel::kEncoderFrontLeft].MetresPerCount();
  for (int k = 0; k < n; ++k) {
    log.t_s.push_back(0.1 * k);
    log.line.push_back(k + 2);
    log.counts[static_cast<int>(telemetry::Channel::kEncoderFrontLeft)].push_back(
        std::round(0.05 * k * counts_per_m));
    log.counts[static_cast<int>(pitch)].push_back(k < n / 2 ? 512 : 512 + 114);  // 10.02 deg
  }
  return log;
}

telemetry::SensorModel Model(const std::string& pitch_column) {
  return telemetry::SensorModelFromJson(nlohmann::json::parse(R"({
    "format": "lunarnav.sensors/1",
    "channels": {
      "enc_fl": {"counts_per_revolution": 512, "wheel_radius_m": 0.2},
      ")" + pitch_column + R"(": {"scale": 0.087890625, "offset": -45.0, "units": "deg"}
    }
  })"),
                                        "model");
}

// With one inclinometer, either, the pitch is that inclinometer low-passed: the step shows
// the filter's smooth rise (no jump), and the two sides give the same trajectory.
TEST(RunPosfilter, OneInclinometerOnEitherSideGivesItsFilteredPitch) {
  const telemetry::SensorModel left_model = Model("pitch_left"), right_model = Model("pitch_right");
  const PosfilterResult left = RunPosfilter(OneInclinometerLog(left_model, telemetry::Channel::kPitchLeft),
                                            left_model, PosfilterOptions{});
  const PosfilterResult right = RunPosfilter(OneInclinometerLog(right_model, telemetry::Channel::kPitchRight),
                                             right_model, PosfilterOptions{});
  const auto& a = left.motion.trajectory;
  const auto& b = right.motion.trajectory;
  ASSERT_EQ(a.size(), 400u);
  ASSERT_EQ(b.size(), a.size());
  for (std::size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].pitch_rad, b[k].pitch_rad) << k;
    EXPECT_EQ(a[k].z_m, b[k].z_m) << k;
  }
  // Filtered: the step's first sample moves the pitch by far less than the step (10 deg).
  const double deg = M_PI / 180.0;
  EXPECT_LT(b[200].pitch_rad - b[199].pitch_rad, 1.0 * deg);
  EXPECT_NEAR(b.back().pitch_rad, 114 * 0.087890625 * deg, 0.001 * deg);
}

}  // namespace
}  // namespace lunarnav::positioning
