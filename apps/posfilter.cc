// posfilter: raw 10- or 7-bit rover telemetry -> screened, filtered streams -> 3-D trajectory.
// docs/posfilter.md describes every option and output.
#include <filesystem>
#include <optional>
#include <string>

#include "io/atomic_file.h"
#include "io/json_io.h"
#include "positioning/posfilter.h"
#include "positioning/trajectory_io.h"
#include "util/cli.h"
#include "util/errors.h"
#include "util/log.h"
#include "util/progress.h"
#include "util/resources.h"
#include "util/run_main.h"
#include "util/timer.h"
#include "util/summary.h"

namespace fs = std::filesystem;
using namespace lunarnav;

int main(int argc, char** argv) {
  CLI::App app{
      "Position estimation of Krotkov & Hebert (1995) sec. 4: screens raw encoder, compass,\n"
      "inclinometer and gyro counts, filters them, and dead-reckons a 3-D trajectory.\n"
      "Writes OUT_DIR/trajectory.csv, trajectory.tum, baseline.csv (plain dead reckoning of the same\n"
      "counts, for comparison) and summary.json.\n"
      "Exit codes: 0 ok, 1 internal error, 2 usage, 3 bad input."};
  positioning::PosfilterOptions opt;  // defaults live in the library
  fs::path telemetry_csv, sensors, output_dir, screening_log, streams;
  std::string filter = "butterworth", heading = "kalman";
  int bits = 0;
  bool zero_phase = false, quiet = false;
  app.add_option("TELEMETRY", telemetry_csv, "telemetry CSV (header; time in s, raw counts)")->required();
  app.add_option("--sensors", sensors, "sensor model JSON (docs/formats.md)")->required();
  app.add_option("-o,--output", output_dir, "output directory (created)")->required();
  app.add_option("--bits", bits, "digitisation of every channel, e.g. 7 for old telemetry (default: the sensor file's)")
      ->check(CLI::Range(1, 16));
  app.add_option("--filter", filter, "low-pass filter type")->check(CLI::IsMember({"butterworth", "bessel"}))
      ->capture_default_str();
  app.add_option("--order", opt.filter_order, "low-pass filter order")->capture_default_str();
  app.add_option("--cutoff", opt.cutoff_hz, "the compass's low-pass cut-off (--heading lowpass), Hz")
      ->capture_default_str();
  app.add_option("--tilt-cutoff", opt.tilt_cutoff_hz,
                 "the pitch and roll inclinometers' low-pass cut-off, Hz (default: 1 with --attitude smoothed, 1.5 "
                 "filtered)")
      ->check(CLI::PositiveNumber);
  std::string attitude = "smoothed";
  app.add_option("--attitude", attitude,
                 "the pitch and roll reported: smoothed (forward and backward over 4 cut-off periods ahead, the "
                 "vehicle's acceleration taken out) or filtered (the tilt low-pass as read)")
      ->check(CLI::IsMember({"smoothed", "filtered"}))
      ->capture_default_str();
  app.add_flag("--zero-phase", zero_phase, "filter forward and backward (no delay; for logs processed afterwards)");
  app.add_option("--heading", heading, "heading filter")->check(CLI::IsMember({"kalman", "lowpass"}))
      ->capture_default_str();
  app.add_option("--heading-lag", opt.heading_lag_s,
                 "the Kalman heading smoothed over this lag, s (the compass's correction after a turn carried back "
                 "over it); 0: the filter alone, causal, as on the vehicle")
      ->check(CLI::Range(0.0, 3600.0))
      ->capture_default_str();
  app.add_option("--screening-log", screening_log, "CSV listing every rejected or repaired sample");
  app.add_option("--streams", streams, "CSV of the raw and filtered heading streams (for plots)");
  util::AddCommonFlags(&app, &quiet);
  if (const auto exit_code = util::ParseCommandLine(&app, argc, argv, quiet)) return *exit_code;

  return util::RunMain([&] {
    util::Timer timer;
    opt.filter = telemetry::LowPassTypeFromString(filter);
    opt.mode = zero_phase ? positioning::FilterMode::kZeroPhase : positioning::FilterMode::kCausal;
    opt.smooth_attitude = attitude == "smoothed";
    opt.heading = heading == "kalman" ? positioning::HeadingMethod::kKalman : positioning::HeadingMethod::kLowPass;
    opt.Validate();
    io::CreateOutputDirectory(output_dir);  // before the work, not after it
    telemetry::SensorModel model = telemetry::ReadSensorModel(sensors);
    if (bits > 0) model.OverrideBits(bits);
    telemetry::TelemetryReader reader(telemetry_csv, model);
    for (telemetry::Channel c : reader.missing_columns()) {
      LN_LOG(Warning) << telemetry_csv.string() << ": no column '" << model[c].column << "' for channel "
                      << telemetry::ToString(c) << "; going on without it";
    }
    // The log is read, screened, filtered and written a block at a time; each row goes to the
    // files as it is computed.
    positioning::TrajectoryWriter writer(output_dir / "trajectory.csv", output_dir / "trajectory.tum");
    positioning::TrajectoryWriter baseline_writer(output_dir / "baseline.csv", {});
    double baseline_written_t = -1e300;
    std::optional<positioning::HeadingStreamsWriter> streams_writer;
    if (!streams.empty()) streams_writer.emplace(streams, model);
    const positioning::PoseSink sink = [&](const positioning::PoseOutput& row) {
      writer.Add(row.pose, row.enu_from_body);
      if (streams_writer) streams_writer->Add(row);
      if (row.baseline != nullptr) {
        baseline_writer.Add(*row.baseline);
        baseline_written_t = row.baseline->t_s;
      }
    };
    constexpr std::size_t kSteps = 100;
    util::ProgressBar progress(kSteps, "posfilter (% of the log)", !quiet);
    std::size_t steps = 0;
    const positioning::ProgressFn on_block = [&](double fraction) {
      for (; steps < static_cast<std::size_t>(fraction * kSteps); ++steps) progress.Increment();
    };
    const positioning::PosfilterResult result = positioning::RunPosfilter(reader, model, opt, sink, on_block);
    writer.Commit();
    if (result.baseline_last_pose.t_s > baseline_written_t) baseline_writer.Add(result.baseline_last_pose);
    baseline_writer.Commit();
    if (streams_writer) streams_writer->Commit();
    for (const std::string& note : result.notes) LN_LOG(Info) << "posfilter: " << note;
    for (const std::string& warning : result.warnings) LN_LOG(Warning) << "posfilter: " << warning;

    if (!screening_log.empty()) telemetry::WriteScreeningLog(screening_log, result.screened);
    nlohmann::json summary = result.SummaryJson();
    summary.update(util::SummaryHead("posfilter", util::CommandLineJson(argc, argv)));
    summary["inputs"] = {{"telemetry", telemetry_csv.string()}, {"sensors", sensors.string()}};
    summary["sensor_model"] = model.ToJson();
    summary["options"] = opt.ToJson();
    summary["rows_read"] = result.rows_read;
    summary["seconds"] = timer.ElapsedSeconds();
    summary["peak_memory_mib"] = util::PeakResidentMemoryMiB();
    io::WriteJsonAtomic(output_dir / "summary.json", summary);
    LN_LOG(Info) << "posfilter: " << result.rows_read << " rows, " << result.screened.events.size()
                 << " screening events, " << result.motion.distance_m << " m travelled; outputs in "
                 << output_dir.string();
    return kExitOk;
  });
}
