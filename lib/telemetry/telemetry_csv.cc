#include "telemetry/telemetry_csv.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string_view>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "util/check.h"
#include "util/log.h"

namespace lunarnav::telemetry {
namespace {

std::string_view Trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

// Cell `index` (0-based) of a line that has it.
std::string_view SplitCell(std::string_view line, int index) {
  for (; index > 0; --index) line.remove_prefix(line.find(',') + 1);
  return line.substr(0, line.find(','));
}

// Reads one trimmed cell: a time stamp (a finite decimal number) or a count (an integer,
// optionally with a '+'; an empty cell is a missing sample, NaN). False when it is neither.
bool ParseCell(std::string_view cell, bool time, double* value) {
  const char* const end = cell.data() + cell.size();
  if (time) {
    const auto [ptr, ec] = std::from_chars(cell.data(), end, *value);
    return !cell.empty() && ec == std::errc() && ptr == end && std::isfinite(*value);
  }
  if (cell.empty()) {
    *value = std::numeric_limits<double>::quiet_NaN();
    return true;
  }
  long long count = 0;
  const auto [ptr, ec] = std::from_chars(cell.data() + (cell.front() == '+' ? 1 : 0), end, count);
  *value = static_cast<double>(count);
  return ec == std::errc() && ptr == end;
}

// A plain decimal, digits with at most one point and at most 15 digits in all (the usual time
// stamp), read exactly as std::from_chars reads it: the digits make an integer below 2^53 and
// the point a power of ten up to 1e15, both exact doubles, so their quotient is the correctly
// rounded value of the decimal (Clinger's fast path). False, and nothing read, for anything
// else (signs, exponents, longer numbers), which std::from_chars then reads.
bool ParsePlainDecimal(const char* p, const char* end, double* value) {
  static constexpr double kPow10[16] = {1e0, 1e1, 1e2,  1e3,  1e4,  1e5,  1e6,  1e7,
                                        1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15};
  std::uint64_t mantissa = 0;
  int digits = 0, decimals = -1;  // decimals: digits after the point, -1 before it
  for (; p != end; ++p) {
    const unsigned digit = static_cast<unsigned>(*p - '0');
    if (digit < 10) {
      mantissa = 10 * mantissa + digit;
      ++digits;
      if (decimals >= 0) ++decimals;
    } else if (*p == '.' && decimals < 0) {
      decimals = 0;
    } else {
      return false;
    }
  }
  if (digits == 0 || digits > 15) return false;
  *value = static_cast<double>(mantissa) / kPow10[decimals < 0 ? 0 : decimals];
  return true;
}

// The leading digits of the eight bytes at p (which must be readable): their count (0 to 8)
// in *digits and, when fewer than eight, their value. SWAR: a byte is a digit when its high
// nibble is 3 and adding 6 leaves it 3; the digits are moved to the top of a register, the
// bytes below them zero (leading zeros), and combined pairwise (x10, x100, x10000).
inline std::uint64_t EightByteCount(const char* p, int* digits) {
  std::uint64_t bytes;
  std::memcpy(&bytes, p, 8);
  const std::uint64_t high = bytes & 0xF0F0F0F0F0F0F0F0ULL;
  const std::uint64_t high_plus6 = (bytes + 0x0606060606060606ULL) & 0xF0F0F0F0F0F0F0F0ULL;
  // Nonzero nibble pattern in a byte that is not a digit (bytes are ASCII: no carries between).
  const std::uint64_t not_digit = (high ^ 0x3030303030303030ULL) | (high_plus6 ^ 0x3030303030303030ULL);
  const int n = not_digit == 0 ? 8 : __builtin_ctzll(not_digit) / 8;
  *digits = n;
  if (n == 0 || n == 8) return 0;
  std::uint64_t x = (bytes - 0x3030303030303030ULL) << (8 * (8 - n));  // digits at the top
  x = (x * 10 + (x >> 8)) & 0x00FF00FF00FF00FFULL;           // pairs
  x = (x * 100 + (x >> 16)) & 0x0000FFFF0000FFFFULL;         // fours
  return (x * 10000 + (x >> 32)) & 0xFFFFFFFFULL;            // eight
}

// The common row, read in one scan from `p` up to the first newline (or `end`): no spaces,
// time stamps as std::from_chars reads them, counts of digits only (at most 18) or empty.
// Fills row[c] for the used columns (roles: -2 time, -1 unused, else a channel) and returns
// where the row ends (its newline, or `end`); null for any other row, which the general path
// then reads (and reports, when it is bad). Both give the same values.
const char* ParsePlainRow(const char* p, const char* const end, const std::vector<int>& role, double* row) {
  const int num_columns = static_cast<int>(role.size());
  for (int c = 0; c < num_columns; ++c) {
    if (role[c] == -2) {
      // Digits and a point, read as they are scanned; the cell's end is where they stop.
      const char* cell_end = p;
      while (cell_end != end && (static_cast<unsigned>(*cell_end - '0') < 10 || *cell_end == '.')) ++cell_end;
      if (cell_end != end && *cell_end != ',' && *cell_end != '\n') {  // something else: std::from_chars
        while (cell_end != end && *cell_end != ',' && *cell_end != '\n') ++cell_end;
        const auto [ptr, ec] = std::from_chars(p, cell_end, row[c]);
        if (p == cell_end || ec != std::errc() || ptr != cell_end || !std::isfinite(row[c])) return nullptr;
      } else if (!ParsePlainDecimal(p, cell_end, &row[c])) {
        const auto [ptr, ec] = std::from_chars(p, cell_end, row[c]);
        if (p == cell_end || ec != std::errc() || ptr != cell_end || !std::isfinite(row[c])) return nullptr;
      }
      p = cell_end;
    } else if (role[c] == -1) {
      while (p != end && *p != ',' && *p != '\n') ++p;
    } else if (p == end || *p == ',' || *p == '\n') {
      row[c] = std::numeric_limits<double>::quiet_NaN();
    } else if (end - p >= 8) {  // a count of up to seven digits, from eight bytes at once
      int digits = 0;
      const std::uint64_t value = EightByteCount(p, &digits);
      if (digits == 8) {  // longer counts: digit by digit
        const char* const start = p;
        std::uint64_t count = 0;
        while (p != end && static_cast<unsigned>(*p - '0') < 10) count = 10 * count + static_cast<unsigned>(*p++ - '0');
        if (p - start > 18) return nullptr;
        row[c] = static_cast<double>(static_cast<long long>(count));
      } else {
        row[c] = static_cast<double>(static_cast<long long>(value));  // below 10^7: one signed conversion
        p += digits;
      }
    } else {
      const char* const start = p;
      std::uint64_t count = 0;
      while (p != end && static_cast<unsigned>(*p - '0') < 10) count = 10 * count + static_cast<unsigned>(*p++ - '0');
      if (p - start > 18) return nullptr;
      row[c] = static_cast<double>(static_cast<long long>(count));
    }
    if (c + 1 < num_columns) {
      if (p == end || *p != ',') return nullptr;
      ++p;
    } else if (p != end && *p != '\n') {
      return nullptr;
    }
  }
  return p;
}

// The value of the n (0 to 8) digits that end at p: the eight bytes before p are read (they
// must be readable), the digits' low nibbles kept and combined pairwise (SWAR, as in
// EightByteCount).
inline std::uint64_t DigitsEndingAt(const char* p, int n) {
  static constexpr std::uint64_t kKeep[9] = {0,
                                             0x0F00000000000000ULL,
                                             0x0F0F000000000000ULL,
                                             0x0F0F0F0000000000ULL,
                                             0x0F0F0F0F00000000ULL,
                                             0x0F0F0F0F0F000000ULL,
                                             0x0F0F0F0F0F0F0000ULL,
                                             0x0F0F0F0F0F0F0F00ULL,
                                             0x0F0F0F0F0F0F0F0FULL};
  std::uint64_t x;
  std::memcpy(&x, p - 8, 8);
  x &= kKeep[n];
  x = (x * 10 + (x >> 8)) & 0x00FF00FF00FF00FFULL;
  x = (x * 100 + (x >> 16)) & 0x0000FFFF0000FFFFULL;
  return (x * 10000 + (x >> 32)) & 0xFFFFFFFFULL;
}

// The columns a short row has, and which are read (the others are skipped).
struct ShortRowLayout {
  int columns = 0;
  int time = 0;
  std::vector<int> counts;  // the channels' columns
};

#if defined(__SSE2__)
// The usual row, classified 16 bytes at a time: bit i of each mask says what byte i of the
// row is. Reads the 8 bytes before `p` and 64 from `p` (the caller checks they exist); null
// for a row that is not plain in the narrowest sense (at most 63 bytes, only digits and
// commas and one point in the time cell, the header's cell count, counts of at most eight
// digits, time stamps of at most eight digits either side of the point and 15 in all), which
// ParsePlainRow then reads. Same values as ParsePlainRow. Not inlined: inlined into the row
// loop it ran 20 % slower (its many live values spill the loop's registers).
[[gnu::noinline]] const char* ParseShortRow(const char* p, const ShortRowLayout& layout, double* row) {
  std::uint64_t commas = 0, newlines = 0, points = 0, other = 0;
  for (int k = 0; k < 4; ++k) {
    const __m128i bytes = _mm_loadu_si128(reinterpret_cast<const __m128i*>(p + 16 * k));
    const __m128i comma = _mm_cmpeq_epi8(bytes, _mm_set1_epi8(','));
    const __m128i newline = _mm_cmpeq_epi8(bytes, _mm_set1_epi8('\n'));
    const __m128i point = _mm_cmpeq_epi8(bytes, _mm_set1_epi8('.'));
    const __m128i value = _mm_sub_epi8(bytes, _mm_set1_epi8('0'));
    const __m128i digit = _mm_cmpeq_epi8(_mm_min_epu8(value, _mm_set1_epi8(9)), value);
    const __m128i known = _mm_or_si128(_mm_or_si128(comma, newline), _mm_or_si128(point, digit));
    const int shift = 16 * k;
    commas |= static_cast<std::uint64_t>(_mm_movemask_epi8(comma)) << shift;
    newlines |= static_cast<std::uint64_t>(_mm_movemask_epi8(newline)) << shift;
    points |= static_cast<std::uint64_t>(_mm_movemask_epi8(point)) << shift;
    other |= static_cast<std::uint64_t>(_mm_movemask_epi8(known) ^ 0xFFFF) << shift;
  }
  if (newlines == 0) return nullptr;
  const int length = __builtin_ctzll(newlines);
  const std::uint64_t in_row = (std::uint64_t{1} << length) - 1;
  if ((other & in_row) != 0) return nullptr;
  commas &= in_row;
  points &= in_row;
  // Cell c spans (bound[c], bound[c + 1]): its commas (the newline after the last).
  const int num_columns = layout.columns;
  if (num_columns > 32) return nullptr;  // no such row in 63 bytes
  int bound[33];
  bound[0] = -1;
  for (int c = 1; c < num_columns; ++c) {
    if (commas == 0) return nullptr;  // too few cells
    bound[c] = __builtin_ctzll(commas);
    commas &= commas - 1;
  }
  if (commas != 0) return nullptr;  // too many
  bound[num_columns] = length;
  // The time stamp: digits with at most one point, the only point in the row.
  {
    const int start = bound[layout.time] + 1, end = bound[layout.time + 1], size = end - start;
    const std::uint64_t point = points & (((std::uint64_t{1} << size) - 1) << start);  // size < 64
    if (point != points || (point & (point - 1)) != 0) return nullptr;
    const int whole = point == 0 ? size : __builtin_ctzll(point) - start;
    const int decimals = point == 0 ? 0 : size - whole - 1;
    // At most 15 digits, as ParsePlainDecimal reads (below 2^53).
    if (whole > 8 || decimals > 8 || whole + decimals == 0 || whole + decimals > 15) return nullptr;
    static constexpr double kPow10[9] = {1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8};
    static constexpr std::uint64_t kPow10Int[9] = {1, 10, 100, 1000, 10000, 100000, 1000000, 10000000, 100000000};
    const std::uint64_t mantissa =
        DigitsEndingAt(p + start + whole, whole) * kPow10Int[decimals] + DigitsEndingAt(p + end, decimals);
    // As ParsePlainDecimal: the digits' integer over a power of ten, both exact doubles.
    row[layout.time] = static_cast<double>(mantissa) / kPow10[decimals];
  }
  // The counts, without a branch per cell (empty cells come and go with a channel's rate).
  bool too_long = false;
  for (const int c : layout.counts) {
    const int size = bound[c + 1] - bound[c] - 1;
    too_long |= size > 8;
    const std::uint64_t digits = DigitsEndingAt(p + bound[c + 1], std::min(size, 8));
    const double count = static_cast<double>(static_cast<long long>(digits));
    row[c] = size == 0 ? std::numeric_limits<double>::quiet_NaN() : count;
  }
  if (too_long) return nullptr;
  return p + length;
}
#endif

// Splits one line at commas into `cells` (views into the line); returns the count.
int SplitCells(std::string_view line, std::vector<std::string_view>* cells) {
  cells->clear();
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    cells->push_back(Trim(line.substr(start, comma == std::string_view::npos ? line.npos : comma - start)));
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return static_cast<int>(cells->size());
}

}  // namespace

void TelemetryLog::ClearRows() {
  t_s.clear();
  line.clear();
  for (std::vector<double>& c : counts) c.clear();
}

struct TelemetryReader::Impl {
  std::filesystem::path source;
  // The text: mapped (a regular file), owned (read from a pipe), or the caller's.
  void* mapped = nullptr;
  std::size_t mapped_size = 0;
  std::string owned;
  std::string_view all;
  std::size_t pos = 0;
  long line_number = 0;
  std::vector<std::string> header;
  std::vector<int> role;  // per column: -2 time, -1 unused, else a channel
  ShortRowLayout layout;  // the same, for ParseShortRow
  int time_column = -1;
  double seconds_per_unit = 1.0;  // of the time column (the sensor model's time_units)
  std::vector<Channel> missing_columns;
  std::vector<std::string> unused_columns;
  std::array<bool, kNumChannels> has{};
  std::vector<double> row;  // one row's cells
  std::vector<std::pair<int, double*>> columns;  // while reading: channel columns and their arrays

  ~Impl() {
    if (mapped != nullptr) ::munmap(mapped, mapped_size);
  }

  bool NextLine(std::string_view* line) {
    if (pos >= all.size()) return false;
    std::size_t end = all.find('\n', pos);
    if (end == std::string_view::npos) end = all.size();
    *line = all.substr(pos, end - pos);
    pos = end + 1;
    ++line_number;
    return true;
  }

  // Header: the first line that is neither blank nor a comment.
  void ReadHeader(const SensorModel& model) {
    seconds_per_unit = SecondsPer(model.time_units);
    const std::string name = source.string();
    std::string_view line;
    bool have_header = false;
    while (NextLine(&line)) {
      // A UTF-8 byte-order mark (spreadsheets write one) is no part of the first line, be it
      // the header or a comment.
      if (line_number == 1 && line.substr(0, 3) == "\xEF\xBB\xBF") line.remove_prefix(3);
      const std::string_view trimmed = Trim(line);
      if (trimmed.empty() || trimmed.front() == '#') continue;
      have_header = true;
      break;
    }
    LN_CHECK_INPUT(have_header) << name << ": no header line (the file is empty)";
    const long header_line = line_number;
    std::vector<std::string_view> cells;
    const int num_columns = SplitCells(line, &cells);
    header.assign(cells.begin(), cells.end());
    role.assign(num_columns, -1);
    for (int c = 0; c < num_columns; ++c) {
      if (header[c] == model.time_column) {
        LN_CHECK_INPUT(time_column < 0) << name << ":" << header_line << ": column '" << header[c]
                                        << "' appears twice";
        time_column = c;
        role[c] = -2;
      }
    }
    LN_CHECK_INPUT(time_column >= 0) << name << ":" << header_line << ": missing required column '"
                                     << model.time_column << "'";
    for (Channel ch : kAllChannels) {
      const ChannelModel& m = model[ch];
      if (!m.present) continue;
      int found = -1;
      for (int c = 0; c < num_columns; ++c) {
        if (header[c] != m.column) continue;
        LN_CHECK_INPUT(found < 0) << name << ":" << header_line << ": column '" << m.column
                                  << "' appears twice (columns " << found + 1 << " and " << c + 1 << ")";
        found = c;
      }
      if (found < 0) {
        missing_columns.push_back(ch);
      } else {
        role[found] = static_cast<int>(ch);
        has[static_cast<int>(ch)] = true;
      }
    }
    for (int c = 0; c < num_columns; ++c) {
      if (role[c] == -1) unused_columns.push_back(header[c]);
    }
    row.assign(num_columns, 0.0);
    layout.columns = num_columns;
    layout.time = time_column;
    for (int c = 0; c < num_columns; ++c) {
      if (role[c] >= 0) layout.counts.push_back(c);
    }
  }

  std::size_t Read(TelemetryLog* out, std::size_t max_rows) {
    // In pieces, so that the arrays grow by a bounded amount at a time.
    constexpr std::size_t kPiece = 1 << 16;
    std::size_t total = 0;
    while (total < max_rows) {
      const std::size_t piece = std::min(max_rows - total, kPiece);
      const std::size_t n = ReadPiece(out, piece);
      total += n;
      if (n < piece) break;
    }
    return total;
  }

  // Up to max_rows rows, stored by index into the arrays grown by max_rows beforehand (and
  // cut to the rows read afterwards, also when a bad row throws).
  std::size_t ReadPiece(TelemetryLog* out, std::size_t max_rows) {
    const int num_columns = static_cast<int>(role.size());
    const std::size_t base = out->t_s.size();
    std::size_t rows = 0;
    struct CutToSize {
      TelemetryLog* out;
      const std::vector<int>& role;
      const std::size_t& size;
      ~CutToSize() {
        out->t_s.resize(size);
        out->line.resize(size);
        for (int ch : role) {
          if (ch >= 0) out->counts[ch].resize(size);
        }
      }
    };
    std::size_t size = base;
    const CutToSize cut_at_return{out, role, size};
    out->t_s.resize(base + max_rows);
    out->line.resize(base + max_rows);
    double* const t = out->t_s.data() + base;
    long* const line_of = out->line.data() + base;
    columns.clear();  // (column, its array) for the channel columns
    for (int c = 0; c < num_columns; ++c) {
      if (role[c] < 0) continue;
      out->counts[role[c]].resize(base + max_rows);
      columns.push_back({c, out->counts[role[c]].data() + base});
    }
    const char* const text_end = all.data() + all.size();
    while (rows < max_rows && pos < all.size()) {
      // The common row straight from the text; anything else (blank and comment lines too)
      // as a line by the general path.
      const char* const start = all.data() + pos;
      const char first = *start;
      const char* row_end = nullptr;
      if (first != '#' && first != ' ' && first != '\t' && first != '\r' && first != '\n') {
#if defined(__SSE2__)
        if (text_end - start >= 64 && start - all.data() >= 8) row_end = ParseShortRow(start, layout, row.data());
#endif
        if (row_end == nullptr) row_end = ParsePlainRow(start, text_end, role, row.data());
      }
      if (row_end != nullptr) {
        pos = static_cast<std::size_t>(row_end - all.data()) + 1;
        ++line_number;
      } else {
        std::string_view line;
        NextLine(&line);
        const std::string_view trimmed = Trim(line);
        if (trimmed.empty() || trimmed.front() == '#') continue;
        ParseGeneralRow(line);
      }
      t[rows] = row[time_column];
      for (const auto& [c, column] : columns) column[rows] = row[c];
      line_of[rows] = line_number;
      size = base + ++rows;
    }
    return rows;
  }

  // Any row the plain path does not read: cells are parsed as they are split; the first
  // error is reported after the cell count has been checked.
  void ParseGeneralRow(std::string_view line) {
    const int num_columns = static_cast<int>(role.size());
    int n = 0, bad = -1;
    std::size_t start = 0;
    while (true) {
      const std::size_t comma = line.find(',', start);
      const std::string_view cell =
          Trim(line.substr(start, comma == std::string_view::npos ? line.npos : comma - start));
      if (n < num_columns && bad < 0 && role[n] != -1 && !ParseCell(cell, role[n] == -2, &row[n])) bad = n;
      ++n;
      if (comma == std::string_view::npos) break;
      start = comma + 1;
    }
    const std::string name = source.string();
    LN_CHECK_INPUT(n == num_columns) << name << ":" << line_number << ": " << n << " cells, the header has "
                                     << num_columns;
    // The cell quoted printable (a NUL would cut the message where it is carried as C text).
    LN_CHECK_INPUT(bad < 0) << name << ":" << line_number << ": column '" << header[bad] << "': '"
                            << util::BoundedMessage(std::string(Trim(SplitCell(line, bad))), 200) << "' is not "
                            << (bad == time_column ? "a time stamp" : "an integer count");
  }
};

TelemetryReader::TelemetryReader(const std::filesystem::path& path, const SensorModel& model)
    : impl_(std::make_unique<Impl>()) {
  impl_->source = path;
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  LN_CHECK_INPUT(fd >= 0) << path.string() << ": cannot open";
  const struct Close {
    int fd;
    ~Close() { ::close(fd); }
  } close_at_return{fd};
  // A regular file is mapped, not copied (long logs are hundreds of megabytes); anything else
  // (a pipe) is read.
  struct stat info {};
  if (::fstat(fd, &info) == 0 && S_ISREG(info.st_mode) && info.st_size > 0) {
    const std::size_t size = static_cast<std::size_t>(info.st_size);
    void* const mapped = ::mmap(nullptr, size, PROT_READ, MAP_PRIVATE | MAP_POPULATE, fd, 0);
    if (mapped != MAP_FAILED) {
      impl_->mapped = mapped;
      impl_->mapped_size = size;
      impl_->all = std::string_view(static_cast<const char*>(mapped), size);
    }
  }
  if (impl_->mapped == nullptr) {
    char buffer[1 << 16];
    while (true) {
      const ssize_t n = ::read(fd, buffer, sizeof(buffer));
      if (n == 0) break;
      if (n < 0 && errno == EINTR) continue;
      LN_CHECK_INPUT(n > 0) << path.string() << ": read error";
      impl_->owned.append(buffer, static_cast<std::size_t>(n));
    }
    impl_->all = impl_->owned;
  }
  impl_->ReadHeader(model);
}

TelemetryReader::TelemetryReader(std::string_view text, const std::string& source, const SensorModel& model)
    : impl_(std::make_unique<Impl>()) {
  impl_->source = source;
  impl_->all = text;
  impl_->ReadHeader(model);
}

TelemetryReader::~TelemetryReader() = default;

std::size_t TelemetryReader::Read(TelemetryLog* out, std::size_t max_rows) {
  const std::size_t base = out->t_s.size();
  const std::size_t n = impl_->Read(out, max_rows);
  if (impl_->seconds_per_unit != 1.0) {  // time stamps in ms, us or ns: to seconds
    for (std::size_t k = base; k < base + n; ++k) out->t_s[k] *= impl_->seconds_per_unit;
  }
  return n;
}
const std::filesystem::path& TelemetryReader::source() const { return impl_->source; }
bool TelemetryReader::Has(Channel c) const { return impl_->has[static_cast<int>(c)]; }
const std::vector<Channel>& TelemetryReader::missing_columns() const { return impl_->missing_columns; }
const std::vector<std::string>& TelemetryReader::unused_columns() const { return impl_->unused_columns; }

std::size_t TelemetryReader::LinesLeft() const {
  const std::string_view rest = impl_->all.substr(std::min(impl_->pos, impl_->all.size()));
  return static_cast<std::size_t>(std::count(rest.begin(), rest.end(), '\n')) + 1;
}

double TelemetryReader::FractionRead() const {
  return impl_->all.empty() ? 1.0
                            : static_cast<double>(std::min(impl_->pos, impl_->all.size())) /
                                  static_cast<double>(impl_->all.size());
}

namespace {

// The whole log from a reader.
TelemetryLog ReadAll(TelemetryReader& reader) {
  TelemetryLog log;
  log.source = reader.source();
  log.missing_columns = reader.missing_columns();
  log.unused_columns = reader.unused_columns();
  // The arrays are reserved for the number of lines left (an upper bound).
  const std::size_t estimate = reader.LinesLeft();
  log.t_s.reserve(estimate);
  log.line.reserve(estimate);
  for (Channel c : kAllChannels) {
    if (reader.Has(c)) log.counts[static_cast<int>(c)].reserve(estimate);
  }
  reader.Read(&log, static_cast<std::size_t>(-1));
  return log;
}

}  // namespace

TelemetryLog ParseTelemetryCsv(std::string_view text, const std::string& source, const SensorModel& model) {
  TelemetryReader reader(text, source, model);
  return ReadAll(reader);
}

TelemetryLog ReadTelemetryCsv(const std::filesystem::path& path, const SensorModel& model) {
  TelemetryReader reader(path, model);
  return ReadAll(reader);
}

}  // namespace lunarnav::telemetry
