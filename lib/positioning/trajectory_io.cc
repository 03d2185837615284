#include "positioning/trajectory_io.h"

#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>

#include <Eigen/Geometry>

#include "io/atomic_file.h"
#include "positioning/attitude.h"
#include "util/check.h"

namespace lunarnav::positioning {
namespace {
constexpr double kDeg = 180.0 / M_PI;

// Locale-independent formatting: `decimals` (0..9) digits after the point, or the shortest
// text that reads back to the same double when decimals < 0. Fixed-point goes through a
// rounded integer (std::to_chars with a precision is several times slower).
void Put(std::string* out, double v, int decimals) {
  char buf[64];
  if (decimals < 0 || !(std::abs(v) < 9e9)) {
    const std::to_chars_result r = std::to_chars(buf, buf + sizeof(buf), v);
    out->append(buf, r.ptr);
    return;
  }
  static constexpr long long kPow10[] = {1, 10, 100, 1000, 10000, 100000, 1000000, 10000000,
                                         100000000, 1000000000};
  const long long scale = kPow10[decimals];
  const long long scaled = std::llround(v * static_cast<double>(scale));
  const unsigned long long magnitude = static_cast<unsigned long long>(scaled < 0 ? -scaled : scaled);
  if (scaled < 0) out->push_back('-');
  char* end = std::to_chars(buf, buf + sizeof(buf), magnitude / scale).ptr;
  out->append(buf, end);
  if (decimals == 0) return;
  out->push_back('.');
  unsigned long long fraction = magnitude % scale;
  char digits[16];
  for (int i = decimals - 1; i >= 0; --i) {
    digits[i] = static_cast<char>('0' + fraction % 10);
    fraction /= 10;
  }
  out->append(digits, static_cast<std::size_t>(decimals));
}
}  // namespace

// Output is built in blocks of about this size and streamed to the file.
constexpr std::size_t kBlockBytes = 1 << 20;

void WriteTrajectoryCsv(const std::filesystem::path& path, const std::vector<TrajectorySample>& trajectory) {
  io::AtomicOutputFile file(path);
  std::string s;
  s.reserve(kBlockBytes + 1024);
  s += "# lunarnav trajectory: frame x east, y north, z up (m), origin at the start;\n";
  s += "# heading clockwise from north (deg, [0, 360)), pitch nose up (deg), roll right side down (deg)\n";
  s += "t_s,x_m,y_m,z_m,heading_deg,pitch_deg,roll_deg,speed_mps\n";
  for (const TrajectorySample& p : trajectory) {
    double heading = std::fmod(p.heading_rad * kDeg, 360.0);
    if (heading < 0) heading += 360.0;
    Put(&s, p.t_s, -1); s += ',';  // as read
    Put(&s, p.x_m, 4); s += ',';    // 0.1 mm
    Put(&s, p.y_m, 4); s += ',';
    Put(&s, p.z_m, 4); s += ',';
    Put(&s, heading, 4); s += ',';  // 0.0001 deg
    Put(&s, p.pitch_rad * kDeg, 4); s += ',';
    Put(&s, p.roll_rad * kDeg, 4); s += ',';
    Put(&s, p.speed_mps, 4); s += '\n';
    if (s.size() >= kBlockBytes) {
      file.Write(s);
      s.clear();
    }
  }
  file.Write(s);
  file.Commit();
}

void WriteTrajectoryTum(const std::filesystem::path& path, const std::vector<TrajectorySample>& trajectory) {
  io::AtomicOutputFile file(path);
  std::string s;
  s.reserve(kBlockBytes + 1024);
  s += "# timestamp tx ty tz qx qy qz qw (lunarnav; ENU frame, body x forward, y left, z up)\n";
  for (const TrajectorySample& p : trajectory) {
    const Eigen::Quaterniond q = EnuFromBody(p.heading_rad, p.pitch_rad, p.roll_rad);
    Put(&s, p.t_s, -1);
    for (double v : {p.x_m, p.y_m, p.z_m}) {
      s += ' ';
      Put(&s, v, 4);
    }
    for (double v : {q.x(), q.y(), q.z(), q.w()}) {
      s += ' ';
      Put(&s, v, 8);
    }
    s += ' ';
    s.back() = '\n';
    if (s.size() >= kBlockBytes) {
      file.Write(s);
      s.clear();
    }
  }
  file.Write(s);
  file.Commit();
}

std::vector<TrajectorySample> ReadTrajectoryCsv(const std::filesystem::path& path) {
  std::ifstream in(path);
  LN_CHECK_INPUT(in.good()) << path.string() << ": cannot open";
  std::vector<TrajectorySample> out;
  std::string line;
  long number = 0;
  bool header = false;
  while (std::getline(in, line)) {
    ++number;
    if (line.empty() || line[0] == '#') continue;
    if (!header) {
      LN_CHECK_INPUT(line.rfind("t_s,x_m,y_m,z_m,heading_deg", 0) == 0)
          << path.string() << ":" << number << ": not a lunarnav trajectory header";
      header = true;
      continue;
    }
    std::istringstream row(line);
    row.imbue(std::locale::classic());
    TrajectorySample p;
    double heading = 0, pitch = 0, roll = 0;
    char c1, c2, c3, c4, c5, c6, c7;
    row >> p.t_s >> c1 >> p.x_m >> c2 >> p.y_m >> c3 >> p.z_m >> c4 >> heading >> c5 >> pitch >> c6 >>
        roll >> c7 >> p.speed_mps;
    LN_CHECK_INPUT(!row.fail()) << path.string() << ":" << number << ": malformed row";
    p.heading_rad = heading / kDeg;
    p.pitch_rad = pitch / kDeg;
    p.roll_rad = roll / kDeg;
    out.push_back(p);
  }
  LN_CHECK_INPUT(header) << path.string() << ": no header";
  return out;
}

}  // namespace lunarnav::positioning
