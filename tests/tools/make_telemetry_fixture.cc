// Writes testdata/telemetry/turning.csv (see testdata/README.md):
//   build/tests/tools/make_telemetry_fixture testdata/telemetry/turning.csv
// 120 s at 10 Hz of a rover with the sensors of testdata/telemetry/ratler_sensors.json: 10 s
// standing still, then 0.5 m/s, with a 15 deg/s left... right turn from 30 to 50 s and a left
// turn from 70 to 90 s (2 s ramps). The gyro has a 1.5 deg/s bias and 0.3 deg/s noise; the
// compass 2 deg noise and, while turning, a transient of 25 deg per 15 deg/s of turn (the
// motors' currents), as in the paper's Figure 6; inclinometers 0.3 deg noise.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: make_telemetry_fixture OUT.csv\n");
    return 2;
  }
  std::FILE* out = std::fopen(argv[1], "w");
  if (out == nullptr) {
    std::fprintf(stderr, "error: %s: cannot open\n", argv[1]);
    return 3;
  }
  std::mt19937 rng(2024);
  std::normal_distribution<double> unit(0.0, 1.0);
  auto ramp = [](double t, double t0, double t1) {
    return std::clamp((t - t0) / 2.0, 0.0, 1.0) * std::clamp((t1 - t) / 2.0, 0.0, 1.0);
  };
  std::fprintf(out, "# lunarnav test log: a turning rover with compass transients (make_telemetry_fixture)\n");
  std::fprintf(out, "t,enc_fl,enc_fr,enc_rl,enc_rr,compass,pitch_left,pitch_right,roll,gyro_z\n");
  double heading = 170.0, distance = 0.0;
  const double metres_per_count = 2 * M_PI * 0.25 / 256;
  for (int i = 0; i < 1200; ++i) {
    const double t = 0.1 * i;
    const double rate = 15.0 * ramp(t, 30, 50) - 15.0 * ramp(t, 70, 90);  // deg/s, right positive
    const double speed = t < 10 ? 0.0 : 0.5;
    if (i > 0) {
      heading += rate * 0.1;
      distance += speed * 0.1;
    }
    const long enc = std::lround(distance / metres_per_count) % 1024;
    const double compass_deg = std::fmod(heading + 2.0 * unit(rng) + 25.0 * rate / 15.0 + 720.0, 360.0);
    const long compass = std::lround(compass_deg / 0.3515625) % 1024;
    const long pitch_l = std::lround((3.0 + 0.3 * unit(rng) + 45.0) / 0.087890625);
    const long pitch_r = std::lround((3.0 + 0.3 * unit(rng) + 45.0) / 0.087890625);
    const long roll = std::lround((0.3 * unit(rng) + 45.0) / 0.087890625);
    const long gyro = std::lround((rate + 1.5 + 0.3 * unit(rng) + 60.0) / 0.1171875);
    std::fprintf(out, "%.1f,%ld,%ld,%ld,%ld,%ld,%ld,%ld,%ld,%ld\n", t, enc, enc, enc, enc, compass,
                 pitch_l, pitch_r, roll, gyro);
  }
  std::fclose(out);
  return 0;
}
