#include "telemetry/heading_kalman.h"
#include <algorithm>

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <Eigen/Dense>

#include "telemetry/lowpass.h"

namespace lunarnav::telemetry {
namespace {

constexpr double kDeg = M_PI / 180.0;

// 120 s at 10 Hz: standing still for 10 s, then straight, a 15 deg/s left turn through
// +-180 deg, straight, a right turn, straight. The gyro has a 1.5 deg/s bias and 0.3 deg/s
// noise; the compass has 2 deg noise and, while turning, a 25 deg transient proportional to
// the turn rate (the motors' currents disturb it), as in the paper's sec. 4.1.
struct TurningLog {
  HeadingInputs inputs;
  std::vector<double> truth_rad;

  TurningLog() {
    std::mt19937 rng(42);
    std::normal_distribution<double> gyro_noise(0.0, 0.3), compass_noise(0.0, 2.0);
    auto rate_dps = [](double t) {
      auto ramp = [](double t, double t0, double t1) {  // 0 -> 1 over 2 s at t0, back at t1
        return std::clamp((t - t0) / 2.0, 0.0, 1.0) * std::clamp((t1 - t) / 2.0, 0.0, 1.0);
      };
      return 15.0 * ramp(t, 30, 50) - 15.0 * ramp(t, 70, 90);
    };
    double heading_deg = 170.0;
    for (int i = 0; i < 1200; ++i) {
      const double t = 0.1 * i;
      if (i > 0) heading_deg += 0.5 * (rate_dps(t) + rate_dps(t - 0.1)) * 0.1;
      const double rate = rate_dps(t);
      inputs.t_s.push_back(t);
      truth_rad.push_back(heading_deg * kDeg);
      inputs.gyro_radps.push_back((rate + 1.5 + gyro_noise(rng)) * kDeg);
      const double compass_deg = heading_deg + compass_noise(rng) + 25.0 * rate / 15.0;
      inputs.compass_rad.push_back(WrapPi(compass_deg * kDeg));  // as a compass reads
      inputs.stationary.push_back(t < 10.0);
    }
  }
};

double RmsErrorDeg(const std::vector<double>& estimate, const std::vector<double>& truth) {
  double sum = 0;
  for (std::size_t k = 0; k < truth.size(); ++k) {
    sum += std::pow(WrapPi(estimate[k] - truth[k]) / kDeg, 2);
  }
  return std::sqrt(sum / truth.size());
}

TEST(FilterHeading, BeatsThePlainLowPassOnATurningLogWithCompassTransients) {
  const TurningLog log;
  const HeadingEstimate kalman = FilterHeading(log.inputs, HeadingKalmanOptions{});
  // The comparison: the compass, unwrapped and low-passed (2nd-order Butterworth, 0.25 Hz).
  std::vector<double> unwrapped = log.inputs.compass_rad;
  for (std::size_t k = 1; k < unwrapped.size(); ++k) {
    unwrapped[k] += 2 * M_PI * std::round((unwrapped[k - 1] - unwrapped[k]) / (2 * M_PI));
  }
  const std::vector<double> lowpass =
      FilterCausal(DesignLowPass(LowPassType::kButterworth, 2, 0.25, 10.0), unwrapped);
  const double kalman_rms = RmsErrorDeg(kalman.heading_rad, log.truth_rad);
  const double lowpass_rms = RmsErrorDeg(lowpass, log.truth_rad);
  // Measured (this revision): 0.51 deg against 6.35 deg.
  EXPECT_LT(kalman_rms, 0.25 * lowpass_rms) << kalman_rms << " vs " << lowpass_rms;
  EXPECT_LT(kalman_rms, 1.0);
  EXPECT_NEAR(kalman.gyro_bias_radps / kDeg, 1.5, 0.2);
}

TEST(FilterHeading, CrossingPlusMinus180DegreesIsNoEvent) {
  const TurningLog log;
  const HeadingEstimate kalman = FilterHeading(log.inputs, HeadingKalmanOptions{});
  // The first turn crosses 180 deg; the estimate stays continuous.
  for (std::size_t k = 1; k < kalman.heading_rad.size(); ++k) {
    ASSERT_LT(std::abs(kalman.heading_rad[k] - kalman.heading_rad[k - 1]), 3 * kDeg) << k;
  }
}

TEST(FilterHeading, IntegratesTheGyroWithoutACompass) {
  TurningLog log;
  log.inputs.compass_rad.clear();
  HeadingKalmanOptions options;
  options.initial_heading_deg = 170.0;
  const HeadingEstimate kalman = FilterHeading(log.inputs, options);
  EXPECT_EQ(kalman.compass_updates, 0);
  // Dead reckoning on a debiased gyro: small drift after 2 minutes.
  EXPECT_NEAR(WrapPi(kalman.heading_rad.back() - log.truth_rad.back()) / kDeg, 0.0, 5.0);
}

// 150 s at 10 Hz: still for 10 s, a 180 deg turn in place (10 deg/s, 2 s ramps), 40 s
// still and straight, the turn back, 40 s. The gyro reads 4 % short (scale error -0.04), with
// a 0.5 deg/s bias and 0.3 deg/s noise; the compass has 2 deg noise and, like a damped
// flux-gate, lags the turn by 1.5 deg per deg/s, smoothed over 1 s.
struct ScaleErrorLog {
  HeadingInputs inputs;
  std::vector<double> truth_rad;
  double turn_end_s[2] = {0, 0};

  ScaleErrorLog() {
    std::mt19937 rng(11);
    std::normal_distribution<double> gyro_noise(0.0, 0.3), compass_noise(0.0, 2.0);
    auto rate_dps = [](double t) {
      auto ramp = [](double t, double t0, double t1) {
        return std::clamp((t - t0) / 2.0, 0.0, 1.0) * std::clamp((t1 - t) / 2.0, 0.0, 1.0);
      };
      return 10.0 * ramp(t, 10, 30) - 10.0 * ramp(t, 70, 90);
    };
    turn_end_s[0] = 30;
    turn_end_s[1] = 90;
    double heading_deg = 20.0, lag_deg = 0.0;
    for (int i = 0; i < 1500; ++i) {
      const double t = 0.1 * i;
      const double rate = rate_dps(t);
      if (i > 0) heading_deg += 0.5 * (rate + rate_dps(t - 0.1)) * 0.1;
      lag_deg += (1.0 - std::exp(-0.1 / 1.0)) * (1.5 * rate - lag_deg);
      inputs.t_s.push_back(t);
      truth_rad.push_back(heading_deg * kDeg);
      inputs.gyro_radps.push_back((0.96 * rate + 0.5 + gyro_noise(rng)) * kDeg);
      inputs.compass_rad.push_back(WrapPi((heading_deg - lag_deg + compass_noise(rng)) * kDeg));
      inputs.stationary.push_back(t < 10.0);
    }
  }
};

// Seconds after `t0` until the heading error stays below `limit_deg`.
double SettlingTimeS(const HeadingEstimate& e, const ScaleErrorLog& log, double t0, double t1, double limit_deg) {
  double settled = t0;
  for (std::size_t k = 0; k < log.truth_rad.size(); ++k) {
    const double t = log.inputs.t_s[k];
    if (t < t0 || t > t1) continue;
    if (std::abs(WrapPi(e.heading_rad[k] - log.truth_rad[k])) / kDeg >= limit_deg) settled = t;
  }
  return settled - t0;
}

TEST(FilterHeading, AfterATurnWithAGyroScaleErrorTheCompassCorrectsTheHeadingPromptly) {
  const ScaleErrorLog log;
  const HeadingEstimate kalman = FilterHeading(log.inputs, HeadingKalmanOptions{});
  HeadingKalmanOptions old_options;  // the filter before the scale state and the smoothed gate
  old_options.gyro_scale_sigma = 0;
  old_options.gate_smoothing_s = 0;
  const HeadingEstimate old = FilterHeading(log.inputs, old_options);
  // Measured when written: below 1 deg 3.2 and 2.8 s after the turns end (the old filter:
  // 18.5 and 17.3 s); the scale estimated as -0.04 to within 0.01.
  for (int turn = 0; turn < 2; ++turn) {
    const double t0 = log.turn_end_s[turn];
    const double settle = SettlingTimeS(kalman, log, t0, t0 + 40, 1.0);
    const double settle_old = SettlingTimeS(old, log, t0, t0 + 40, 1.0);
    EXPECT_LT(settle, 5.0) << "turn " << turn;
    EXPECT_GT(settle_old, 10.0) << "turn " << turn;
  }
  EXPECT_NEAR(kalman.gyro_scale_error, -0.04, 0.01);
  EXPECT_NEAR(kalman.gyro_bias_radps / kDeg, 0.5, 0.1);
}

TEST(FilterHeading, WithACompassAndNoStopTheBiasIsLearntFromTheCompass) {
  ScaleErrorLog log;
  std::fill(log.inputs.stationary.begin(), log.inputs.stationary.end(), 0);  // never still
  const HeadingEstimate kalman = FilterHeading(log.inputs, HeadingKalmanOptions{});
  HeadingKalmanOptions no_bias;
  no_bias.estimate_gyro_bias = false;
  const HeadingEstimate without = FilterHeading(log.inputs, no_bias);
  EXPECT_TRUE(kalman.gyro_bias_from_compass);
  // Measured when written: 0.50 deg/s (true 0.5); heading RMS 1.48 deg against 9.64 deg with
  // the bias held at 0 (the compass is hardly believed in the turns, where the bias adds up).
  EXPECT_NEAR(kalman.gyro_bias_radps / kDeg, 0.5, 0.1);
  EXPECT_FALSE(without.gyro_bias_from_compass);
  EXPECT_EQ(without.gyro_bias_radps, 0.0);
  const double rms = RmsErrorDeg(kalman.heading_rad, log.truth_rad);
  const double rms_without = RmsErrorDeg(without.heading_rad, log.truth_rad);
  EXPECT_LT(rms, 0.5 * rms_without) << rms << " vs " << rms_without;
}

TEST(FilterHeading, WithoutACompassOrAStopTheBiasIsHeldAtZero) {
  ScaleErrorLog log;
  std::fill(log.inputs.stationary.begin(), log.inputs.stationary.end(), 0);
  log.inputs.compass_rad.clear();
  const HeadingEstimate kalman = FilterHeading(log.inputs, HeadingKalmanOptions{});
  EXPECT_FALSE(kalman.gyro_bias_from_compass);
  EXPECT_EQ(kalman.gyro_bias_radps, 0.0);
  EXPECT_EQ(kalman.gyro_scale_error, 0.0);
}

TEST(FilterHeading, AtTheFirstStopTheStopsTakeOverTheBiasFromTheCompass) {
  // Still for the first 10 s: the stationary readings give the bias, the compass does not
  // move it afterwards (its estimate is the one of the stops' filter).
  const ScaleErrorLog log;
  HeadingKalman filter(HeadingKalmanOptions{}, log.inputs.compass_rad[0]);
  EXPECT_TRUE(filter.gyro_bias_from_compass());
  double bias_at_end_of_stop = 0;
  for (std::size_t k = 0; k < log.inputs.t_s.size(); ++k) {
    filter.Update(log.inputs.t_s[k], log.inputs.compass_rad[k], log.inputs.gyro_radps[k], log.inputs.stationary[k]);
    if (log.inputs.stationary[k]) bias_at_end_of_stop = filter.gyro_bias_radps();
  }
  EXPECT_FALSE(filter.gyro_bias_from_compass());
  EXPECT_FALSE(filter.gyro_bias_prior_from_compass());  // the log starts still: no compass before
  EXPECT_EQ(filter.gyro_bias_radps(), bias_at_end_of_stop);
  EXPECT_NEAR(filter.gyro_bias_radps() / kDeg, 0.5, 0.1);
}


// With the filter linear (no scale or bias state, no gating) the smoother's estimate is the
// whole log's least-squares one: the heading and rate at every sample minimising the prior's,
// the process noise's and every reading's squared errors, each over its variance, solved here
// at once as one linear system (a brute-force reference, none of the smoother's recursion).
TEST(SmoothHeading, IsTheWholeLogsLeastSquaresWhenTheFilterIsLinear) {
  HeadingKalmanOptions o;
  o.gyro_scale_sigma = 0;
  o.estimate_gyro_bias = false;
  o.gate_gain = 0;
  HeadingInputs in;
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 1.0);
  const int n = 80;
  for (int k = 0; k < n; ++k) {
    in.t_s.push_back(0.1 * k + (k % 3 == 0 ? 0.02 : 0.0));  // uneven steps
    const double truth = 0.3 * std::sin(0.05 * k);
    in.compass_rad.push_back(k % 7 == 3 ? std::nan("") : truth + 2.0 * kDeg * noise(rng));  // some missing
    in.gyro_radps.push_back(k % 11 == 5 ? std::nan("") : 0.015 * std::cos(0.05 * k) / 0.1 + 0.3 * kDeg * noise(rng));
  }
  const HeadingEstimate smoothed = SmoothHeading(in, o);
  // The least-squares problem: unknowns (heading, rate) per sample.
  const double rc = std::pow(o.compass_sigma_deg * kDeg, 2), rg = std::pow(o.gyro_sigma_dps * kDeg, 2);
  const double q = std::pow(o.rate_walk_dps2 * kDeg, 2);
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(2 * n, 2 * n);
  Eigen::VectorXd b = Eigen::VectorXd::Zero(2 * n);
  auto add = [&](const Eigen::VectorXd& row, double z, double var) {  // (row x - z)^2 / var
    a += row * row.transpose() / var;
    b += row * z / var;
  };
  Eigen::VectorXd row = Eigen::VectorXd::Zero(2 * n);
  row[0] = 1;
  add(row, in.compass_rad[0], rc);  // the initial state: the first compass reading
  row.setZero();
  row[1] = 1;
  add(row, 0.0, std::pow(5 * kDeg, 2));  // and rate 0, 5 deg/s
  for (int k = 1; k < n; ++k) {  // x_k = F x_k-1 + w, cov(w) = q [dt^3/3, dt^2/2; dt^2/2, dt]
    const double dt = in.t_s[k] - in.t_s[k - 1];
    Eigen::Matrix2d cov;
    cov << q * dt * dt * dt / 3, q * dt * dt / 2, q * dt * dt / 2, q * dt;
    const Eigen::Matrix2d info = cov.inverse();
    Eigen::MatrixXd d = Eigen::MatrixXd::Zero(2, 2 * n);  // x_k - F x_k-1
    d(0, 2 * k) = 1;
    d(1, 2 * k + 1) = 1;
    d(0, 2 * (k - 1)) = -1;
    d(0, 2 * (k - 1) + 1) = -dt;
    d(1, 2 * (k - 1) + 1) = -1;
    a += d.transpose() * info * d;
  }
  for (int k = 0; k < n; ++k) {
    if (!std::isnan(in.gyro_radps[k])) {
      row.setZero();
      row[2 * k + 1] = 1;
      add(row, in.gyro_radps[k], rg);
    }
    if (!std::isnan(in.compass_rad[k])) {
      row.setZero();
      row[2 * k] = 1;
      add(row, in.compass_rad[k], rc);
    }
  }
  const Eigen::VectorXd x = a.ldlt().solve(b);
  for (int k = 0; k < n; ++k) {
    ASSERT_NEAR(smoothed.heading_rad[k], x[2 * k], 1e-9) << k;
    ASSERT_NEAR(smoothed.rate_radps[k], x[2 * k + 1], 1e-9) << k;
  }
}

// A turn with a 4 % gyro scale error and a compass lagging it: the filter has the gyro alone
// through the turn and is corrected after it; the smoother carries the correction back.
TEST(SmoothHeading, CarriesTheCompassCorrectionAfterATurnBackOverIt) {
  const ScaleErrorLog log;
  const HeadingEstimate filtered = FilterHeading(log.inputs, HeadingKalmanOptions{});
  const HeadingEstimate smoothed = SmoothHeading(log.inputs, HeadingKalmanOptions{});
  auto rms_in = [&](const HeadingEstimate& e, double t0, double t1) {
    double sum = 0;
    int count = 0;
    for (std::size_t k = 0; k < log.truth_rad.size(); ++k) {
      if (log.inputs.t_s[k] < t0 || log.inputs.t_s[k] > t1) continue;
      sum += std::pow(WrapPi(e.heading_rad[k] - log.truth_rad[k]) / kDeg, 2);
      ++count;
    }
    return std::sqrt(sum / count);
  };
  // Measured when written: through the first turn 4.50 deg RMS filtered (the scale not yet
  // known), 0.22 smoothed; through the second (the scale learnt) 0.29 and 0.35; over the log
  // 1.86 and 0.20.
  const double f1 = rms_in(filtered, 10, 35), s1 = rms_in(smoothed, 10, 35);
  EXPECT_LT(s1, 0.2 * f1) << s1 << " vs " << f1;
  EXPECT_LT(rms_in(smoothed, 70, 95), 0.5);
  const double f = RmsErrorDeg(filtered.heading_rad, log.truth_rad), s = RmsErrorDeg(smoothed.heading_rad, log.truth_rad);
  EXPECT_LT(s, 0.2 * f) << s << " vs " << f;
  // The last sample has nothing after it: the filter's.
  EXPECT_EQ(smoothed.heading_rad.back(), filtered.heading_rad.back());
  EXPECT_EQ(smoothed.gyro_scale_error, filtered.gyro_scale_error);
}

}  // namespace
}  // namespace lunarnav::telemetry
