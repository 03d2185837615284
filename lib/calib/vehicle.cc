#include "calib/vehicle.h"

#include <cmath>
#include <set>

#include "io/json_io.h"
#include "util/check.h"

namespace lunarnav::calib {
namespace {

constexpr const char* kFormat = "lunarnav.vehicle/1";

void OnlyKeys(const nlohmann::json& j, const std::set<std::string>& allowed, const std::string& where) {
  LN_CHECK_INPUT(j.is_object()) << where << ": expected an object";
  for (const auto& [key, value] : j.items()) {
    LN_CHECK_INPUT(allowed.count(key) > 0) << where << ": unknown field '" << key << "'";
  }
}

double Number(const nlohmann::json& j, const char* key, const std::string& where) {
  LN_CHECK_INPUT(j.contains(key)) << where << ": missing field '" << key << "'";
  LN_CHECK_INPUT(j.at(key).is_number()) << where << "." << key << ": expected a number";
  return j.at(key).get<double>();
}

// A value in (lo, hi] (or [lo, hi] with closed_low): what the vehicle files of real rovers
// and cars hold, with room; beyond it a value is a mistake that would make the planner's
// distances or the map's rules absurd (a friction of 1e-300 made requests of 10^300 m, blamed
// on the poses).
void CheckRange(double value, double lo, double hi, bool closed_low, const std::string& where, const char* units) {
  const bool low_ok = closed_low ? value >= lo : value > lo;
  LN_CHECK_INPUT(std::isfinite(value) && low_ok && value <= hi)
      << where << ": must be in " << (closed_low ? "[" : "(") << lo << ", " << hi << "]" << units << ", got " << value;
}

}  // namespace

void VehicleSpec::Validate(const std::string& source) const {
  CheckRange(max_speed_m_s, 0, 100, false, source + ".max_speed_m_s", " m/s");
  CheckRange(sliding_friction, 0.01, 10, true, source + ".sliding_friction", "");
  CheckRange(stop_time_s, 0, 3600, true, source + ".stop_time_s", " s");
  CheckRange(width_m, 0, 100, false, source + ".width_m", " m");
  CheckRange(wheel_diameter_m, 0, 20, false, source + ".wheel_diameter_m", " m");
  CheckRange(front_axle_y_m, -100, 100, true, source + ".front_axle_y_m", " m");
  LN_CHECK_INPUT(std::isfinite(max_slope_deg) && max_slope_deg > 0 && max_slope_deg < 90)
      << source << ".max_slope_deg: must be in (0, 90), got " << max_slope_deg;
  const std::string r = source + ".requirements";
  CheckRange(requirements.fov_vehicle_widths, 0, 1000, false, r + ".fov_vehicle_widths", "");
  // At least 5 cm: the map's step rule keeps a tolerance of 2 cm below it.
  CheckRange(requirements.obstacle_height_m, 0.05, 10, true, r + ".obstacle_height_m", " m");
  CheckRange(requirements.obstacle_min_px, 1, 10000, true, r + ".obstacle_min_px", " px");
  CheckRange(requirements.far_range_m, 0, 1000, false, r + ".far_range_m", " m");
}

nlohmann::json VehicleSpecToJson(const VehicleSpec& v) {
  return {{"format", kFormat},
          {"name", v.name},
          {"max_speed_m_s", v.max_speed_m_s},
          {"sliding_friction", v.sliding_friction},
          {"stop_time_s", v.stop_time_s},
          {"width_m", v.width_m},
          {"wheel_diameter_m", v.wheel_diameter_m},
          {"front_axle_y_m", v.front_axle_y_m},
          {"max_slope_deg", v.max_slope_deg},
          {"requirements", {{"fov_vehicle_widths", v.requirements.fov_vehicle_widths},
                            {"obstacle_height_m", v.requirements.obstacle_height_m},
                            {"obstacle_min_px", v.requirements.obstacle_min_px},
                            {"far_range_m", v.requirements.far_range_m}}}};
}

VehicleSpec VehicleSpecFromJson(const nlohmann::json& j, const std::string& source) {
  OnlyKeys(j,
           {"format", "name", "description", "sources", "max_speed_m_s", "sliding_friction", "stop_time_s", "width_m",
            "wheel_diameter_m", "front_axle_y_m", "max_slope_deg", "requirements"},
           source);
  LN_CHECK_INPUT(j.contains("format") && j["format"] == kFormat)
      << source << ".format: expected \"" << kFormat << "\"";
  VehicleSpec v;
  if (j.contains("name")) {
    LN_CHECK_INPUT(j["name"].is_string()) << source << ".name: expected a string";
    v.name = j["name"].get<std::string>();
  }
  v.max_speed_m_s = Number(j, "max_speed_m_s", source);
  v.sliding_friction = Number(j, "sliding_friction", source);
  v.stop_time_s = Number(j, "stop_time_s", source);
  v.width_m = Number(j, "width_m", source);
  v.wheel_diameter_m = Number(j, "wheel_diameter_m", source);
  v.front_axle_y_m = Number(j, "front_axle_y_m", source);
  if (j.contains("max_slope_deg")) v.max_slope_deg = Number(j, "max_slope_deg", source);
  if (j.contains("requirements")) {
    const std::string r = source + ".requirements";
    const nlohmann::json& rj = j["requirements"];
    OnlyKeys(rj, {"fov_vehicle_widths", "obstacle_height_m", "obstacle_min_px", "far_range_m"}, r);
    ImagingRequirements& q = v.requirements;
    if (rj.contains("fov_vehicle_widths")) q.fov_vehicle_widths = Number(rj, "fov_vehicle_widths", r);
    if (rj.contains("obstacle_height_m")) q.obstacle_height_m = Number(rj, "obstacle_height_m", r);
    if (rj.contains("obstacle_min_px")) q.obstacle_min_px = Number(rj, "obstacle_min_px", r);
    if (rj.contains("far_range_m")) q.far_range_m = Number(rj, "far_range_m", r);
  }
  v.Validate(source);
  return v;
}

VehicleSpec ReadVehicleSpec(const std::filesystem::path& path) {
  return VehicleSpecFromJson(io::ReadJson(path), path.string());
}

}  // namespace lunarnav::calib
