// A smooth procedural ground surface for the telemetry simulator: a tilted plane with broad
// undulations and short bumps (sums of sinusoids), the ground a simulated rover drives on.
// (The stereo renderer's rocky height field is sim::Terrain; this one only needs heights and
// slopes under the wheels.)
#pragma once

#include <cstdint>
#include <vector>

#include <nlohmann/json.hpp>

namespace lunarnav::sim {

/// Shape of the ground. Heights are smooth (sums of sinusoids), so slopes are defined
/// everywhere. Frame: x east, y north, z up, metres.
struct GroundSurfaceOptions {
  double slope_deg = 0.0;             ///< Slope of the mean plane, degrees, [0, 45).
  double slope_azimuth_deg = 0.0;     ///< Direction of steepest ascent, clockwise from north.
  double undulation_m = 0.0;          ///< RMS height of the broad undulations, >= 0.
  double undulation_wavelength_m = 30.0;  ///< Their typical wavelength, > 0.
  double roughness_m = 0.0;           ///< RMS height of the short bumps, >= 0.
  double roughness_wavelength_m = 1.5;    ///< Their typical wavelength, > 0.
  void Validate() const;
  nlohmann::json ToJson() const;
};

/// The height field of GroundSurfaceOptions, with random wave directions, wavelengths and phases
/// drawn from a seed (the same seed gives the same surface).
class GroundSurface {
 public:
  GroundSurface(const GroundSurfaceOptions& options, std::uint64_t seed);
  /// Height above the plane through the origin at (x_m, y_m), metres.
  double HeightAt(double x_m, double y_m) const;
  const GroundSurfaceOptions& options() const { return options_; }

 private:
  struct Wave {
    double kx, ky, phase, amplitude;
  };
  GroundSurfaceOptions options_;
  double grad_x_ = 0, grad_y_ = 0;  // mean plane: dz/dx, dz/dy
  std::vector<Wave> waves_;
};

}  // namespace lunarnav::sim
