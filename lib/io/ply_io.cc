#include "io/ply_io.h"

#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <system_error>

#include "io/atomic_file.h"
#include "util/check.h"

namespace lunarnav::io {
namespace fs = std::filesystem;

namespace {

// Appends the little-endian bytes of a float.
void AppendFloat(float value, std::string* out) {
  std::uint32_t bits;
  std::memcpy(&bits, &value, sizeof bits);
  for (int k = 0; k < 4; ++k) out->push_back(static_cast<char>((bits >> (8 * k)) & 0xFFu));
}

bool Finite(const cv::Vec3f& p) { return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]); }

// Bytes of a PLY scalar type, 0 for an unknown name.
int ScalarSize(const std::string& type) {
  static const std::map<std::string, int> kSizes = {
      {"char", 1},   {"uchar", 1},  {"int8", 1},   {"uint8", 1},   {"short", 2},   {"ushort", 2},
      {"int16", 2},  {"uint16", 2}, {"int", 4},    {"uint", 4},    {"int32", 4},   {"uint32", 4},
      {"float", 4},  {"float32", 4}, {"double", 8}, {"float64", 8}};
  const auto it = kSizes.find(type);
  return it == kSizes.end() ? 0 : it->second;
}

double ReadLittleEndian(const unsigned char* p, const std::string& type) {
  const int size = ScalarSize(type);
  std::uint64_t bits = 0;
  for (int k = 0; k < size; ++k) bits |= std::uint64_t{p[k]} << (8 * k);
  if (type == "float" || type == "float32") {
    const auto b = static_cast<std::uint32_t>(bits);
    float f;
    std::memcpy(&f, &b, sizeof f);
    return f;
  }
  if (type == "double" || type == "float64") {
    double d;
    std::memcpy(&d, &bits, sizeof d);
    return d;
  }
  const bool is_signed = type == "char" || type == "int8" || type == "short" || type == "int16" ||
                         type == "int" || type == "int32";
  if (is_signed && size < 8 && (bits >> (8 * size - 1)) != 0) {
    return static_cast<double>(static_cast<std::int64_t>(bits | (~std::uint64_t{0} << (8 * size))));
  }
  return static_cast<double>(bits);
}

}  // namespace

std::int64_t WritePlyAtomic(const fs::path& path, const cv::Mat& xyz, const cv::Mat& colour,
                            const std::vector<std::string>& comments) {
  LN_CHECK_ARG(xyz.type() == CV_32FC3) << path.string() << ": PLY output needs a CV_32FC3 XYZ map";
  LN_CHECK_ARG(colour.empty() || ((colour.type() == CV_8UC1 || colour.type() == CV_8UC3) &&
                                  colour.size() == xyz.size()))
      << path.string() << ": the colour image must be 8-bit grey or RGB of the XYZ map's size";
  for (const std::string& c : comments) {
    LN_CHECK_ARG(c.find_first_of("\r\n") == std::string::npos) << "PLY comment with a line break";
  }
  std::int64_t count = 0;
  for (int y = 0; y < xyz.rows; ++y) {
    const cv::Vec3f* row = xyz.ptr<cv::Vec3f>(y);
    for (int x = 0; x < xyz.cols; ++x) count += Finite(row[x]);
  }

  std::ostringstream header;
  header << "ply\nformat binary_little_endian 1.0\n";
  for (const std::string& c : comments) header << "comment " << c << "\n";
  header << "element vertex " << count << "\nproperty float x\nproperty float y\nproperty float z\n";
  if (!colour.empty()) header << "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  header << "end_header\n";

  AtomicOutputFile file(path);
  file.Write(header.str());
  std::string buffer;
  const std::size_t record = colour.empty() ? 12 : 15;
  buffer.reserve(static_cast<std::size_t>(xyz.cols) * record);
  for (int y = 0; y < xyz.rows; ++y) {
    buffer.clear();
    const cv::Vec3f* row = xyz.ptr<cv::Vec3f>(y);
    for (int x = 0; x < xyz.cols; ++x) {
      if (!Finite(row[x])) continue;
      for (int k = 0; k < 3; ++k) AppendFloat(row[x][k], &buffer);
      if (colour.empty()) continue;
      if (colour.type() == CV_8UC1) {
        buffer.append(3, static_cast<char>(colour.at<std::uint8_t>(y, x)));
      } else {
        const cv::Vec3b c = colour.at<cv::Vec3b>(y, x);
        for (int k = 0; k < 3; ++k) buffer.push_back(static_cast<char>(c[k]));
      }
    }
    file.Write(buffer);
  }
  file.Commit();
  return count;
}

PlyPointCloud ReadPly(const fs::path& path) {
  const std::string name = path.string();
  std::ifstream in(path, std::ios::binary);
  LN_CHECK_INPUT(in.good()) << name << ": cannot open";
  std::string line;
  LN_CHECK_INPUT(std::getline(in, line) && line == "ply") << name << ": not a PLY file";
  struct Property {
    std::string type, name;
  };
  PlyPointCloud cloud;
  std::vector<Property> vertex_properties;
  std::int64_t vertex_count = -1;
  bool in_vertex = false, format_ok = false;
  int line_number = 1;
  while (true) {
    LN_CHECK_INPUT(std::getline(in, line)) << name << ": header has no end_header";
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream words(line);
    std::string keyword;
    words >> keyword;
    if (keyword == "end_header") break;
    if (keyword == "format") {
      std::string format, version;
      words >> format >> version;
      LN_CHECK_INPUT(format == "binary_little_endian")
          << name << ":" << line_number << ": format " << format << " is not supported (binary_little_endian only)";
      format_ok = true;
    } else if (keyword == "comment") {
      cloud.comments.push_back(line.size() > 8 ? line.substr(8) : "");
    } else if (keyword == "element") {
      std::string element;
      std::int64_t count = -1;
      words >> element >> count;
      LN_CHECK_INPUT(count >= 0) << name << ":" << line_number << ": bad element count";
      LN_CHECK_INPUT(vertex_count < 0 || element != "vertex") << name << ":" << line_number << ": two vertex elements";
      // Elements after the vertices are never read; elements before them would have to be skipped.
      LN_CHECK_INPUT(element == "vertex" || vertex_count >= 0)
          << name << ":" << line_number << ": element " << element << " before the vertices is not supported";
      in_vertex = element == "vertex";
      if (in_vertex) vertex_count = count;
    } else if (keyword == "property") {
      if (!in_vertex) continue;
      Property p;
      words >> p.type >> p.name;
      LN_CHECK_INPUT(p.type != "list") << name << ":" << line_number << ": list properties of vertices are not supported";
      LN_CHECK_INPUT(ScalarSize(p.type) > 0) << name << ":" << line_number << ": unknown property type " << p.type;
      vertex_properties.push_back(p);
    } else if (keyword != "obj_info" && !keyword.empty()) {
      throw InputError(name + ":" + std::to_string(line_number) + ": unexpected header line '" + line + "'");
    }
  }
  LN_CHECK_INPUT(format_ok) << name << ": header has no format line";
  LN_CHECK_INPUT(vertex_count >= 0) << name << ": no vertex element";
  std::map<std::string, std::size_t> offset;
  std::map<std::string, std::string> type;
  std::size_t record = 0;
  for (const Property& p : vertex_properties) {
    offset[p.name] = record;
    type[p.name] = p.type;
    record += static_cast<std::size_t>(ScalarSize(p.type));
  }
  for (const char* axis : {"x", "y", "z"}) {
    LN_CHECK_INPUT(offset.count(axis) != 0) << name << ": vertices have no " << axis << " property";
  }
  const bool has_colour = offset.count("red") && offset.count("green") && offset.count("blue");
  // What the header announces must be in the file before anything is allocated for it.
  std::error_code ec;
  const std::uintmax_t file_bytes = fs::file_size(path, ec);
  const std::streamoff header_bytes = in.tellg();
  const std::uintmax_t body_bytes =
      ec || header_bytes < 0 || file_bytes < static_cast<std::uintmax_t>(header_bytes) ? 0 : file_bytes - header_bytes;
  LN_CHECK_INPUT(static_cast<std::uintmax_t>(vertex_count) <= body_bytes / std::max<std::size_t>(record, 1))
      << name << ": truncated (" << vertex_count << " vertices of " << record << " bytes announced, " << body_bytes
      << " bytes after the header)";
  std::vector<unsigned char> bytes(record * static_cast<std::size_t>(vertex_count));
  in.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  LN_CHECK_INPUT(in.gcount() == static_cast<std::streamsize>(bytes.size()))
      << name << ": truncated (" << vertex_count << " vertices of " << record << " bytes announced)";
  cloud.points.reserve(static_cast<std::size_t>(vertex_count));
  for (std::int64_t i = 0; i < vertex_count; ++i) {
    const unsigned char* r = bytes.data() + static_cast<std::size_t>(i) * record;
    auto get = [&](const char* field) { return ReadLittleEndian(r + offset[field], type[field]); };
    cloud.points.emplace_back(static_cast<float>(get("x")), static_cast<float>(get("y")),
                              static_cast<float>(get("z")));
    if (has_colour) {
      cloud.colours.emplace_back(static_cast<std::uint8_t>(get("red")), static_cast<std::uint8_t>(get("green")),
                                 static_cast<std::uint8_t>(get("blue")));
    }
  }
  return cloud;
}

}  // namespace lunarnav::io
