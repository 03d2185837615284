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
  // Already in range (the usual case): what the general path computes, without fmod.
  const double shifted = angle_rad + M_PI;
  if (shifted > 0 && shifted < 2.0 * M_PI) return shifted - M_PI;
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
  LN_CHECK_ARG(gyro_bias_walk_dps_per_sqrt_s >= 0 && std::isfinite(gyro_bias_walk_dps_per_sqrt_s))
      << "heading filter: the gyro bias walk must be >= 0";
  LN_CHECK_ARG(gyro_bias_sigma_dps > 0 && std::isfinite(gyro_bias_sigma_dps))
      << "heading filter: the gyro bias prior sigma must be > 0";
}

nlohmann::json HeadingKalmanOptions::ToJson() const {
  return {{"compass_sigma_deg", compass_sigma_deg}, {"gyro_sigma_dps", gyro_sigma_dps},
          {"rate_walk_dps2", rate_walk_dps2},       {"turn_gate_dps", turn_gate_dps},
          {"accel_gate_dps2", accel_gate_dps2},     {"gate_gain", gate_gain},
          {"gate_smoothing_s", gate_smoothing_s},       {"gyro_scale_sigma", gyro_scale_sigma},
          {"gyro_scale_walk_per_sqrt_s", gyro_scale_walk_per_sqrt_s},
          {"estimate_gyro_bias", estimate_gyro_bias}, {"gyro_bias_walk_dps_per_sqrt_s", gyro_bias_walk_dps_per_sqrt_s},
          {"gyro_bias_sigma_dps", gyro_bias_sigma_dps},
          {"zero_rate_when_stationary", zero_rate_when_stationary}, {"initial_heading_deg", initial_heading_deg}};
}

HeadingKalman::HeadingKalman(const HeadingKalmanOptions& options, double first_compass_rad) : o_(options) {
  o_.Validate();
  r_compass_ = std::pow(o_.compass_sigma_deg * kDeg, 2);
  r_gyro_ = std::pow(o_.gyro_sigma_dps * kDeg, 2);
  q_rate_ = std::pow(o_.rate_walk_dps2 * kDeg, 2);  // per second
  // Only observable states: the scale needs a heading reference (a compass).
  estimate_scale_ = o_.gyro_scale_sigma > 0 && !std::isnan(first_compass_rad);
  q_scale_ = std::pow(o_.gyro_scale_walk_per_sqrt_s, 2);  // per second
  turn_gate_ = o_.turn_gate_dps * kDeg;
  accel_gate_ = o_.accel_gate_dps2 * kDeg;
  // Initial state: the first compass reading (else the given heading, exactly: the heading
  // is then relative to the start), rate 0, uncertain.
  const bool have_compass = !std::isnan(first_compass_rad);
  xh_ = have_compass ? first_compass_rad : o_.initial_heading_deg * kDeg;
  p_[0][0] = have_compass ? r_compass_ : 0.0;
  p_[1][1] = std::pow(5 * kDeg, 2);
  p_[2][2] = estimate_scale_ ? std::pow(o_.gyro_scale_sigma, 2) : 0.0;
  // With a compass the bias is a state (observable through the compass) until the first stop.
  joint_bias_ = have_compass && o_.estimate_gyro_bias;
  q_bias_ = std::pow(o_.gyro_bias_walk_dps_per_sqrt_s * kDeg, 2);  // per second
  if (joint_bias_) p_[3][3] = std::pow(o_.gyro_bias_sigma_dps * kDeg, 2);
  // The gate's turn rate and acceleration: the gyro's rate low-passed (first order, time
  // constant gate_smoothing_s) and that rate's derivative low-passed the same way. A damped
  // compass's transients are smoothed functions of the motion, and so is the gate: it falls
  // as the transient dies out after a turn, and the gyro's sample-to-sample noise (a
  // differentiated noisy rate reads several deg/s^2 at rest) does not gate a steady rover.
  gate_time_ = std::numeric_limits<double>::quiet_NaN();
  alpha_dt_.fill(std::numeric_limits<double>::quiet_NaN());
}

double HeadingKalman::gyro_scale_sigma() const { return std::sqrt(std::max(0.0, p_[2][2])); }

double HeadingKalman::gyro_bias_sigma_radps() const {
  if (joint_bias_) return std::sqrt(std::max(0.0, p_[3][3]));
  return bias_count_ > 0 ? std::sqrt(bias_var_) : 0.0;
}

void HeadingKalman::Measure(const double (&h)[4], double innovation, double r) {
  double (&P)[4][4] = p_;
  double hp[4];  // H P, which is (P H')' as P is symmetric
  for (int j = 0; j < 4; ++j) hp[j] = h[0] * P[0][j] + h[1] * P[1][j] + h[2] * P[2][j] + h[3] * P[3][j];
  const double s = hp[0] * h[0] + hp[1] * h[1] + hp[2] * h[2] + hp[3] * h[3] + r;
  double gain[4];
  for (int i = 0; i < 4; ++i) gain[i] = hp[i] / s;
  xh_ += gain[0] * innovation;
  xr_ += gain[1] * innovation;
  xs_ += gain[2] * innovation;
  xb_ += gain[3] * innovation;
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 4; ++j) P[i][j] -= gain[i] * hp[j];
  }
}

// The covariance is kept as plain numbers, P a 4x4 matrix updated in place: each expression
// is the one the matrix form (F P F' + Q, P - K H P, ...) reduces to once the known zeros and
// ones of F and H are taken out; written out it is several times faster than general 3x3
// products.
HeadingKalman::Output HeadingKalman::Update(double t_s, double compass_rad, double gyro_radps, bool stationary,
                                            HeadingKalmanStep* step) {
  double (&P)[4][4] = p_;
  if (step != nullptr) step->dt = started_ ? t_s - last_t_ : 0.0;
  // Predict: F = [1 dt 0 0; 0 1 0 0; 0 0 1 0; 0 0 0 1].
  if (started_) {
    const double dt = t_s - last_t_;
    xh_ = xh_ + dt * xr_;
    // F P: row 0 gains dt times row 1; then (F P) F': column 0 gains dt times column 1.
    // Element by element (an array in between was stored in halves and read back whole,
    // which the processor cannot forward).
    const double fp01 = P[0][1] + dt * P[1][1];
    P[0][0] = (P[0][0] + dt * P[1][0]) + dt * fp01;
    P[0][1] = fp01;
    P[0][2] = P[0][2] + dt * P[1][2];
    P[1][0] = P[1][0] + dt * P[1][1];
    P[2][0] = P[2][0] + dt * P[2][1];
    if (joint_bias_) {
      P[0][3] = P[0][3] + dt * P[1][3];
      P[3][0] = P[3][0] + dt * P[3][1];
      P[3][3] += q_bias_ * dt;
    }
    const double q01 = q_rate_ * dt * dt / 2;
    P[0][0] += q_rate_ * dt * dt * dt / 3;
    P[0][1] += q01;
    P[1][0] += q01;
    P[1][1] += q_rate_ * dt;
    P[2][2] += estimate_scale_ ? q_scale_ * dt : 0.0;
  }
  started_ = true;
  last_t_ = t_s;
  if (step != nullptr) {
    step->x_predicted = {xh_, xr_, xs_, xb_};
    for (int i = 0; i < 4; ++i) {
      for (int j = 0; j < 4; ++j) step->p_predicted[i][j] = P[i][j];
    }
  }
  // Gyro: measures (1 + s) x the rate (after removing the bias); linearised (EKF).
  if (!std::isnan(gyro_radps)) {
    if (o_.estimate_gyro_bias && stationary && joint_bias_) {
      // The first stop: from here on the stops show the bias, directly; the compass showed it
      // through its transients (a damped compass lags a long turn by a steady amount, which a
      // bias state learning from it all along would take in and keep). What the compass has
      // taught so far (once it has halved the prior's sigma) is the stops' prior, and the bias
      // leaves the filter's state.
      joint_bias_ = false;
      if (P[3][3] < 0.25 * std::pow(o_.gyro_bias_sigma_dps * kDeg, 2)) {  // the compass has shown something
        bias_ = xb_;
        bias_var_ = P[3][3];
        bias_t_ = t_s;
        bias_prior_from_compass_ = true;
      }
      for (int j = 0; j < 4; ++j) P[3][j] = P[j][3] = 0.0;
      xb_ = 0.0;
    }
    if (o_.estimate_gyro_bias && stationary) {
      if (!was_stationary_) ++bias_periods_;  // a new stationary period
      if (bias_count_ == 0 && !bias_prior_from_compass_) {  // the first reading: the estimate, with the gyro's noise
        bias_ = gyro_radps;
        bias_var_ = r_gyro_;
      } else {  // the estimate has wandered since its last update; this reading corrects it
        const double q = o_.gyro_bias_walk_dps_per_sqrt_s * kDeg;
        bias_var_ += q * q * std::max(0.0, t_s - bias_t_);
        const double gain = bias_var_ / (bias_var_ + r_gyro_);
        bias_ += gain * (gyro_radps - bias_);
        bias_var_ *= 1.0 - gain;
      }
      bias_t_ = t_s;
      ++bias_count_;
    }
    was_stationary_ = stationary;
    const double rate = stationary && o_.zero_rate_when_stationary ? 0.0 : gyro_radps - gyro_bias_radps();
    if (std::isnan(gate_time_) || o_.gate_smoothing_s == 0) {
      gate_accel_ = std::isnan(gate_time_) || t_s <= gate_time_ ? 0.0 : (rate - gate_rate_) / (t_s - gate_time_);
      gate_rate_ = rate;
    } else if (t_s > gate_time_) {
      const double dt = t_s - gate_time_;
      // An interval seen lately (the usual case): its alpha again, without exp().
      int entry = 0;
      while (entry < kAlphaCache && alpha_dt_[entry] != dt) ++entry;
      if (entry == kAlphaCache) {
        entry = alpha_next_;
        alpha_next_ = (alpha_next_ + 1) % kAlphaCache;
        alpha_[entry] = 1.0 - std::exp(-dt / o_.gate_smoothing_s);
        alpha_dt_[entry] = dt;
      }
      const double alpha = alpha_[entry];
      const double previous = gate_rate_;
      gate_rate_ += alpha * (rate - gate_rate_);
      gate_accel_ += alpha * ((gate_rate_ - previous) / dt - gate_accel_);
    }
    gate_time_ = t_s;
    if (joint_bias_) {
      // The reading is (1 + s) x rate + b: H = [0, 1 + s, rate, 1] (rate only with the scale
      // state). Standing still, the rate is first known to be 0 (a rover does not turn with
      // its wheels still: a measurement far finer than the gyro), so the reading shows b.
      if (stationary && o_.zero_rate_when_stationary) Measure({0.0, 1.0, 0.0, 0.0}, -xr_, 1e-4 * r_gyro_);
      const double h[4] = {0.0, 1.0 + xs_, estimate_scale_ ? xr_ : 0.0, 1.0};
      Measure(h, gyro_radps - (1.0 + xs_) * xr_ - xb_, r_gyro_);
    } else {
      // The rate, bias removed, is the measurement: H = [0, 1 + s, rate] (rate only with the
      // scale state).
      const double h1 = 1.0 + xs_, h2 = estimate_scale_ ? xr_ : 0.0;
      double hp[3];  // H P
      for (int j = 0; j < 3; ++j) hp[j] = h1 * P[1][j] + h2 * P[2][j];
      const double s = (hp[1] * h1 + hp[2] * h2) + r_gyro_;
      double gain[3];
      for (int i = 0; i < 3; ++i) gain[i] = (P[i][1] * h1 + P[i][2] * h2) / s;
      const double innovation = rate - (1.0 + xs_) * xr_;
      xh_ += gain[0] * innovation;
      xr_ += gain[1] * innovation;
      xs_ += gain[2] * innovation;
      double khp[3][3];  // (K H) P
      for (int i = 0; i < 3; ++i) {
        const double k1 = gain[i] * h1, k2 = gain[i] * h2;
        for (int j = 0; j < 3; ++j) khp[i][j] = k1 * P[1][j] + k2 * P[2][j];
      }
      for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) P[i][j] -= khp[i][j];
      }
    }
    ++gyro_updates_;
  }
  // Compass: measures the heading; believed little while turning or accelerating.
  if (!std::isnan(compass_rad)) {
    const double gate = 1.0 + o_.gate_gain * (std::pow(gate_rate_ / turn_gate_, 2) + std::pow(gate_accel_ / accel_gate_, 2));
    const double innovation = WrapPi(compass_rad - xh_);
    const double s = P[0][0] + r_compass_ * gate;
    const double gain[4] = {P[0][0] / s, P[1][0] / s, P[2][0] / s, P[3][0] / s};
    xh_ += gain[0] * innovation;
    xr_ += gain[1] * innovation;
    xs_ += gain[2] * innovation;
    xb_ += gain[3] * innovation;  // 0 without the bias state
    const double row0[4] = {P[0][0], P[0][1], P[0][2], P[0][3]};
    for (int i = 0; i < 4; ++i) {
      for (int j = 0; j < 4; ++j) P[i][j] -= gain[i] * row0[j];
    }
    ++compass_updates_;
  }
  for (int i = 0; i < 4; ++i) {  // symmetric: 0.5 (P + P')
    for (int j = i + 1; j < 4; ++j) P[i][j] = P[j][i] = 0.5 * (P[i][j] + P[j][i]);
  }
  if (step != nullptr) {
    step->x = {xh_, xr_, xs_, xb_};
    for (int i = 0; i < 4; ++i) {
      for (int j = 0; j < 4; ++j) step->p[i][j] = P[i][j];
    }
  }
  return {xh_, xr_, std::sqrt(std::max(0.0, P[0][0]))};
}

namespace {

// The filter over a whole log; with `steps`, each sample's step (one per sample) for a smoother.
HeadingEstimate RunFilter(const HeadingInputs& in, const HeadingKalmanOptions& o, std::vector<HeadingKalmanStep>* steps) {
  const std::size_t n = in.t_s.size();
  const bool have_compass = !in.compass_rad.empty();
  const bool have_gyro = !in.gyro_radps.empty();
  LN_CHECK(!have_compass || in.compass_rad.size() == n);
  LN_CHECK(!have_gyro || in.gyro_radps.size() == n);
  LN_CHECK(in.stationary.empty() || in.stationary.size() == n);
  double first_compass = std::numeric_limits<double>::quiet_NaN();
  for (std::size_t k = 0; have_compass && k < n && std::isnan(first_compass); ++k) first_compass = in.compass_rad[k];
  HeadingKalman filter(o, first_compass);
  HeadingEstimate out;
  out.heading_rad.resize(n);
  out.rate_radps.resize(n);
  out.heading_sigma_rad.resize(n);
  if (steps != nullptr) steps->resize(n);
  constexpr double kNone = std::numeric_limits<double>::quiet_NaN();
  for (std::size_t k = 0; k < n; ++k) {
    const HeadingKalman::Output e =
        filter.Update(in.t_s[k], have_compass ? in.compass_rad[k] : kNone, have_gyro ? in.gyro_radps[k] : kNone,
                      !in.stationary.empty() && in.stationary[k], steps != nullptr ? &(*steps)[k] : nullptr);
    out.heading_rad[k] = e.heading_rad;
    out.rate_radps[k] = e.rate_radps;
    out.heading_sigma_rad[k] = e.heading_sigma_rad;
  }
  out.gyro_scale_error = filter.gyro_scale_error();
  out.gyro_scale_sigma = filter.gyro_scale_sigma();
  out.gyro_bias_radps = filter.gyro_bias_radps();
  out.gyro_bias_from_compass = filter.gyro_bias_from_compass();
  out.compass_updates = filter.compass_updates();
  out.gyro_updates = filter.gyro_updates();
  return out;
}

}  // namespace

HeadingEstimate FilterHeading(const HeadingInputs& in, const HeadingKalmanOptions& o) { return RunFilter(in, o, nullptr); }

void SmoothHeadingSteps(std::span<const HeadingKalmanStep> steps, std::span<double> heading_rad,
                        std::span<double> rate_radps) {
  const std::size_t n = steps.size();
  LN_CHECK(heading_rad.size() == n && rate_radps.size() == n) << "SmoothHeadingSteps: one output per step";
  if (n == 0) return;
  using Vec = Eigen::Vector4d;
  using Mat = Eigen::Matrix4d;
  Vec xs(steps[n - 1].x.data());  // the smoothed state at step k + 1
  heading_rad[n - 1] = xs[0];
  rate_radps[n - 1] = xs[1];
  for (std::size_t k = n - 1; k-- > 0;) {
    const HeadingKalmanStep& now = steps[k];
    const HeadingKalmanStep& next = steps[k + 1];
    // x_k|n = x_k|k + C (x_k+1|n - x_k+1|k), C = P_k|k F' P_k+1|k^-1 with F = [1 dt 0 0; 0 1 0 0;
    // 0 0 1 0; 0 0 0 1], over the states the filter holds at both steps: the others (no scale
    // state; the bias once the stops show it, dropped between the steps) pass nothing back.
    Mat pf, pp;  // P_k|k F' and P_k+1|k, the states not held replaced by the identity's
    Vec d;
    bool active[4];
    for (int i = 0; i < 4; ++i) active[i] = now.p[i][i] > 0 && next.p_predicted[i][i] > 0 && next.p[i][i] > 0;
    for (int i = 0; i < 4; ++i) {
      for (int j = 0; j < 4; ++j) {
        const double pft = now.p[i][j] + (j == 0 ? next.dt * now.p[i][1] : 0.0);  // (P F')_ij
        pf(i, j) = active[j] ? pft : 0.0;
        pp(i, j) = active[i] && active[j] ? next.p_predicted[i][j] : (i == j ? 1.0 : 0.0);
      }
      d[i] = active[i] ? xs[i] - next.x_predicted[i] : 0.0;
    }
    const Eigen::LLT<Mat> llt(pp);  // P_k+1|k is positive definite over the states held
    Vec x(now.x.data());
    if (llt.info() == Eigen::Success) x += pf * llt.solve(d);
    xs = x;
    heading_rad[k] = xs[0];
    rate_radps[k] = xs[1];
  }
}

HeadingEstimate SmoothHeading(const HeadingInputs& in, const HeadingKalmanOptions& o) {
  std::vector<HeadingKalmanStep> steps;
  HeadingEstimate out = RunFilter(in, o, &steps);
  SmoothHeadingSteps(steps, out.heading_rad, out.rate_radps);
  return out;
}

}  // namespace lunarnav::telemetry
