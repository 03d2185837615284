#include "telemetry/heading_kalman.h"

#include <cmath>
#include <limits>

#include <Eigen/Dense>

#include "util/check.h"

namespace lunarnav::telemetry {
namespace {
constexpr double kDeg = M_PI / 180.0;
}  // namespace

double WrapPi(double angle_rad) {
  double a = std::fmod(angle_rad + M_PI, 2.0 * M_PI);
  if (a <= 0) a += 2.0 * M_PI;
  return a - M_PI;
}

void HeadingKalmanOptions::Validate() const {
  LN_CHECK_ARG(compass_sigma_deg > 0 && gyro_sigma_dps > 0 && rate_walk_dps2 > 0)
      << "heading filter: noise levels must be > 0";
  LN_CHECK_ARG(turn_gate_dps > 0 && accel_gate_dps2 > 0 && gate_gain >= 0)
      << "heading filter: gates must be > 0 and the gain >= 0";
  LN_CHECK_ARG(std::isfinite(initial_heading_deg)) << "initial heading: not finite";
}

nlohmann::json HeadingKalmanOptions::ToJson() const {
  return {{"compass_sigma_deg", compass_sigma_deg}, {"gyro_sigma_dps", gyro_sigma_dps},
          {"rate_walk_dps2", rate_walk_dps2},       {"turn_gate_dps", turn_gate_dps},
          {"accel_gate_dps2", accel_gate_dps2},     {"gate_gain", gate_gain},
          {"estimate_gyro_bias", estimate_gyro_bias}, {"initial_heading_deg", initial_heading_deg}};
}

HeadingEstimate FilterHeading(const HeadingInputs& in, const HeadingKalmanOptions& o) {
  o.Validate();
  const std::size_t n = in.t_s.size();
  const bool have_compass = !in.compass_rad.empty();
  const bool have_gyro = !in.gyro_radps.empty();
  LN_CHECK(!have_compass || in.compass_rad.size() == n);
  LN_CHECK(!have_gyro || in.gyro_radps.size() == n);
  HeadingEstimate out;
  out.heading_rad.resize(n);
  out.rate_radps.resize(n);
  out.heading_sigma_rad.resize(n);
  if (n == 0) return out;

  const double r_compass = std::pow(o.compass_sigma_deg * kDeg, 2);
  const double r_gyro = std::pow(o.gyro_sigma_dps * kDeg, 2);
  const double q_rate = std::pow(o.rate_walk_dps2 * kDeg, 2);  // per second

  // Initial state: the first compass reading (else the given heading), rate 0, uncertain.
  Eigen::Vector2d x(o.initial_heading_deg * kDeg, 0.0);
  Eigen::Matrix2d p = Eigen::Vector2d(std::pow(10 * kDeg, 2), std::pow(5 * kDeg, 2)).asDiagonal();
  bool initialised = false;
  if (have_compass) {
    for (std::size_t k = 0; k < n; ++k) {
      if (!std::isnan(in.compass_rad[k])) {
        x(0) = in.compass_rad[k];
        p(0, 0) = r_compass;
        initialised = true;
        break;
      }
    }
  }
  if (!initialised) p(0, 0) = 0.0;  // no compass: the heading is relative to the start

  double bias_sum = 0;
  long bias_count = 0;
  double previous_gyro = std::numeric_limits<double>::quiet_NaN(), previous_gyro_t = 0;
  double gate_rate = 0, gate_accel = 0;  // latest gyro turn rate and its change, rad/s, rad/s^2
  for (std::size_t k = 0; k < n; ++k) {
    // Predict.
    if (k > 0) {
      const double dt = in.t_s[k] - in.t_s[k - 1];
      Eigen::Matrix2d f;
      f << 1, dt, 0, 1;
      x = f * x;
      Eigen::Matrix2d q;
      q << dt * dt * dt / 3, dt * dt / 2, dt * dt / 2, dt;
      p = f * p * f.transpose() + q_rate * q;
    }
    // Gyro: measures the rate (after removing the bias).
    if (have_gyro && !std::isnan(in.gyro_radps[k])) {
      const double raw = in.gyro_radps[k];
      if (o.estimate_gyro_bias && !in.stationary.empty() && in.stationary[k]) {
        bias_sum += raw;
        ++bias_count;
      }
      const double bias = bias_count > 0 ? bias_sum / bias_count : 0.0;
      const double rate = raw - bias;
      if (!std::isnan(previous_gyro) && in.t_s[k] > previous_gyro_t) {
        gate_accel = (rate - previous_gyro) / (in.t_s[k] - previous_gyro_t);
      }
      previous_gyro = rate;
      previous_gyro_t = in.t_s[k];
      gate_rate = rate;
      const double s = p(1, 1) + r_gyro;
      const Eigen::Vector2d gain = p.col(1) / s;
      x += gain * (rate - x(1));
      p -= gain * p.row(1);
      ++out.gyro_updates;
    }
    // Compass: measures the heading; believed little while turning or accelerating.
    if (have_compass && !std::isnan(in.compass_rad[k])) {
      const double gate = 1.0 + o.gate_gain * (std::pow(gate_rate / (o.turn_gate_dps * kDeg), 2) +
                                               std::pow(gate_accel / (o.accel_gate_dps2 * kDeg), 2));
      const double innovation = WrapPi(in.compass_rad[k] - x(0));
      const double s = p(0, 0) + r_compass * gate;
      const Eigen::Vector2d gain = p.col(0) / s;
      x += gain * innovation;
      p -= gain * p.row(0);
      ++out.compass_updates;
    }
    out.heading_rad[k] = x(0);
    out.rate_radps[k] = x(1);
    out.heading_sigma_rad[k] = std::sqrt(std::max(0.0, p(0, 0)));
  }
  out.gyro_bias_radps = bias_count > 0 ? bias_sum / bias_count : 0.0;
  return out;
}

}  // namespace lunarnav::telemetry
