// posfilter: raw telemetry -> screened, filtered sensor streams -> 3-D trajectory
// (Krotkov & Hebert sec. 4).
#pragma once

#include <filesystem>
#include <functional>
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

struct PosfilterOptions {
  telemetry::ScreeningOptions screening;
  telemetry::LowPassType filter = telemetry::LowPassType::kButterworth;
  int filter_order = 2;
  double cutoff_hz = 0.25;  ///< The paper's compass noise cut-off.
  FilterMode mode = FilterMode::kCausal;
  HeadingMethod heading = HeadingMethod::kKalman;
  telemetry::HeadingKalmanOptions kalman;
  DeadReckoningOptions dead_reckoning;
  double stationary_min_s = 1.0;  ///< Wheels still this long: stationary (gyro bias). > 0.
  void Validate() const;
  nlohmann::json ToJson() const;
};

struct PosfilterResult {
  DeadReckoningResult motion;
  telemetry::ScreenedLog screened;
  telemetry::LowPassDesign design;           ///< Low-pass used for pitch, roll (and heading).
  telemetry::HeadingEstimate heading;        ///< When the Kalman filter ran.
  bool kalman_used = false;
  double sample_rate_hz = 0;
  std::vector<std::string> channels_used;
  std::vector<std::string> notes;            ///< Substitutions ("no compass: ...").
  nlohmann::json SummaryJson() const;
};

/// Receives the poses one by one as they are computed, each with its attitude (EnuFromBody
/// of its heading, pitch and roll).
using PoseSink = std::function<void(const TrajectorySample&, const Eigen::Quaterniond& enu_from_body)>;

/// Screens the log, then runs row by row: fills the gaps, low-passes, runs the heading filter
/// and dead-reckons. Without a sink the result holds the trajectory (and the Kalman heading
/// streams); with one, each pose goes to the sink as it is computed and the result holds only
/// the last (memory stays that of the screened log, however long the trajectory).
/// Channels may be missing (no compass: heading from the gyro; no inclinometers: flat ground)
/// or sampled at lower rates (gaps are interpolated in time before filtering); at least one
/// encoder is needed.
/// @throws InputError when the log has fewer than two usable rows or no encoder.
PosfilterResult RunPosfilter(const telemetry::TelemetryLog& log, const telemetry::SensorModel& model,
                             const PosfilterOptions& options, const PoseSink& sink = {});

/// Writes the heading streams, raw and filtered, per kept row (the data of the paper's
/// Figure 6): t_s, compass_raw_deg, heading_deg, gyro_raw_dps, heading_rate_dps; empty cells
/// where a channel has no sample. Headings in [0, 360).
void WriteHeadingStreamsCsv(const std::filesystem::path& path, const telemetry::TelemetryLog& log,
                            const telemetry::SensorModel& model, const PosfilterResult& result);

}  // namespace lunarnav::positioning
