#include "io/point_cloud_io.h"

#include <cmath>
#include <cstring>
#include <fstream>
#include <locale>
#include <sstream>
#include <string>

#include "io/ply_io.h"
#include "util/check.h"
#include "util/errors.h"

namespace lunarnav::io {
namespace fs = std::filesystem;

namespace {

bool Finite(const Eigen::Vector3f& p) { return std::isfinite(p.x()) && std::isfinite(p.y()) && std::isfinite(p.z()); }

float LittleEndianFloat(const unsigned char* p) {
  const std::uint32_t bits =
      std::uint32_t{p[0]} | std::uint32_t{p[1]} << 8 | std::uint32_t{p[2]} << 16 | std::uint32_t{p[3]} << 24;
  float v;
  std::memcpy(&v, &bits, sizeof v);
  return v;
}

double LittleEndianDouble(const unsigned char* p) {
  std::uint64_t bits = 0;
  for (int k = 0; k < 8; ++k) bits |= std::uint64_t{p[k]} << (8 * k);
  double v;
  std::memcpy(&v, &bits, sizeof v);
  return v;
}

std::uintmax_t FileSize(const fs::path& path) {
  std::error_code ec;
  LN_CHECK_INPUT(fs::is_regular_file(path, ec)) << path.string() << ": no such file";
  const std::uintmax_t size = fs::file_size(path, ec);
  LN_CHECK_INPUT(!ec) << path.string() << ": cannot read its size";
  return size;
}

std::vector<Eigen::Vector3f> ReadKittiBin(const fs::path& path) {
  const std::uintmax_t size = FileSize(path);
  LN_CHECK_INPUT(size % 16 == 0) << path.string() << ": " << size
                                 << " bytes, not whole KITTI points (float32 x, y, z, reflectance: 16 bytes each)";
  LN_CHECK_INPUT(size / 16 <= static_cast<std::uintmax_t>(kMaxCloudPoints))
      << path.string() << ": more than " << kMaxCloudPoints << " points";
  std::ifstream in(path, std::ios::binary);
  LN_CHECK_INPUT(in.good()) << path.string() << ": cannot open";
  std::vector<unsigned char> bytes(static_cast<std::size_t>(size));
  in.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(size));
  LN_CHECK_INPUT(in.gcount() == static_cast<std::streamsize>(size)) << path.string() << ": cut short";
  std::vector<Eigen::Vector3f> points;
  points.reserve(bytes.size() / 16);
  for (std::size_t k = 0; k < bytes.size(); k += 16) {
    const Eigen::Vector3f p(LittleEndianFloat(&bytes[k]), LittleEndianFloat(&bytes[k + 4]),
                            LittleEndianFloat(&bytes[k + 8]));
    if (Finite(p)) points.push_back(p);
  }
  return points;
}

std::vector<Eigen::Vector3f> ReadPlyPoints(const fs::path& path) {
  const PlyPointCloud cloud = ReadPly(path);
  std::vector<Eigen::Vector3f> points;
  points.reserve(cloud.points.size());
  for (const cv::Point3f& p : cloud.points) {
    const Eigen::Vector3f v(p.x, p.y, p.z);
    if (Finite(v)) points.push_back(v);
  }
  return points;
}

// PCL's PCD: a text header (VERSION, FIELDS, SIZE, TYPE, COUNT, WIDTH, HEIGHT, VIEWPOINT,
// POINTS, DATA), then the points as text lines or packed records.
std::vector<Eigen::Vector3f> ReadPcd(const fs::path& path) {
  const std::string name = path.string();
  const std::uintmax_t file_size = FileSize(path);
  std::ifstream in(path, std::ios::binary);
  LN_CHECK_INPUT(in.good()) << name << ": cannot open";
  std::vector<std::string> fields, types;
  std::vector<int> sizes, counts;
  long long points = -1;
  std::string data, line;
  for (int number = 1; data.empty(); ++number) {
    LN_CHECK_INPUT(number <= 100 && std::getline(in, line)) << name << ": no DATA line in the PCD header";
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    std::istringstream words(line);
    words.imbue(std::locale::classic());
    std::string key, word;
    words >> key;
    const std::string where = name + ":" + std::to_string(number);
    if (key == "FIELDS") {
      while (words >> word) fields.push_back(word);
    } else if (key == "TYPE") {
      while (words >> word) types.push_back(word);
    } else if (key == "SIZE" || key == "COUNT") {
      std::vector<int>& out = key == "SIZE" ? sizes : counts;
      int v = 0;
      while (words >> v) {
        LN_CHECK_INPUT(v >= 1 && v <= 1024) << where << ": " << key << " " << v << " out of range";
        out.push_back(v);
      }
      LN_CHECK_INPUT(words.eof()) << where << ": " << key << ": expected whole numbers";
    } else if (key == "POINTS") {
      LN_CHECK_INPUT(words >> points && points >= 0 && points <= kMaxCloudPoints)
          << where << ": POINTS: expected a count up to " << kMaxCloudPoints;
    } else if (key == "DATA") {
      LN_CHECK_INPUT(words >> data) << where << ": DATA: expected ascii or binary";
      LN_CHECK_INPUT(data == "ascii" || data == "binary")
          << where << ": DATA " << data << " is not supported (ascii or binary; PCL's pcl_convert_pcd_ascii_binary "
          << "converts binary_compressed)";
    }
  }
  LN_CHECK_INPUT(fields.size() <= 256) << name << ": " << fields.size() << " fields, more than 256";
  if (counts.empty()) counts.assign(fields.size(), 1);
  LN_CHECK_INPUT(!fields.empty() && sizes.size() == fields.size() && types.size() == fields.size() &&
                 counts.size() == fields.size())
      << name << ": FIELDS, SIZE, TYPE and COUNT must list the same number of fields";
  LN_CHECK_INPUT(points >= 0) << name << ": no POINTS in the header";
  int xyz[3] = {-1, -1, -1};  // the fields' indices
  std::vector<int> offset(fields.size() + 1, 0);
  for (std::size_t i = 0; i < fields.size(); ++i) {
    offset[i + 1] = offset[i] + sizes[i] * counts[i];
    for (int a = 0; a < 3; ++a) {
      if (fields[i] == std::string(1, "xyz"[a])) xyz[a] = static_cast<int>(i);
    }
  }
  for (int a = 0; a < 3; ++a) {
    LN_CHECK_INPUT(xyz[a] >= 0) << name << ": no field "
                                << "xyz"[a];
    const std::size_t i = static_cast<std::size_t>(xyz[a]);
    LN_CHECK_INPUT(types[i] == "F" && (sizes[i] == 4 || sizes[i] == 8))
        << name << ": field " << fields[i] << ": expected TYPE F of SIZE 4 or 8";
  }
  std::vector<Eigen::Vector3f> out;
  if (data == "ascii") {
    // Each line holds the fields' values, COUNT of each, in order.
    std::vector<int> column(fields.size() + 1, 0);
    for (std::size_t i = 0; i < fields.size(); ++i) column[i + 1] = column[i] + counts[i];
    for (long long k = 0; k < points; ++k) {
      LN_CHECK_INPUT(std::getline(in, line)) << name << ": " << k << " of " << points << " points, then the file ends";
      std::istringstream values(line);
      values.imbue(std::locale::classic());
      std::vector<std::string> cells;
      std::string cell;
      while (values >> cell) cells.push_back(cell);
      LN_CHECK_INPUT(static_cast<int>(cells.size()) == column.back())
          << name << ": point " << k << ": " << cells.size() << " values, expected " << column.back();
      Eigen::Vector3f p;
      for (int a = 0; a < 3; ++a) {
        const std::string& text = cells[static_cast<std::size_t>(column[static_cast<std::size_t>(xyz[a])])];
        char* end = nullptr;
        p[a] = std::strtof(text.c_str(), &end);
        LN_CHECK_INPUT(end != text.c_str() && *end == '\0')
            << name << ": point " << k << ": '" << text << "' is not a number";
      }
      if (Finite(p)) out.push_back(p);
    }
    return out;
  }
  const std::uintmax_t record = static_cast<std::uintmax_t>(offset.back());
  const std::uintmax_t start = static_cast<std::uintmax_t>(in.tellg());
  LN_CHECK_INPUT(file_size >= start && (file_size - start) / record >= static_cast<std::uintmax_t>(points))
      << name << ": " << points << " points of " << record << " bytes declared, " << file_size - start
      << " bytes of data";
  std::vector<unsigned char> bytes(static_cast<std::size_t>(record * static_cast<std::uintmax_t>(points)));
  in.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  LN_CHECK_INPUT(in.gcount() == static_cast<std::streamsize>(bytes.size())) << name << ": cut short";
  out.reserve(static_cast<std::size_t>(points));
  for (std::size_t k = 0; k < static_cast<std::size_t>(points); ++k) {
    Eigen::Vector3f p;
    for (int a = 0; a < 3; ++a) {
      const std::size_t i = static_cast<std::size_t>(xyz[a]);
      const unsigned char* at = &bytes[k * record + static_cast<std::size_t>(offset[i])];
      p[a] = sizes[i] == 4 ? LittleEndianFloat(at) : static_cast<float>(LittleEndianDouble(at));
    }
    if (Finite(p)) out.push_back(p);
  }
  return out;
}

}  // namespace

bool HasPointCloudExtension(const fs::path& path) {
  const std::string e = path.extension().string();
  return e == ".bin" || e == ".ply" || e == ".pcd";
}

std::vector<Eigen::Vector3f> ReadPointCloud(const fs::path& path) {
  const std::string e = path.extension().string();
  if (e == ".bin") return ReadKittiBin(path);
  if (e == ".ply") return ReadPlyPoints(path);
  if (e == ".pcd") return ReadPcd(path);
  throw InputError(path.string() + ": not a point cloud this reads (.bin of KITTI's, .ply, .pcd)");
}

}  // namespace lunarnav::io
