// posfilter end to end on one core: parse, screen, filter, integrate, write (the trajectory
// as CSV and TUM, as the tool does).
//
//   build/bin/posfilter_benchmark
//   build/bin/posfilter_benchmark --write-log FILE   (the log as a file, for scripts/bench-posfilter)
//
// The log: 2 million rows (55 hours at 10 Hz) of a rover driving and turning, with sensor
// noise, in the format of testdata/telemetry/ratler_sensors.json.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <string_view>

#include "positioning/posfilter.h"
#include "positioning/trajectory_io.h"
#include "telemetry/telemetry_csv.h"

namespace {
using namespace lunarnav;

const telemetry::SensorModel& Model() {
  static const telemetry::SensorModel model = telemetry::SensorModelFromJson(nlohmann::json::parse(R"({
    "format": "lunarnav.sensors/1", "bits": 10,
    "channels": {
      "enc_fl": {"counts_per_revolution": 256, "wheel_radius_m": 0.25},
      "enc_fr": {"counts_per_revolution": 256, "wheel_radius_m": 0.25},
      "enc_rl": {"counts_per_revolution": 256, "wheel_radius_m": 0.25},
      "enc_rr": {"counts_per_revolution": 256, "wheel_radius_m": 0.25},
      "compass": {"scale": 0.3515625, "units": "deg"},
      "pitch_left": {"scale": 0.087890625, "offset": -45.0, "units": "deg"},
      "pitch_right": {"scale": 0.087890625, "offset": -45.0, "units": "deg"},
      "roll": {"scale": 0.087890625, "offset": -45.0, "units": "deg"},
      "gyro_z": {"scale": 0.1171875, "offset": -60.0, "units": "deg/s"}}})"),
                                                                             "benchmark");
  return model;
}

const std::string& Log() {
  static const std::string text = [] {
    std::mt19937 rng(3);
    std::normal_distribution<double> noise(0.0, 1.0);
    std::string s = "t,enc_fl,enc_fr,enc_rl,enc_rr,compass,pitch_left,pitch_right,roll,gyro_z\n";
    s.reserve(2'000'000 * 50);
    double heading = 10, distance = 0;
    char row[160];
    for (int i = 0; i < 2'000'000; ++i) {
      const double t = 0.1 * i;
      const double rate = 8.0 * std::sin(t / 40.0);  // deg/s
      heading += rate * 0.1;
      distance += 0.5 * 0.1;
      const long enc = std::lround(distance / (2 * M_PI * 0.25 / 256)) % 1024;
      const long compass = (std::lround(std::fmod(heading + 3600000.0, 360.0) / 0.3515625 + noise(rng))) % 1024;
      const long pitch = std::lround(45.0 / 0.087890625 + 20 * std::sin(t / 7.0) + noise(rng));
      const long gyro = std::lround((rate + 60.0) / 0.1171875 + noise(rng));
      const int n = std::snprintf(row, sizeof(row), "%.1f,%ld,%ld,%ld,%ld,%ld,%ld,%ld,%ld,%ld\n", t, enc, enc,
                                  enc, enc, compass, pitch, pitch, 512L, gyro);
      s.append(row, static_cast<std::size_t>(n));
    }
    return s;
  }();
  return text;
}

void BM_PosfilterEndToEnd(benchmark::State& state) {
  const std::string& text = Log();
  const std::filesystem::path out = std::filesystem::temp_directory_path() / "lunarnav_posfilter_bench.csv";
  const std::filesystem::path tum = std::filesystem::temp_directory_path() / "lunarnav_posfilter_bench.tum";
  for (auto _ : state) {
    // Read, screened and written a block at a time, as the tool runs.
    telemetry::TelemetryReader reader(text, "benchmark.csv", Model());
    positioning::TrajectoryWriter writer(out, tum);
    const positioning::PosfilterResult r = positioning::RunPosfilter(
        reader, Model(), positioning::PosfilterOptions{},
        [&writer](const positioning::PoseOutput& row) { writer.Add(row.pose, row.enu_from_body); });
    writer.Commit();
    benchmark::DoNotOptimize(r.motion.distance_m);
  }
  std::filesystem::remove(out);
  std::filesystem::remove(tum);
  state.counters["rows_per_s"] =
      benchmark::Counter(2e6 * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_PosfilterEndToEnd)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);

// The parts, for where the time goes, each as the tool runs it (a block of rows at a time):
// reading; reading and screening; reading, screening, filtering and dead reckoning (the rows
// dropped); and writing alone below. Differences between them are the stages' costs.
void BM_ReadOnly(benchmark::State& state) {
  const std::string& text = Log();  // made before the clock runs
  for (auto _ : state) {
    telemetry::TelemetryReader reader(text, "benchmark.csv", Model());
    telemetry::TelemetryLog block;
    std::size_t rows = 0;
    while (true) {
      block.ClearRows();
      const std::size_t n = reader.Read(&block, 1024);
      if (n == 0) break;
      rows += n;
    }
    benchmark::DoNotOptimize(rows);
  }
  state.counters["rows_per_s"] =
      benchmark::Counter(2e6 * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_ReadOnly)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);

void BM_ReadAndScreen(benchmark::State& state) {
  const std::string& text = Log();
  for (auto _ : state) {
    telemetry::TelemetryReader reader(text, "benchmark.csv", Model());
    std::array<bool, telemetry::kNumChannels> present{};
    for (telemetry::Channel c : telemetry::kAllChannels) present[static_cast<int>(c)] = reader.Has(c);
    telemetry::ScreeningStream stream(Model(), telemetry::ScreeningOptions{}, present);
    const telemetry::ScreeningStream::Source source = [&reader](telemetry::TelemetryLog* out, std::size_t n) {
      return reader.Read(out, n);
    };
    while (stream.Read(source, 1024) > 0) stream.Release(stream.final_end());
    stream.Finish();
    benchmark::DoNotOptimize(stream.report().rows);
  }
  state.counters["rows_per_s"] =
      benchmark::Counter(2e6 * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_ReadAndScreen)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);

void BM_ReadScreenFilterAndDeadReckon(benchmark::State& state) {
  const std::string& text = Log();
  for (auto _ : state) {
    telemetry::TelemetryReader reader(text, "benchmark.csv", Model());
    double sum = 0;
    const positioning::PosfilterResult r = positioning::RunPosfilter(
        reader, Model(), positioning::PosfilterOptions{},
        [&sum](const positioning::PoseOutput& row) { sum += row.pose.x_m + row.enu_from_body.w(); });
    benchmark::DoNotOptimize(sum + r.motion.distance_m);
  }
  state.counters["rows_per_s"] =
      benchmark::Counter(2e6 * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_ReadScreenFilterAndDeadReckon)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);

// Writing the two trajectory files alone (formatting and the file system's work).
void BM_WriteOnly(benchmark::State& state) {
  const telemetry::TelemetryLog log = telemetry::ParseTelemetryCsv(Log(), "benchmark.csv", Model());
  const positioning::PosfilterResult r = positioning::RunPosfilter(log, Model(), positioning::PosfilterOptions{});
  const std::filesystem::path out = std::filesystem::temp_directory_path() / "lunarnav_posfilter_bench.csv";
  const std::filesystem::path tum = std::filesystem::temp_directory_path() / "lunarnav_posfilter_bench.tum";
  for (auto _ : state) {
    positioning::TrajectoryWriter writer(out, tum);
    for (const positioning::TrajectorySample& pose : r.motion.trajectory) writer.Add(pose);
    writer.Commit();
  }
  std::filesystem::remove(out);
  std::filesystem::remove(tum);
  state.counters["rows_per_s"] =
      benchmark::Counter(2e6 * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_WriteOnly)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);

}  // namespace

int main(int argc, char** argv) {
  if (argc == 3 && std::string_view(argv[1]) == "--write-log") {
    std::ofstream file(argv[2], std::ios::binary);
    file << Log();
    file.close();
    if (!file) {
      std::fprintf(stderr, "error: %s: cannot write\n", argv[2]);
      return 1;
    }
    return 0;
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 2;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
