// The heading filter of Krotkov & Hebert sec. 4.1: a Kalman filter on heading and heading
// rate that "does not believe the compass when Ratler turns".
#pragma once

#include <array>
#include <span>

#include <vector>

#include <nlohmann/json.hpp>

namespace lunarnav::telemetry {

/// Parameters of the heading filter. Angles in degrees for readability; the filter works in
/// radians.
struct HeadingKalmanOptions {
  double compass_sigma_deg = 3.0;       ///< Compass noise when the rover is steady. > 0.
  double gyro_sigma_dps = 0.5;          ///< Gyro noise. > 0.
  double rate_walk_dps2 = 5.0;          ///< Process noise of the heading rate, deg/s per sqrt(s). > 0.
  /// Compass gating: its variance is multiplied by
  /// 1 + gate_gain * ((w / turn_gate_dps)^2 + (a / accel_gate_dps2)^2), w the gyro's turn
  /// rate and a its change per second: turning or accelerating, the compass is hardly
  /// believed (the paper's transients), steady, fully.
  double turn_gate_dps = 2.0;           ///< > 0.
  double accel_gate_dps2 = 4.0;         ///< > 0.
  double gate_gain = 100.0;             ///< >= 0; 0 = no gating.
  /// w and a are the gyro's rate and its change low-passed with this time constant (first
  /// order; 0 = the raw rate and its sample-to-sample change): the compass's transients,
  /// smoothed by its damping, die out over about this time after a turn, and the gyro's noise
  /// (which, differentiated, reads several deg/s^2 at rest) does not gate a steady rover. >= 0.
  double gate_smoothing_s = 0.5;
  /// Gyro scale factor: the gyro reads (1 + s) times the true rate; s is a third state with
  /// this prior standard deviation (a rate gyro's scale error is typically 1-3 %), so a turn
  /// makes the heading as uncertain as the gyro's scale makes it, and the compass, trusted
  /// again after the turn, corrects both the heading and s. 0 = no scale state. >= 0.
  double gyro_scale_sigma = 0.02;
  double gyro_scale_walk_per_sqrt_s = 1e-4;  ///< Random walk of s (temperature drift). >= 0.
  /// Gyro bias: estimated from the gyro's readings while the wheels stand still
  /// (stationary), by a scalar Kalman filter: each reading (noise gyro_sigma_dps) updates the
  /// estimate, whose variance grows by gyro_bias_walk_dps_per_sqrt_s^2 per second between
  /// them, so that a stop's readings count more than older stops' as the bias wanders (a MEMS
  /// gyro's does, with temperature). With no walk it is the mean of all stationary readings.
  ///
  ///
  /// With a compass, until the first stop, the bias is a fourth state of the heading filter,
  /// observed through the compass: the heading the gyro integrates drifts from the compass's
  /// by the bias times the time, so a log without any stop still has its bias estimated.
  /// At the first stop that estimate becomes the stationary filter's prior and the stops take
  /// over (they show the bias directly; the compass shows it through its transients). Without
  /// a compass nothing but a stop shows the bias, and it is held at 0 until the first one.
  bool estimate_gyro_bias = true;
  double gyro_bias_walk_dps_per_sqrt_s = 0.005;  ///< >= 0.
  /// Prior standard deviation of the bias state (with a compass): a MEMS gyro's turn-on bias
  /// is a fraction of a deg/s to a few deg/s. > 0.
  double gyro_bias_sigma_dps = 1.0;
  /// While stationary the heading rate is known to be 0 (a rover does not turn with its
  /// wheels still): the gyro's reading is replaced by that, so the heading does not wander
  /// on the gyro's noise during stops.
  bool zero_rate_when_stationary = true;
  double initial_heading_deg = 0.0;     ///< Used only when there is no compass.
  void Validate() const;
  nlohmann::json ToJson() const;
};

/// Per-sample inputs; NaN marks a missing or rejected sample.
struct HeadingInputs {
  std::vector<double> t_s;
  std::vector<double> compass_rad;      ///< Heading, radians (any branch: wrapped or not).
  std::vector<double> gyro_radps;       ///< Turn rate, rad/s, same sign as heading increases.
  std::vector<char> stationary;         ///< 1 where the wheels stand still (may be empty).
};

struct HeadingEstimate {
  std::vector<double> heading_rad;      ///< Continuous (unwrapped) heading.
  std::vector<double> rate_radps;
  std::vector<double> heading_sigma_rad;
  double gyro_bias_radps = 0;           ///< Final bias estimate.
  bool gyro_bias_from_compass = false;  ///< The bias was a state observed through the compass.
  double gyro_scale_error = 0;          ///< Final estimate of s (0 without the scale state).
  double gyro_scale_sigma = 0;          ///< Its standard deviation.
  int compass_updates = 0, gyro_updates = 0;
};

/// Runs the filter forward in time (causal, as on the vehicle). The compass innovation is
/// wrapped to (-pi, pi], so a heading passing through +-180 deg is no event.
HeadingEstimate FilterHeading(const HeadingInputs& inputs, const HeadingKalmanOptions& options);

/// One step of the filter as a smoother needs it: the state and covariance predicted to the
/// sample (before its readings) and after them, and the time step. States: heading, heading
/// rate, gyro scale error, gyro bias (radians, seconds); a state the filter does not hold
/// then (no scale state, the bias once the stops show it) has no variance.
struct HeadingKalmanStep {
  double dt = 0;
  std::array<double, 4> x_predicted{}, x{};
  std::array<std::array<double, 4>, 4> p_predicted{}, p{};
};

/// The Rauch-Tung-Striebel smoother over the steps of one forward pass (in time order): the
/// heading and rate at each step given every reading of the steps, before and after it. After
/// a turn the compass, trusted again, corrects the heading and (through their covariance) the
/// gyro's scale; the smoother carries that correction back over the turn, where the forward
/// filter had only the gyro. A state without variance at a step passes nothing back through
/// it. The smoothing starts from the last step's filtered state; `heading_rad` and
/// `rate_radps` get one value per step.
void SmoothHeadingSteps(std::span<const HeadingKalmanStep> steps, std::span<double> heading_rad,
                        std::span<double> rate_radps);

/// FilterHeading, then the smoother over the whole log (for logs processed afterwards).
HeadingEstimate SmoothHeading(const HeadingInputs& inputs, const HeadingKalmanOptions& options);

/// The filter sample by sample, for pipelines that stream a log instead of holding it whole:
/// FilterHeading is a loop over Update, and gives the same numbers.
class HeadingKalman {
 public:
  /// `first_compass_rad`: the log's first compass reading, the initial heading (NaN when the
  /// log has no compass reading: the heading starts at options.initial_heading_deg, exactly
  /// known, and is relative to the start). Validates the options.
  HeadingKalman(const HeadingKalmanOptions& options, double first_compass_rad);

  struct Output {
    double heading_rad, rate_radps, heading_sigma_rad;
  };
  /// One sample, in time order: predicts to t_s, then takes the gyro and the compass
  /// readings (NaN: none). `stationary`: the wheels stand still (the gyro's bias is learnt).
  /// With `step`, also what a smoother needs of it.
  Output Update(double t_s, double compass_rad, double gyro_radps, bool stationary,
                HeadingKalmanStep* step = nullptr);

  double gyro_bias_radps() const { return joint_bias_ ? xb_ : bias_; }
  /// Standard deviation of the bias estimate (0 before anything has shown it).
  double gyro_bias_sigma_radps() const;
  /// The bias is (still) a state of the filter observed through the compass: a log with a
  /// compass and no stop so far.
  bool gyro_bias_from_compass() const { return joint_bias_; }
  /// The stops' bias estimate started from what the compass had shown before the first stop.
  bool gyro_bias_prior_from_compass() const { return bias_prior_from_compass_; }
  double gyro_scale_error() const { return xs_; }
  double gyro_scale_sigma() const;
  int compass_updates() const { return compass_updates_; }
  long stationary_samples() const { return bias_count_; }
  int stationary_periods() const { return bias_periods_; }
  int gyro_updates() const { return gyro_updates_; }

 private:
  HeadingKalmanOptions o_;
  // One scalar measurement z = H x + noise (variance r) of the four states, `innovation`
  // z - H x: the general Kalman update.
  void Measure(const double (&h)[4], double innovation, double r);

  double r_compass_, r_gyro_, q_rate_, q_scale_, q_bias_, turn_gate_, accel_gate_;
  bool estimate_scale_;
  bool joint_bias_ = false;  // the bias is state 3 (with a compass, until the first stop)
  bool bias_prior_from_compass_ = false;  // the stops' bias filter started from state 3
  // State: heading, true heading rate, gyro scale error s (the gyro reads (1 + s) x rate),
  // gyro bias b (with a compass), and their covariance P. Without the scale state s stays 0
  // with no variance; without a compass, and from the first stop on, b's row and column are 0
  // and the bias comes from the stationary readings' own scalar filter below.
  double xh_, xr_ = 0, xs_ = 0, xb_ = 0;
  double p_[4][4] = {};
  double last_t_ = 0;
  bool started_ = false;
  long bias_count_ = 0;
  double bias_ = 0;  // without a compass: the bias used, 0 before the first stationary sample
  double bias_var_ = 0, bias_t_ = 0;  // its variance (rad/s)^2, and the time of its last update
  int bias_periods_ = 0;
  bool was_stationary_ = false;
  double gate_rate_ = 0, gate_accel_ = 0, gate_time_;
  // The gate smoothing's alpha for the last few intervals (time stamps in tenths of a second
  // give a handful of distinct binary differences): alpha_[i] belongs to alpha_dt_[i].
  static constexpr int kAlphaCache = 4;
  std::array<double, kAlphaCache> alpha_dt_{}, alpha_{};
  int alpha_next_ = 0;  // the entry replaced next
  int compass_updates_ = 0, gyro_updates_ = 0;
};

/// Wraps an angle to (-pi, pi].
double WrapPi(double angle_rad);

}  // namespace lunarnav::telemetry
