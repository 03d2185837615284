#include "calib/vehicle.h"

#include <gtest/gtest.h>

#include "util/errors.h"
#include "util/testing.h"

namespace lunarnav::calib {
namespace {

TEST(VehicleSpec, RoundTripsThroughJson) {
  VehicleSpec v;
  v.name = "test";
  v.max_speed_m_s = 1.1;
  v.front_axle_y_m = -0.2;
  v.requirements.far_range_m = 9.0;
  const VehicleSpec back = VehicleSpecFromJson(VehicleSpecToJson(v), "v");
  EXPECT_EQ(back.name, "test");
  EXPECT_EQ(back.max_speed_m_s, 1.1);
  EXPECT_EQ(back.front_axle_y_m, -0.2);
  EXPECT_EQ(back.requirements.far_range_m, 9.0);
  EXPECT_EQ(back.requirements.obstacle_min_px, 6.0);
}

TEST(VehicleSpec, TheShippedRatlerHoldsThePapersValues) {
  const VehicleSpec v = ReadVehicleSpec(util::TestDataPath("vehicles/ratler.json"));
  EXPECT_EQ(v.name, "Ratler");
  EXPECT_EQ(v.max_speed_m_s, 0.7);       // sec. 3.1
  EXPECT_EQ(v.sliding_friction, 0.25);   // sec. 3.1
  EXPECT_EQ(v.stop_time_s, 2.0);         // sec. 3.1
  EXPECT_NEAR(3 * v.width_m, 4.0, 0.001);  // "3 vehicle widths (about 400 cm)"
  EXPECT_EQ(v.requirements.obstacle_height_m, 0.2);
  EXPECT_EQ(v.requirements.obstacle_min_px, 6.0);
  EXPECT_DOUBLE_EQ(v.FrontOfWheelsY(), 0.75);
}

TEST(VehicleSpec, RejectsUnknownMissingAndImpossibleFields) {
  nlohmann::json j = VehicleSpecToJson(VehicleSpec());
  j["colour"] = "red";
  EXPECT_THROW(VehicleSpecFromJson(j, "v"), InputError);
  j = VehicleSpecToJson(VehicleSpec());
  j.erase("width_m");
  try {
    VehicleSpecFromJson(j, "v.json");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("v.json: missing field 'width_m'"), std::string::npos) << e.what();
  }
  j = VehicleSpecToJson(VehicleSpec());
  j["sliding_friction"] = -0.1;
  EXPECT_THROW(VehicleSpecFromJson(j, "v"), InputError);
  j = VehicleSpecToJson(VehicleSpec());
  j["requirements"]["pixels"] = 6;
  EXPECT_THROW(VehicleSpecFromJson(j, "v"), InputError);
  j = VehicleSpecToJson(VehicleSpec());
  j["format"] = "lunarnav.rig/1";
  EXPECT_THROW(VehicleSpecFromJson(j, "v"), InputError);
  // Values no vehicle has, named with their range: a friction of 1e-300 made the planner's
  // requests reach 10^300 m (and blamed the poses); an obstacle 1e-300 m tall was blamed on
  // terrain-map's --step-tolerance.
  auto message = [](const nlohmann::json& bad) {
    try {
      VehicleSpecFromJson(bad, "v.json");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  j = VehicleSpecToJson(VehicleSpec());
  j["sliding_friction"] = 1e-300;
  EXPECT_NE(message(j).find("v.json.sliding_friction: must be in [0.01, 10], got 1e-300"), std::string::npos)
      << message(j);
  j = VehicleSpecToJson(VehicleSpec());
  j["requirements"]["obstacle_height_m"] = 1e-300;
  EXPECT_NE(message(j).find("v.json.requirements.obstacle_height_m: must be in [0.05, 10] m"), std::string::npos)
      << message(j);
  j = VehicleSpecToJson(VehicleSpec());
  j["max_speed_m_s"] = 1e300;
  EXPECT_NE(message(j).find("v.json.max_speed_m_s: must be in (0, 100] m/s"), std::string::npos) << message(j);
}

}  // namespace
}  // namespace lunarnav::calib
