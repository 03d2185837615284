#include "telemetry/sensor_model.h"

#include <gtest/gtest.h>

#include <cmath>

#include "util/errors.h"
#include "util/testing.h"

namespace lunarnav::telemetry {
namespace {

nlohmann::json Minimal() {
  return nlohmann::json::parse(R"({
    "format": "lunarnav.sensors/1",
    "bits": 10,
    "channels": {
      "enc_fl": {"counts_per_revolution": 512, "wheel_radius_m": 0.2, "counter_bits": 16},
      "compass": {"column": "heading_raw", "scale": 0.3515625, "offset": -180, "units": "deg"},
      "gyro_z": {"scale": 0.1, "offset": -51.2, "units": "deg/s", "valid_range": [5, 1018]}
    }
  })");
}

TEST(SensorModelFromJson, ReadsChannelsWithDefaults) {
  const SensorModel m = SensorModelFromJson(Minimal(), "s.json");
  EXPECT_TRUE(m[Channel::kEncoderFrontLeft].present);
  EXPECT_FALSE(m[Channel::kEncoderRearRight].present);
  EXPECT_EQ(m[Channel::kEncoderFrontLeft].column, "enc_fl");
  EXPECT_EQ(m[Channel::kEncoderFrontLeft].valid_max, 65535);  // counter width
  EXPECT_NEAR(m[Channel::kEncoderFrontLeft].MetresPerCount(), 2 * M_PI * 0.2 / 512, 1e-15);
  EXPECT_EQ(m[Channel::kCompass].column, "heading_raw");
  EXPECT_EQ(m[Channel::kCompass].valid_max, 1023);
  // count 512 -> -180 + 180 = 0 deg; count 768 -> 90 deg.
  EXPECT_NEAR(m[Channel::kCompass].ToRadians(768), M_PI / 2, 1e-12);
  EXPECT_EQ(m[Channel::kGyroZ].valid_min, 5);
}

TEST(SensorModelFromJson, OverridingBitsKeepsEachChannelsFullScale) {
  SensorModel m = SensorModelFromJson(Minimal(), "s.json");
  const double compass_full_scale = m[Channel::kCompass].ToRadians(1023);
  m.OverrideBits(7);
  EXPECT_EQ(m[Channel::kCompass].valid_max, 127);
  EXPECT_NEAR(m[Channel::kCompass].ToRadians(127), compass_full_scale, 8 * 0.3515625 * M_PI / 180);
  EXPECT_EQ(m[Channel::kGyroZ].valid_min, 0);    // [5, 1018] / 8, widened to whole counts
  EXPECT_EQ(m[Channel::kGyroZ].valid_max, 128);
  EXPECT_EQ(m[Channel::kEncoderFrontLeft].counter_bits, 13);  // 16 bits, three fewer
  EXPECT_NEAR(m[Channel::kEncoderFrontLeft].counts_per_revolution, 512.0 / 8, 1e-12);
  const SensorModel back = SensorModelFromJson(m.ToJson(), "round trip");
  EXPECT_EQ(back[Channel::kCompass].bits, 7);
  EXPECT_EQ(back[Channel::kCompass].column, "heading_raw");
}

TEST(SensorModelFromJson, NamesTheKeyOfEveryMistake) {
  auto expect_error = [](nlohmann::json j, const std::string& words) {
    try {
      SensorModelFromJson(j, "s.json");
      ADD_FAILURE() << "accepted: " << words;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  nlohmann::json j = Minimal();
  j["channels"]["magnetometer"] = {{"scale", 1}};
  expect_error(j, "s.json.channels.magnetometer: unknown channel");
  j = Minimal();
  j["channels"]["compass"].erase("scale");
  expect_error(j, "s.json.channels.compass: missing field 'scale'");
  j = Minimal();
  j["channels"]["compass"]["scael"] = 2;
  expect_error(j, "unknown field 'scael'");
  j = Minimal();
  j["channels"]["enc_fl"]["wheel_radius_m"] = -0.2;
  expect_error(j, "wheel_radius_m: must be > 0");
  j = Minimal();
  j["channels"]["compass"]["units"] = "furlongs";
  expect_error(j, "units");
  j = Minimal();
  j["channels"]["gyro_z"]["column"] = "heading_raw";
  expect_error(j, "used twice");
  j = Minimal();
  j["format"] = "something else";
  expect_error(j, "format");
  j = Minimal();
  j["time_units"] = "fortnights";
  expect_error(j, "s.json.time_units: 'fortnights'");
  j = Minimal();
  j["vehicle"] = {{"max_turn_accel_dps2", -5}};
  expect_error(j, "s.json.vehicle.max_turn_accel_dps2: must be > 0");
  j = Minimal();
  j["vehicle"] = {{"top_speed", 1}};
  expect_error(j, "s.json.vehicle: unknown field 'top_speed'");
  j = Minimal();
  j["channels"]["compass"]["noise_rms"] = -1;
  expect_error(j, "noise_rms: must be >= 0");
  // What no sensor is: a wheel of 1e300 m (it made positions of 10^297 m, exit 0), a scale of
  // 1e308 units a count.
  j = Minimal();
  j["channels"]["enc_fl"]["wheel_radius_m"] = 1e300;
  expect_error(j, "s.json.channels.enc_fl.wheel_radius_m: must be > 0 and at most 10 m, got 1e+300");
  j = Minimal();
  j["channels"]["compass"]["scale"] = 1e308;
  expect_error(j, "s.json.channels.compass.scale: must be nonzero and at most 1000 units a count");
  j = Minimal();
  j["channels"]["compass"]["offset"] = -1e200;
  expect_error(j, "s.json.channels.compass.offset: must be within 10^6 units");
}

TEST(SensorModelFromJson, ReadsTimeUnitsVehicleLimitsAndNoiseAndWritesThemBack) {
  nlohmann::json j = Minimal();
  j["time_units"] = "ns";
  j["vehicle"] = {{"max_turn_accel_dps2", 500}, {"max_tilt_rate_dps", 45}};
  j["channels"]["compass"]["noise_rms"] = 2.5;
  const SensorModel m = SensorModelFromJson(j, "s.json");
  EXPECT_EQ(m.time_units, TimeUnits::kNanoseconds);
  EXPECT_EQ(SecondsPer(m.time_units), 1e-9);
  EXPECT_EQ(m.vehicle.max_turn_accel_dps2, 500.0);
  EXPECT_EQ(m.vehicle.max_tilt_rate_dps, 45.0);
  EXPECT_FALSE(m.vehicle.max_speed_mps.has_value());
  EXPECT_EQ(m[Channel::kCompass].noise_rms, 2.5);
  const SensorModel back = SensorModelFromJson(m.ToJson(), "back");
  EXPECT_EQ(back.time_units, TimeUnits::kNanoseconds);
  EXPECT_EQ(back.vehicle.max_turn_accel_dps2, 500.0);
  EXPECT_EQ(back[Channel::kCompass].noise_rms, 2.5);
  // Defaults: seconds, no limits (screening's own), noise unknown.
  const SensorModel plain = SensorModelFromJson(Minimal(), "s.json");
  EXPECT_EQ(plain.time_units, TimeUnits::kSeconds);
  EXPECT_TRUE(plain.vehicle.empty());
  EXPECT_EQ(plain[Channel::kCompass].noise_rms, 0.0);
}

TEST(ReadSensorModel, ReadsThePaperRoversExample) {
  const SensorModel m = ReadSensorModel(util::TestDataPath("telemetry/ratler_sensors.json"));
  for (Channel c : kAllChannels) EXPECT_TRUE(m[c].present) << ToString(c);
}

}  // namespace
}  // namespace lunarnav::telemetry
