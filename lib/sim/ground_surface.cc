#include "sim/ground_surface.h"

#include <cmath>

#include "sim/portable_random.h"
#include "util/check.h"

namespace lunarnav::sim {
namespace {
constexpr double kDeg = M_PI / 180.0;
// Sinusoids per band: enough for an irregular, direction-free surface.
constexpr int kWavesPerBand = 8;
}  // namespace

void GroundSurfaceOptions::Validate() const {
  LN_CHECK_ARG(slope_deg >= 0 && slope_deg < 45) << "ground slope: must be in [0, 45) deg";
  LN_CHECK_ARG(std::isfinite(slope_azimuth_deg)) << "ground slope azimuth: not finite";
  LN_CHECK_ARG(undulation_m >= 0 && roughness_m >= 0) << "ground heights: must be >= 0";
  LN_CHECK_ARG(undulation_wavelength_m > 0 && roughness_wavelength_m > 0)
      << "ground wavelengths: must be > 0";
}

nlohmann::json GroundSurfaceOptions::ToJson() const {
  return {{"slope_deg", slope_deg},
          {"slope_azimuth_deg", slope_azimuth_deg},
          {"undulation_m", undulation_m},
          {"undulation_wavelength_m", undulation_wavelength_m},
          {"roughness_m", roughness_m},
          {"roughness_wavelength_m", roughness_wavelength_m}};
}

GroundSurface::GroundSurface(const GroundSurfaceOptions& options, std::uint64_t seed) : options_(options) {
  options.Validate();
  const double g = std::tan(options.slope_deg * kDeg);
  grad_x_ = g * std::sin(options.slope_azimuth_deg * kDeg);
  grad_y_ = g * std::cos(options.slope_azimuth_deg * kDeg);
  PortableRandom rng(seed, "ground");
  for (const auto& [rms, wavelength] : {std::pair{options.undulation_m, options.undulation_wavelength_m},
                                        std::pair{options.roughness_m, options.roughness_wavelength_m}}) {
    // N sinusoids of amplitude a have variance N a^2 / 2: a = rms sqrt(2 / N).
    const double amplitude = rms * std::sqrt(2.0 / kWavesPerBand);
    for (int i = 0; i < kWavesPerBand; ++i) {
      const double direction = rng.Uniform(0.0, M_PI);
      const double k = 2.0 * M_PI / (wavelength * rng.Uniform(0.7, 1.4));
      const double phase = rng.Uniform(0.0, 2.0 * M_PI);
      if (amplitude > 0) waves_.push_back({k * std::cos(direction), k * std::sin(direction), phase, amplitude});
    }
  }
}

double GroundSurface::HeightAt(double x_m, double y_m) const {
  double z = grad_x_ * x_m + grad_y_ * y_m;
  for (const Wave& w : waves_) z += w.amplitude * std::sin(w.kx * x_m + w.ky * y_m + w.phase);
  return z;
}

}  // namespace lunarnav::sim
