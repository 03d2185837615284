// posfilter: raw telemetry -> screened, filtered sensor streams -> 3-D trajectory
// (Krotkov & Hebert sec. 4).
#pragma once

#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "positioning/attitude.h"
#include "positioning/dead_reckoning.h"
#include "telemetry/heading_kalman.h"
#include "telemetry/lowpass.h"
#include "telemetry/screening.h"
#include "telemetry/sensor_model.h"
#include "telemetry/telemetry_csv.h"

namespace lunarnav::positioning {

enum class FilterMode {
  kCausal,    ///< Forward only, as the rover ran its filters (output lags by the filter delay).
  kZeroPhase  ///< Forward-backward, for logs processed afterwards (no lag).
};
enum class HeadingMethod {
  kKalman,  ///< The gyro-gated Kalman filter of sec. 4.1.
  kLowPass  ///< The compass low-passed like the other channels (for comparison).
};
std::string ToString(FilterMode mode);
std::string ToString(HeadingMethod method);

/// The reported attitude's smoother looks this many periods of the tilt's cut-off ahead of
/// the row it returns (its backward pass starts there; the default 2nd-order Butterworth's
/// response has decayed to 2e-8 by then, exp(-0.707 2 pi 4)).
inline constexpr double kSmootherLagCutoffs = 4.0;

struct PosfilterOptions {
  telemetry::ScreeningOptions screening;
  telemetry::LowPassType filter = telemetry::LowPassType::kButterworth;
  int filter_order = 2;
  double cutoff_hz = 0.25;  ///< The paper's compass noise cut-off (the heading's low-pass).
  /// The pitch and roll inclinometers' cut-off; 0: 1 Hz with smooth_attitude, 1.5 Hz without.
  /// The paper gives its cut-off for the compass (sec. 4.1); at 0.25 Hz the inclinometers lag
  /// the body's pitching over rocks by 0.9 s (pitch errors of 0.39-0.74 deg RMS at the frames
  /// of bench-field-log's paper drives, against 0.19-0.46 at 1.5 Hz: docs/posfilter.md). At
  /// most 0.4 of the sample rate (slower logs).
  double tilt_cutoff_hz = 0;
  double TiltCutoffHz() const { return tilt_cutoff_hz > 0 ? tilt_cutoff_hz : smooth_attitude ? 1.0 : 1.5; }
  /// The attitude reported (pitch and roll; the path's tilts keep the paper's causal filter):
  /// true, the tilts smoothed forward and backward over a fixed lag (SmoothedSeries: the
  /// reported attitude trails the log by kSmootherLagCutoffs / TiltCutoffHz() seconds) with
  /// the vehicle's own acceleration, which an inclinometer reads as tilt (the pendulum), taken
  /// out: the wheels' acceleration from pitch, the turn's centripetal one from roll. false:
  /// the tilts through the causal low-pass (or zero phase with `mode`), as read.
  bool smooth_attitude = true;
  /// The heading (Kalman filter) smoothed over this lag, seconds (SmoothedHeading: the
  /// filter forward, the Rauch-Tung-Striebel smoother backward from this far ahead, so the
  /// compass's correction after a turn reaches back over the turn; the trajectory trails the
  /// log by the lag); 0: the filter alone, causal, as on the vehicle. >= 0.
  double heading_lag_s = 60.0;
  FilterMode mode = FilterMode::kCausal;
  HeadingMethod heading = HeadingMethod::kKalman;
  telemetry::HeadingKalmanOptions kalman;
  DeadReckoningOptions dead_reckoning;
  double stationary_min_s = 1.0;  ///< Wheels still this long: stationary (gyro bias). > 0.
  /// The plain dead-reckoning baseline (PlainDeadReckoner) is output every this many seconds
  /// (and at the last row). > 0.
  double baseline_interval_s = 1.0;
  /// The filtered and the baseline trajectory are expected to part at the end by at most
  /// baseline_drift_fraction of the path length D (odometry drifts by a few % of the
  /// distance), plus the baseline's heading drift, a debiased gyro's drift rate times the
  /// duration T (at most 90 deg), over half the path: D (fraction + min(rate T, pi/2) / 2).
  /// The rate allows a bias measured over a few seconds' stop with a noisy gyro, and its walk.
  /// Beyond it posfilter warns. > 0 and >= 0.
  double baseline_drift_fraction = 0.05;
  double baseline_heading_drift_dps = 0.1;
  /// Rows read and screened at a time (memory and speed only: the results do not depend on
  /// it). >= 1.
  std::size_t block_rows = 1024;
  void Validate() const;
  nlohmann::json ToJson() const;
};

struct PosfilterResult {
  DeadReckoningResult motion;
  std::size_t rows_read = 0;                 ///< Rows in the log (kept or not).
  telemetry::ScreenedLog screened;           ///< Counts and events (no arrays).
  telemetry::LowPassDesign design;           ///< Low-pass of the heading (--heading lowpass).
  telemetry::LowPassDesign tilt_design;      ///< Low-pass of pitch and roll.
  telemetry::HeadingEstimate heading;        ///< When the Kalman filter ran.
  bool kalman_used = false;
  double kalman_rate_walk_dps2 = 0;          ///< The heading rate's process noise used.
  double sample_rate_hz = 0;
  /// With smooth_attitude: how far the smoother looks ahead (s), and the largest correction
  /// of the vehicle's acceleration applied to the pitch and to the roll (radians).
  double attitude_lag_s = 0;
  double heading_lag_s = 0;  ///< The heading smoother's lag used (0: the filter alone).
  /// The largest change the heading smoother made to the filter's heading, radians.
  double heading_correction_max_rad = 0;
  double pendulum_pitch_max_rad = 0, pendulum_roll_max_rad = 0;
  std::vector<std::string> channels_used;
  std::vector<std::string> notes;            ///< Substitutions ("no compass: ...").
  /// What became of each state the heading filter could estimate: "estimated" or "held at
  /// prior" with the reason (gyro_scale, gyro_bias).
  nlohmann::json states = nlohmann::json::object();
  /// The plain baseline: its trajectory (when the result holds the trajectory), last pose,
  /// path length and gyro bias; the end difference from the filtered trajectory (metres,
  /// horizontal) and the difference expected (baseline_drift_fraction x path length).
  std::vector<TrajectorySample> baseline_trajectory;
  TrajectorySample baseline_last_pose;
  double baseline_distance_m = 0, baseline_gyro_bias_radps = 0;
  bool baseline_bias_known = false;
  double baseline_end_difference_m = 0, baseline_expected_drift_m = 0;
  /// Warnings for the user (a screening rule rejecting much of a channel, the baseline
  /// parting from the filtered trajectory); also in summary.json.
  std::vector<std::string> warnings;
  nlohmann::json SummaryJson() const;
};

/// One kept row's results, as a sink receives them.
struct PoseOutput {
  TrajectorySample pose;
  Eigen::Quaterniond enu_from_body;  ///< EnuFromBody of the pose's heading, pitch and roll.
  double heading_rate_radps = 0;     ///< The Kalman filter's; NaN when it did not run.
  double compass_count = 0, gyro_count = 0;  ///< The row's raw counts; NaN for no sample.
  /// The baseline's pose when one is due (every baseline_interval_s), else null.
  const TrajectorySample* baseline = nullptr;
};
/// Receives the rows' results one by one as they are computed.
using PoseSink = std::function<void(const PoseOutput&)>;
/// Told the fraction of the log read, after every block.
using ProgressFn = std::function<void(double fraction)>;

/// Runs a log through posfilter as it is read, a block of rows at a time: screening, then
/// row by row the gaps filled, the low-pass filters, the heading filter and the dead
/// reckoning. Memory is bounded by the look-ahead the rules need (docs/posfilter.md), not by
/// the log's length, except with zero-phase filtering, which holds the whole log.
/// Without a sink the result holds the trajectory (and the Kalman heading streams); with
/// one, each row goes to the sink as it is computed and the result holds only the last pose.
/// Channels may be missing (no compass: heading from the gyro; no inclinometers: flat ground)
/// or sampled at lower rates (gaps are interpolated in time before filtering); at least one
/// encoder is needed.
/// @throws InputError for a bad row (file and line), a log with fewer than two usable rows
///         or no encoder.
PosfilterResult RunPosfilter(telemetry::TelemetryReader& reader, const telemetry::SensorModel& model,
                             const PosfilterOptions& options, const PoseSink& sink = {},
                             const ProgressFn& progress = {});
/// The same for a log in memory.
PosfilterResult RunPosfilter(const telemetry::TelemetryLog& log, const telemetry::SensorModel& model,
                             const PosfilterOptions& options, const PoseSink& sink = {});

/// Writes the heading streams, raw and filtered, per kept row (the data of the paper's
/// Figure 6) as a sink receives them: t_s, compass_raw_deg, heading_deg, gyro_raw_dps,
/// heading_rate_dps; empty cells where a channel has no sample. Headings in [0, 360).
/// Atomic: nothing appears at `path` before Commit().
class HeadingStreamsWriter {
 public:
  HeadingStreamsWriter(const std::filesystem::path& path, const telemetry::SensorModel& model);
  ~HeadingStreamsWriter();
  void Add(const PoseOutput& row);
  void Commit();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace lunarnav::positioning
