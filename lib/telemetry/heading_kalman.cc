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
  LN_CHECK_ARG(gate_smoothing_s >= 0 && std::isfinite(gate_smoothing_s))
      << "heading filter: gate smoothing must be >= 0 s";
  LN_CHECK_ARG(gyro_scale_sigma >= 0 && gyro_scale_sigma < 0.5 && gyro_scale_walk_per_sqrt_s >= 0 &&
               std::isfinite(gyro_scale_walk_per_sqrt_s))
      << "heading filter: gyro scale sigma must be in [0, 0.5) and its walk >= 0";
  LN_CHECK_ARG(std::isfinite(initial_heading_deg)) << "initial heading: not finite";
}

nlohmann::json HeadingKalmanOptions::ToJson() const {
  return {{"compass_sigma_deg", compass_sigma_deg}, {"gyro_sigma_dps", gyro_sigma_dps},
          {"rate_walk_dps2", rate_walk_dps2},       {"turn_gate_dps", turn_gate_dps},
          {"accel_gate_dps2", accel_gate_dps2},     {"gate_gain", gate_gain},
          {"gate_smoothing_s", gate_smoothing_s},       {"gyro_scale_sigma", gyro_scale_sigma},
          {"gyro_scale_walk_per_sqrt_s", gyro_scale_walk_per_sqrt_s},
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

  // State: heading, true heading rate, gyro scale error s (the gyro reads (1 + s) x rate).
  // Without the scale state s stays 0 with no variance, and the filter is the 2-state one.
  const bool estimate_scale = o.gyro_scale_sigma > 0;
  const double q_scale = std::pow(o.gyro_scale_walk_per_sqrt_s, 2);  // per second
  // Initial state: the first compass reading (else the given heading), rate 0, uncertain.
  Eigen::Vector3d x(o.initial_heading_deg * kDeg, 0.0, 0.0);
  Eigen::Matrix3d p =
      Eigen::Vector3d(std::pow(10 * kDeg, 2), std::pow(5 * kDeg, 2), std::pow(o.gyro_scale_sigma, 2)).asDiagonal();
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
  // The gate's turn rate and acceleration: the gyro's rate low-passed (first order, time
  // constant gate_smoothing_s) and that rate's derivative low-passed the same way. A damped
  // compass's transients are smoothed functions of the motion, and so is the gate: it falls
  // as the transient dies out after a turn, and the gyro's sample-to-sample noise (a
  // differentiated noisy rate reads several deg/s^2 at rest) does not gate a steady rover.
  double gate_rate = 0, gate_accel = 0, gate_time = std::numeric_limits<double>::quiet_NaN();
  // The covariance as plain numbers: P, a 3x3 matrix updated in place every sample. Each
  // expression is the one the matrix form (F P F' + Q, P - K H P, ...) reduces to once the
  // known zeros and ones of F and H are taken out, so the arithmetic, and the result, is the
  // same to the last bit; written out it is several times faster than general 3x3 products.
  double xh = x(0), xr = x(1), xs = x(2);
  double P[3][3];
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) P[i][j] = p(i, j);
  }
  double alpha_dt = std::numeric_limits<double>::quiet_NaN(), alpha = 0;  // alpha for the last dt
  const double turn_gate = o.turn_gate_dps * kDeg, accel_gate = o.accel_gate_dps2 * kDeg;
  for (std::size_t k = 0; k < n; ++k) {
    // Predict: F = [1 dt 0; 0 1 0; 0 0 1].
    if (k > 0) {
      const double dt = in.t_s[k] - in.t_s[k - 1];
      xh = xh + dt * xr;
      double fp[3][3];  // F P: row 0 gains dt times row 1
      for (int j = 0; j < 3; ++j) {
        fp[0][j] = P[0][j] + dt * P[1][j];
        fp[1][j] = P[1][j];
        fp[2][j] = P[2][j];
      }
      for (int i = 0; i < 3; ++i) {  // (F P) F': column 0 gains dt times column 1
        P[i][0] = fp[i][0] + dt * fp[i][1];
        P[i][1] = fp[i][1];
        P[i][2] = fp[i][2];
      }
      const double q01 = q_rate * dt * dt / 2;
      P[0][0] += q_rate * dt * dt * dt / 3;
      P[0][1] += q01;
      P[1][0] += q01;
      P[1][1] += q_rate * dt;
      P[2][2] += estimate_scale ? q_scale * dt : 0.0;
    }
    // Gyro: measures (1 + s) x the rate (after removing the bias); linearised (EKF).
    if (have_gyro && !std::isnan(in.gyro_radps[k])) {
      const double raw = in.gyro_radps[k];
      if (o.estimate_gyro_bias && !in.stationary.empty() && in.stationary[k]) {
        bias_sum += raw;
        ++bias_count;
      }
      const double bias = bias_count > 0 ? bias_sum / bias_count : 0.0;
      const double rate = raw - bias;
      if (std::isnan(gate_time) || o.gate_smoothing_s == 0) {
        gate_accel = std::isnan(gate_time) || in.t_s[k] <= gate_time ? 0.0 : (rate - gate_rate) / (in.t_s[k] - gate_time);
        gate_rate = rate;
      } else if (in.t_s[k] > gate_time) {
        const double dt = in.t_s[k] - gate_time;
        if (dt != alpha_dt) {  // the same interval as last time (the usual case): the same alpha
          alpha = 1.0 - std::exp(-dt / o.gate_smoothing_s);
          alpha_dt = dt;
        }
        const double previous = gate_rate;
        gate_rate += alpha * (rate - gate_rate);
        gate_accel += alpha * ((gate_rate - previous) / dt - gate_accel);
      }
      gate_time = in.t_s[k];
      // H = [0, 1 + s, rate] (rate only with the scale state).
      const double h1 = 1.0 + xs, h2 = estimate_scale ? xr : 0.0;
      double hp[3];  // H P
      for (int j = 0; j < 3; ++j) hp[j] = h1 * P[1][j] + h2 * P[2][j];
      const double s = (hp[1] * h1 + hp[2] * h2) + r_gyro;
      double gain[3];
      for (int i = 0; i < 3; ++i) gain[i] = (P[i][1] * h1 + P[i][2] * h2) / s;
      const double innovation = rate - (1.0 + xs) * xr;
      xh += gain[0] * innovation;
      xr += gain[1] * innovation;
      xs += gain[2] * innovation;
      double khp[3][3];  // (K H) P
      for (int i = 0; i < 3; ++i) {
        const double k1 = gain[i] * h1, k2 = gain[i] * h2;
        for (int j = 0; j < 3; ++j) khp[i][j] = k1 * P[1][j] + k2 * P[2][j];
      }
      for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) P[i][j] -= khp[i][j];
      }
      ++out.gyro_updates;
    }
    // Compass: measures the heading; believed little while turning or accelerating.
    if (have_compass && !std::isnan(in.compass_rad[k])) {
      const double gate = 1.0 + o.gate_gain * (std::pow(gate_rate / turn_gate, 2) +
                                               std::pow(gate_accel / accel_gate, 2));
      const double innovation = WrapPi(in.compass_rad[k] - xh);
      const double s = P[0][0] + r_compass * gate;
      const double gain[3] = {P[0][0] / s, P[1][0] / s, P[2][0] / s};
      xh += gain[0] * innovation;
      xr += gain[1] * innovation;
      xs += gain[2] * innovation;
      const double row0[3] = {P[0][0], P[0][1], P[0][2]};
      for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) P[i][j] -= gain[i] * row0[j];
      }
      ++out.compass_updates;
    }
    for (int i = 0; i < 3; ++i) {  // symmetric: 0.5 (P + P')
      for (int j = i + 1; j < 3; ++j) P[i][j] = P[j][i] = 0.5 * (P[i][j] + P[j][i]);
    }
    out.heading_rad[k] = xh;
    out.rate_radps[k] = xr;
    out.heading_sigma_rad[k] = std::sqrt(std::max(0.0, P[0][0]));
  }
  out.gyro_scale_error = xs;
  out.gyro_scale_sigma = std::sqrt(std::max(0.0, P[2][2]));
  out.gyro_bias_radps = bias_count > 0 ? bias_sum / bias_count : 0.0;
  return out;
}

}  // namespace lunarnav::telemetry
