#include "positioning/trajectory_io.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <sstream>

#include <Eigen/Geometry>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "io/atomic_file.h"
#include "positioning/attitude.h"
#include "util/check.h"
#include "util/text_lines.h"

namespace lunarnav::positioning {
namespace {
constexpr double kDeg = 180.0 / M_PI;

// Output is built in blocks of about this size and streamed to the file; one row is far
// shorter than the slack.
constexpr std::size_t kBlockBytes = 1 << 20;
constexpr std::size_t kRowSlack = 1024;

constexpr long long Pow10(int n) { return n == 0 ? 1 : 10 * Pow10(n - 1); }

// The digits of numbers below 100 held in the 16-bit lanes of `lanes` (the first number in
// the lowest lane), as ASCII, the lanes' two bytes each: tens = lane * 103 >> 10 in every
// lane at once (exact below 179, and no lane's product reaches the next), ones = lane -
// 10 tens. The bytes are in order when stored little-endian.
inline std::uint64_t DigitPairsToAscii(std::uint64_t lanes, std::uint64_t lane_mask) {
  std::uint64_t tens = ((lanes * 103) >> 10) & lane_mask;
  return (tens | ((lanes - 10 * tens) << 8)) | 0x3030303030303030ULL;
}

// Four digits, leading zeros included, of v < 10000, made in one register.
inline void Put4Digits(char* out, unsigned v) {
  const unsigned hundreds = v / 100;
  const std::uint64_t lanes = hundreds | (static_cast<std::uint64_t>(v - 100 * hundreds) << 16);
  const auto ascii = static_cast<std::uint32_t>(DigitPairsToAscii(lanes, 0x000F000FULL));
  std::memcpy(out, &ascii, 4);
}

// Eight digits, leading zeros included, of v < 10^8, as ASCII in a register (the first digit
// in the lowest byte): the two halves in 32-bit lanes, each split by 100 (x * 10486 >> 20,
// exact below 10^4) into 16-bit lanes, then as above.
inline std::uint64_t EightDigits(std::uint32_t v) {
  const std::uint64_t halves = (v / 10000) | (static_cast<std::uint64_t>(v % 10000) << 32);
  const std::uint64_t high = ((halves * 10486) >> 20) & 0x0000007F0000007FULL;
  const std::uint64_t lanes = ((halves - 100 * high) << 16) | high;
  return DigitPairsToAscii(lanes, 0x000F000F000F000FULL);
}

inline void Put8Digits(char* out, std::uint32_t v) {
  const std::uint64_t ascii = EightDigits(v);
  std::memcpy(out, &ascii, 8);
}

// The decimal digits of v (no leading zeros). Below 10^8 they are made in one register and
// stored as eight bytes, the leading zeros shifted out: the caller has room for eight bytes
// and writes on after the digits.
inline char* PutUnsigned(char* out, unsigned long long v) {
  if (v < 10) {  // the usual angle and speed
    *out = static_cast<char>('0' + v);
    return out + 1;
  }
  if (v >= 100000000) return std::to_chars(out, out + 24, v).ptr;
  const int digits = 2 + (v >= 100) + (v >= 1000) + (v >= 10000) + (v >= 100000) + (v >= 1000000) +
                     (v >= 10000000);
  const std::uint64_t ascii = EightDigits(static_cast<std::uint32_t>(v)) >> (8 * (8 - digits));
  std::memcpy(out, &ascii, 8);
  return out + digits;
}

// Locale-independent formatting into a buffer with room for 32 characters; returns the end.
// The shortest text that reads back to the same double, as std::to_chars writes it.
// Fast path for the usual time stamps, n / 10 with n not a multiple of 10 (tenths of a
// second): the double nearest n / 10 is written "n/10.d" by std::to_chars (no other decimal
// of as few digits lies within its rounding interval, and fixed notation is the shorter).
char* PutShortest(char* out, double v) {
  if (v > 0 && v < 1e9) {
    const long long tenths = static_cast<long long>(v * 10.0 + 0.5);
    if (tenths % 10 != 0 && static_cast<double>(tenths) / 10.0 == v) {
      out = PutUnsigned(out, static_cast<unsigned long long>(tenths / 10));
      *out++ = '.';
      *out++ = static_cast<char>('0' + tenths % 10);
      return out;
    }
    // A whole number: its digits, when they are shorter than the scientific form
    // ("d.ddde+XX", trailing zeros dropped), which std::to_chars writes otherwise.
    const long long whole = tenths / 10;
    if (tenths % 10 == 0 && static_cast<double>(whole) == v) {
      int digits = 1, significant = 0;
      for (long long w = whole, position = 1; w > 0; w /= 10, ++position) {
        if (w % 10 != 0 && significant == 0) significant = position;  // lowest nonzero digit
        digits = static_cast<int>(position);
      }
      const int mantissa_digits = digits - significant + 1;
      if (digits < mantissa_digits + (mantissa_digits > 1 ? 1 : 0) + 4) {
        return PutUnsigned(out, static_cast<unsigned long long>(whole));
      }
    }
  }
  return std::to_chars(out, out + 32, v).ptr;
}

// v * 10^kDecimals rounded half away from zero (|v| < 9e9): std::llround, inline
// (x - trunc(x) is exact, so the halfway test is too), and without a branch (which way a
// value rounds is as good as random, a branch on it mispredicted).
template <int kDecimals>
long long RoundedScaled(double v) {
  const double x = v * static_cast<double>(Pow10(kDecimals));
  const auto scaled = static_cast<long long>(x);
  const double fraction = x - static_cast<double>(scaled);
  return scaled + static_cast<long long>(fraction >= 0.5) - static_cast<long long>(fraction <= -0.5);
}

// The digits before the point of m / 10^4 (m < 10^8): 1 to 4.
inline int IntegerDigits(unsigned long long m) { return 1 + (m >= 100000) + (m >= 1000000) + (m >= 10000000); }

// The usual fixed-point number, m / 10^kDecimals with m < 10^8, from the eight digits of m
// in `ascii` (EightDigits): "0." and the eight, or for four decimals the integer part (its
// `integer_digits` digits, the leading zeros shifted out), '.', four.
template <int kDecimals>
inline char* PutUsualFixed(char* out, std::uint64_t ascii, int integer_digits) {
  if constexpr (kDecimals == 8) {
    std::memcpy(out, "0.", 2);
    std::memcpy(out + 2, &ascii, 8);
    return out + 10;
  } else {
    const auto integer = static_cast<std::uint32_t>(ascii) >> (8 * (4 - integer_digits));
    const auto decimals = static_cast<std::uint32_t>(ascii >> 32);
    std::memcpy(out, &integer, 4);
    out[integer_digits] = '.';
    std::memcpy(out + integer_digits + 1, &decimals, 4);
    return out + integer_digits + 5;
  }
}

// kDecimals (4 or 8) digits after the point, rounded half away from zero; values of
// 9e9 and beyond (and NaN) as PutShortest. Fixed-point goes through a rounded integer
// (std::to_chars with a precision is several times slower).
template <int kDecimals>
char* PutFixed(char* out, double v) {
  static_assert(kDecimals == 4 || kDecimals == 8);
  if (!(std::abs(v) < 9e9)) return PutShortest(out, v);
  constexpr long long kScale = Pow10(kDecimals);
  const long long scaled = RoundedScaled<kDecimals>(v);
  // The sign without a branch too: pitch, roll and the quaternion change sign at random.
  *out = '-';
  out += scaled < 0;
  const unsigned long long m = static_cast<unsigned long long>(scaled < 0 ? -scaled : scaled);
  if (m < 100000000) {  // the usual number: all its digits from one eight-digit conversion
    return PutUsualFixed<kDecimals>(out, EightDigits(static_cast<std::uint32_t>(m)), IntegerDigits(m));
  }
  // Larger ones: the integer part and the decimals separately.
  out = PutUnsigned(out, m / kScale);
  *out++ = '.';
  const unsigned long long decimals = m % kScale;
  if constexpr (kDecimals == 8) {
    Put8Digits(out, static_cast<std::uint32_t>(decimals));
  } else {
    Put4Digits(out, static_cast<unsigned>(decimals));
  }
  return out + kDecimals;
}

// Four numbers' fixed-point text, made at once: PutFixedDigits then writes number k exactly as
// PutFixed writes it. The conversions of a row's numbers are independent, and SSE2 does four
// in the time PutFixed takes for one (the rounding in doubles, the digits in 16-bit lanes:
// / 10^4 by a 32-bit multiply, / 100 and / 10 by 16-bit ones, exact below 10^8).
struct FixedDigits {
  alignas(16) std::uint64_t ascii[4];  // each number's eight digits (leading zeros), ASCII
  alignas(16) std::int32_t integer_digits[4];  // kDecimals 4: digits before the point (1 to 4)
  int negative;  // bit k: number k is below zero (after rounding)
  int usual;     // bit k: number k is finite and rounds to below 10^8 units
};

template <int kDecimals>
inline void FixedDigits4(double v0, double v1, double v2, double v3, FixedDigits* d) {
#if !defined(__SSE2__)
  // Elsewhere number by number, as PutFixed.
  d->negative = d->usual = 0;
  const double v[4] = {v0, v1, v2, v3};
  for (int k = 0; k < 4; ++k) {
    if (!(std::abs(v[k]) < 9e9)) continue;
    const long long scaled = RoundedScaled<kDecimals>(v[k]);
    const unsigned long long m = static_cast<unsigned long long>(scaled < 0 ? -scaled : scaled);
    if (m >= 100000000) continue;
    d->usual |= 1 << k;
    d->negative |= static_cast<int>(scaled < 0) << k;
    d->ascii[k] = EightDigits(static_cast<std::uint32_t>(m));
    d->integer_digits[k] = IntegerDigits(m);
  }
#else
  const __m128d scale = _mm_set1_pd(static_cast<double>(Pow10(kDecimals)));
  const __m128d x01 = _mm_mul_pd(_mm_set_pd(v1, v0), scale);
  const __m128d x23 = _mm_mul_pd(_mm_set_pd(v3, v2), scale);
  // Rounded half away from zero, as PutFixed: truncated, then +-1 by the fraction.
  const __m128i t = _mm_unpacklo_epi64(_mm_cvttpd_epi32(x01), _mm_cvttpd_epi32(x23));
  const __m128d f01 = _mm_sub_pd(x01, _mm_cvtepi32_pd(t));
  const __m128d f23 = _mm_sub_pd(x23, _mm_cvtepi32_pd(_mm_shuffle_epi32(t, _MM_SHUFFLE(1, 0, 3, 2))));
  const __m128d half = _mm_set1_pd(0.5), minus_half = _mm_set1_pd(-0.5);
  // The four 64-bit comparison masks as 32-bit lanes (all ones: -1).
  const auto lanes = [](__m128d mask01, __m128d mask23) {
    return _mm_castps_si128(_mm_shuffle_ps(_mm_castpd_ps(mask01), _mm_castpd_ps(mask23), _MM_SHUFFLE(2, 0, 2, 0)));
  };
  const __m128i up = lanes(_mm_cmpge_pd(f01, half), _mm_cmpge_pd(f23, half));
  const __m128i down = lanes(_mm_cmple_pd(f01, minus_half), _mm_cmple_pd(f23, minus_half));
  const __m128i scaled = _mm_add_epi32(_mm_sub_epi32(t, up), down);
  const __m128i limit = _mm_set1_epi32(100000000), minus_limit = _mm_set1_epi32(-100000000);
  d->usual = _mm_movemask_ps(
      _mm_castsi128_ps(_mm_and_si128(_mm_cmplt_epi32(scaled, limit), _mm_cmpgt_epi32(scaled, minus_limit))));
  d->negative = _mm_movemask_ps(_mm_castsi128_ps(scaled));
  const __m128i sign = _mm_srai_epi32(scaled, 31);
  const __m128i m = _mm_sub_epi32(_mm_xor_si128(scaled, sign), sign);
  // m = 10^4 hi + lo.
  const __m128i magic = _mm_set1_epi32(static_cast<int>(0xD1B71759u));  // / 10^4: * magic >> 45
  const __m128i hi_even = _mm_srli_epi64(_mm_mul_epu32(m, magic), 45);
  const __m128i hi_odd = _mm_srli_epi64(_mm_mul_epu32(_mm_srli_epi64(m, 32), magic), 45);
  const __m128i hi = _mm_or_si128(hi_even, _mm_slli_epi64(hi_odd, 32));
  const __m128i lo = _mm_sub_epi32(m, _mm_madd_epi16(hi, _mm_set1_epi32(10000)));
  // Eight numbers below 10^4 in 16-bit lanes (hi0..hi3, lo0..lo3), each = 100 q + r.
  const __m128i x = _mm_packs_epi32(hi, lo);
  const __m128i q = _mm_srli_epi16(_mm_mulhi_epu16(x, _mm_set1_epi16(5243)), 3);
  const __m128i r = _mm_sub_epi16(x, _mm_mullo_epi16(q, _mm_set1_epi16(100)));
  // Each below 100 = 10 tens + ones: two digits, in a lane's two bytes in reading order.
  const __m128i q_tens = _mm_mulhi_epu16(q, _mm_set1_epi16(6554));
  const __m128i r_tens = _mm_mulhi_epu16(r, _mm_set1_epi16(6554));
  const __m128i ten = _mm_set1_epi16(10);
  const __m128i q_digits = _mm_or_si128(q_tens, _mm_slli_epi16(_mm_sub_epi16(q, _mm_mullo_epi16(q_tens, ten)), 8));
  const __m128i r_digits = _mm_or_si128(r_tens, _mm_slli_epi16(_mm_sub_epi16(r, _mm_mullo_epi16(r_tens, ten)), 8));
  const __m128i fours_hi = _mm_unpacklo_epi16(q_digits, r_digits);  // hi0..hi3, four digits each
  const __m128i fours_lo = _mm_unpackhi_epi16(q_digits, r_digits);  // lo0..lo3
  const __m128i zeros = _mm_set1_epi8('0');
  auto* const ascii = reinterpret_cast<__m128i*>(d->ascii);
  _mm_store_si128(ascii, _mm_or_si128(_mm_unpacklo_epi32(fours_hi, fours_lo), zeros));      // numbers 0, 1
  _mm_store_si128(ascii + 1, _mm_or_si128(_mm_unpackhi_epi32(fours_hi, fours_lo), zeros));  // 2, 3
  if constexpr (kDecimals == 4) {
    const __m128i count = _mm_sub_epi32(
        _mm_sub_epi32(_mm_sub_epi32(_mm_set1_epi32(1), _mm_cmpgt_epi32(m, _mm_set1_epi32(99999))),
                      _mm_cmpgt_epi32(m, _mm_set1_epi32(999999))),
        _mm_cmpgt_epi32(m, _mm_set1_epi32(9999999)));
    _mm_store_si128(reinterpret_cast<__m128i*>(d->integer_digits), count);
  }
#endif
}

// Number k of `d` (value v), as PutFixed<kDecimals> writes it.
template <int kDecimals>
inline char* PutFixedDigits(char* out, const FixedDigits& d, int k, double v) {
  if (!((d.usual >> k) & 1)) return PutFixed<kDecimals>(out, v);
  *out = '-';
  out += (d.negative >> k) & 1;
  return PutUsualFixed<kDecimals>(out, d.ascii[k], kDecimals == 4 ? d.integer_digits[k] : 0);
}

// Heading in degrees, [0, 360): fmod(heading, 360), plus 360 when negative. The heading is
// continuous, so after the first full turn almost every value needs wrapping, and fmod is
// slow: h - 360 floor(h / 360) is the same real number (360 n is exact, and so is the
// difference when it is fmod's result), so its one rounding gives the same double, except
// when the rounded quotient put n off by one, which the range test catches.
double HeadingDeg(double heading_rad) {
  double heading = heading_rad * kDeg;
  if (!(heading >= 0 && heading < 360.0)) {
    const double wrapped = heading - 360.0 * std::floor(heading / 360.0);
    if (wrapped >= 0 && wrapped < 360.0) return wrapped;
    heading = std::fmod(heading, 360.0);
    if (heading < 0) heading += 360.0;
  }
  return heading;
}
}  // namespace

// One output file: rows are formatted straight into a block that is written out when full.
class TrajectoryWriter::Output {
 public:
  Output(const std::filesystem::path& path, std::string_view header)
      : file_(path), block_(kBlockBytes + kRowSlack) {
    file_.Write(header);
  }
  // Where the next row goes (room for kRowSlack bytes).
  char* cursor() { return block_.data() + used_; }
  // The row ends at `end`.
  void Advance(char* end) {
    used_ = static_cast<std::size_t>(end - block_.data());
    if (used_ >= kBlockBytes) Flush();
  }
  void Commit() {
    Flush();
    file_.Commit();
  }

 private:
  void Flush() {
    file_.Write(std::string_view(block_.data(), used_));
    used_ = 0;
  }
  io::AtomicOutputFile file_;
  std::vector<char> block_;
  std::size_t used_ = 0;
};

TrajectoryWriter::TrajectoryWriter(const std::filesystem::path& csv_path, const std::filesystem::path& tum_path) {
  if (!csv_path.empty()) {
    csv_ = std::make_unique<Output>(
        csv_path,
        "# lunarnav trajectory: frame x east, y north, z up (m), origin at the start;\n"
        "# heading clockwise from north (deg, [0, 360)), pitch nose up (deg), roll right side down (deg)\n"
        "t_s,x_m,y_m,z_m,heading_deg,pitch_deg,roll_deg,speed_mps\n");
  }
  if (!tum_path.empty()) {
    tum_ = std::make_unique<Output>(
        tum_path, "# timestamp tx ty tz qx qy qz qw (lunarnav; ENU frame, body x forward, y left, z up)\n");
  }
}

TrajectoryWriter::~TrajectoryWriter() = default;

void TrajectoryWriter::Add(const TrajectorySample& p) {
  Add(p, tum_ ? EnuFromBody(p.heading_rad, p.pitch_rad, p.roll_rad) : Eigen::Quaterniond::Identity());
}

void TrajectoryWriter::Add(const TrajectorySample& p, const Eigen::Quaterniond& q) {
  // Time (as read) and position (0.1 mm) are the same text in both files: formatted once,
  // into the CSV row itself (or a local buffer without one), and copied into the TUM row
  // after the CSV row is complete: by then its small stores have reached the cache, and the
  // copy's eight-byte loads do not wait on them.
  char local[4 * 32 + 8];
  char* const prefix = csv_ ? csv_->cursor() : local;
  const double heading_deg = HeadingDeg(p.heading_rad);
  FixedDigits position;  // and the heading
  FixedDigits4<4>(p.x_m, p.y_m, p.z_m, heading_deg, &position);
  char* end = PutShortest(prefix, p.t_s);
  *end++ = ',';
  end = PutFixedDigits<4>(end, position, 0, p.x_m);
  *end++ = ',';
  end = PutFixedDigits<4>(end, position, 1, p.y_m);
  *end++ = ',';
  end = PutFixedDigits<4>(end, position, 2, p.z_m);
  const std::size_t prefix_size = static_cast<std::size_t>(end - prefix);
  if (csv_) {
    const double pitch_deg = p.pitch_rad * kDeg, roll_deg = p.roll_rad * kDeg;
    FixedDigits rest;
    FixedDigits4<4>(pitch_deg, roll_deg, p.speed_mps, 0.0, &rest);
    char* out = end;
    *out++ = ',';
    out = PutFixedDigits<4>(out, position, 3, heading_deg);  // 0.0001 deg
    *out++ = ',';
    out = PutFixedDigits<4>(out, rest, 0, pitch_deg);
    *out++ = ',';
    out = PutFixedDigits<4>(out, rest, 1, roll_deg);
    *out++ = ',';
    out = PutFixedDigits<4>(out, rest, 2, p.speed_mps);  // 0.1 mm/s
    *out++ = '\n';  // at least 20 bytes after the prefix: the copy below reads defined bytes
    csv_->Advance(out);  // (a flush leaves the bytes where they are)
  } else {
    std::memset(end, 0, 8);  // defined bytes up to the next multiple of eight
  }
  if (tum_) {
    char* out = tum_->cursor();
    // The prefix with ',' made ' ', eight bytes at a time: a byte of w ^ ",,,,,,,," is zero
    // exactly where w has a comma; its high bit, moved down and times 0x0C, turns 0x2C into
    // 0x20 there. The bytes past the prefix are copied too, and overwritten below.
    for (std::size_t i = 0; i < prefix_size; i += 8) {
      std::uint64_t w;
      std::memcpy(&w, prefix + i, 8);
      constexpr std::uint64_t kCommas = 0x2C2C2C2C2C2C2C2CULL, kLow7 = 0x7F7F7F7F7F7F7F7FULL;
      const std::uint64_t x = w ^ kCommas;
      const std::uint64_t comma = ~(((x & kLow7) + kLow7) | x | kLow7);  // 0x80 in the comma bytes
      w ^= (comma >> 7) * 0x0C;
      std::memcpy(out + i, &w, 8);
    }
    out += prefix_size;
    FixedDigits quaternion;
    FixedDigits4<8>(q.x(), q.y(), q.z(), q.w(), &quaternion);
    for (int k = 0; k < 4; ++k) {
      *out++ = ' ';
      out = PutFixedDigits<8>(out, quaternion, k, q.coeffs()[k]);
    }
    *out++ = '\n';
    tum_->Advance(out);
  }
}

void TrajectoryWriter::Commit() {
  if (csv_) csv_->Commit();
  if (tum_) tum_->Commit();
}

void WriteTrajectoryCsv(const std::filesystem::path& path, const std::vector<TrajectorySample>& trajectory) {
  TrajectoryWriter writer(path, {});
  for (const TrajectorySample& p : trajectory) writer.Add(p);
  writer.Commit();
}

void WriteTrajectoryTum(const std::filesystem::path& path, const std::vector<TrajectorySample>& trajectory) {
  TrajectoryWriter writer({}, path);
  for (const TrajectorySample& p : trajectory) writer.Add(p);
  writer.Commit();
}

std::vector<TrajectorySample> ReadTrajectoryCsv(const std::filesystem::path& path) {
  util::TextLines lines(path);
  std::vector<TrajectorySample> out;
  std::string line;
  bool header = false;
  while (lines.Next(&line)) {
    if (!header) {
      LN_CHECK_INPUT(line.rfind("t_s,x_m,y_m,z_m,heading_deg", 0) == 0) << lines.Where() << ": not a lunarnav trajectory header";
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
    LN_CHECK_INPUT(!row.fail()) << lines.Where() << ": malformed row";
    p.heading_rad = heading / kDeg;
    p.pitch_rad = pitch / kDeg;
    p.roll_rad = roll / kDeg;
    out.push_back(p);
  }
  LN_CHECK_INPUT(header) << path.string() << ": no header";
  return out;
}

std::vector<TumPose> ReadTumPoses(const std::filesystem::path& path) {
  util::TextLines lines(path);
  std::vector<TumPose> poses;
  std::string line;
  while (lines.Next(&line)) {
    const long number = lines.number();
    std::istringstream fields(line);
    fields.imbue(std::locale::classic());
    double v[8];
    for (double& x : v) {
      fields >> x;
      LN_CHECK_INPUT(static_cast<bool>(fields))
          << path.string() << ":" << number << ": expected 8 numbers (t x y z qx qy qz qw)";
    }
    std::string rest;
    LN_CHECK_INPUT(!(fields >> rest)) << path.string() << ":" << number << ": more than 8 fields";
    const Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);
    LN_CHECK_INPUT(std::abs(q.norm() - 1.0) < 1e-3)
        << path.string() << ":" << number << ": quaternion of norm " << q.norm() << " (expected 1)";
    LN_CHECK_INPUT(poses.empty() || v[0] > poses.back().t_s)
        << path.string() << ":" << number << ": time stamps must increase";
    poses.push_back({v[0], Eigen::Vector3d(v[1], v[2], v[3]), q.normalized()});
  }
  return poses;
}

std::vector<TrajectorySample> ReadTrajectoryTum(const std::filesystem::path& path) {
  std::vector<TrajectorySample> out;
  for (const TumPose& tum : ReadTumPoses(path)) {
    // EnuFromBody = Rz(90 deg - heading) Ry(-pitch) Rx(-roll): a Z-Y-X rotation.
    const Eigen::Matrix3d r = tum.world_from_body.toRotationMatrix();
    TrajectorySample p;
    p.t_s = tum.t_s;
    p.x_m = tum.position_m.x();
    p.y_m = tum.position_m.y();
    p.z_m = tum.position_m.z();
    p.heading_rad = std::fmod(M_PI / 2 - std::atan2(r(1, 0), r(0, 0)) + 2 * M_PI, 2 * M_PI);
    p.pitch_rad = std::asin(std::clamp(r(2, 0), -1.0, 1.0));
    p.roll_rad = -std::atan2(r(2, 1), r(2, 2));
    out.push_back(p);
  }
  return out;
}

}  // namespace lunarnav::positioning
