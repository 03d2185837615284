#include "calib/opencv_storage.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <sstream>

#include <expat.h>
#include <nlohmann/json.hpp>
#include <yaml-cpp/depthguard.h>
#include <yaml-cpp/yaml.h>

#include "util/check.h"
#include "util/errors.h"

namespace lunarnav::calib {
namespace {

// The largest matrix of a calibration file: 3x4 (P1, P2) or a distortion vector of up to 14
// coefficients (OpenCV's rational, thin-prism and tilted models) in either orientation.
constexpr int kMaxMatrixSide = 16;

std::string Trimmed(const std::string& s) {
  const std::size_t a = s.find_first_not_of(" \t\r\n");
  if (a == std::string::npos) return "";
  return s.substr(a, s.find_last_not_of(" \t\r\n") - a + 1);
}

// A whole text as an integer / a finite number, or nothing.
bool ParseInt(const std::string& text, long* out) {
  const std::string t = Trimmed(text);
  if (t.empty()) return false;
  char* end = nullptr;
  errno = 0;
  const long v = std::strtol(t.c_str(), &end, 10);
  if (errno != 0 || end != t.c_str() + t.size()) return false;
  *out = v;
  return true;
}
bool ParseNumber(const std::string& text, double* out) {
  const std::string t = Trimmed(text);
  if (t.empty()) return false;
  std::istringstream in(t);
  in.imbue(std::locale::classic());
  double v = 0;
  in >> v;
  if (in.fail() || !in.eof() || !std::isfinite(v)) {
    // strtod's forms the stream does not take ("1." is taken; hex and inf are not numbers here).
    char* end = nullptr;
    v = std::strtod(t.c_str(), &end);
    if (end != t.c_str() + t.size() || !std::isfinite(v)) return false;
  }
  *out = v;
  return true;
}

// XML through expat: the root element, its children (the nodes), their children (fields).
struct XmlReader {
  XML_Parser parser = nullptr;
  int depth = 0;
  bool too_deep = false;
  std::string node, field, text;
  std::map<std::string, std::string>* fields = nullptr;
  std::function<void(const std::string&)> begin_node;
  std::function<void(const std::string&, const std::string&)> end_field;

  static void Start(void* self, const XML_Char* name, const XML_Char**) {
    auto* r = static_cast<XmlReader*>(self);
    if (++r->depth > OpenCvStorage::kMaxDepth) {
      r->too_deep = true;
      XML_StopParser(r->parser, XML_FALSE);
      return;
    }
    if (r->depth == 2) {
      r->node = name;
      r->begin_node(r->node);
    } else if (r->depth == 3) {
      r->field = name;
    }
    r->text.clear();
  }
  static void End(void* self, const XML_Char*) {
    auto* r = static_cast<XmlReader*>(self);
    if (r->depth == 3) r->end_field(r->field, r->text);
    r->text.clear();
    --r->depth;
  }
  static void Text(void* self, const XML_Char* s, int n) {
    auto* r = static_cast<XmlReader*>(self);
    if (r->depth == 3) r->text.append(s, static_cast<std::size_t>(n));
  }
};

}  // namespace

OpenCvStorage OpenCvStorage::Parse(const std::string& text, const std::string& file) {
  OpenCvStorage storage;
  storage.file_ = file;
  const std::size_t first = text.find_first_not_of(" \t\r\n\xEF\xBB\xBF");
  LN_CHECK_INPUT(first != std::string::npos) << file << ": empty (not an OpenCV YAML/XML/JSON file)";
  auto& nodes = storage.nodes_;
  if (text[first] == '<') {
    XmlReader r;
    r.parser = XML_ParserCreate("UTF-8");
    LN_CHECK(r.parser != nullptr) << "expat: cannot create a parser";
    r.begin_node = [&](const std::string& name) { nodes[name] = Node{}; };
    r.end_field = [&](const std::string& name, const std::string& value) {
      Node& n = nodes[r.node];
      n.is_map = true;
      if (name == "data") {
        n.data_is_sequence = true;
        n.data.clear();
        std::istringstream words(value);
        for (std::string w; words >> w;) n.data.push_back(w);
      } else {
        n.scalars[name] = value;
      }
    };
    XML_SetUserData(r.parser, &r);
    XML_SetElementHandler(r.parser, &XmlReader::Start, &XmlReader::End);
    XML_SetCharacterDataHandler(r.parser, &XmlReader::Text);
    const XML_Status status = XML_Parse(r.parser, text.data(), static_cast<int>(text.size()), XML_TRUE);
    const long line = static_cast<long>(XML_GetCurrentLineNumber(r.parser));
    const XML_LChar* message = XML_ErrorString(XML_GetErrorCode(r.parser));
    const std::string reason = message != nullptr ? message : "";
    XML_ParserFree(r.parser);
    LN_CHECK_INPUT(!r.too_deep) << file << ": line " << line << ": nested more than " << kMaxDepth
                                << " levels (not an OpenCV XML file)";
    LN_CHECK_INPUT(status == XML_STATUS_OK) << file << ": line " << line << ": not an OpenCV XML file (" << reason
                                            << ")";
    return storage;
  }
  if (text[first] == '{') {
    nlohmann::json j;
    try {
      j = nlohmann::json::parse(text, [&](int depth, nlohmann::json::parse_event_t, nlohmann::json&) {
        LN_CHECK_INPUT(depth <= kMaxDepth) << file << ": nested more than " << kMaxDepth
                                           << " levels (not an OpenCV JSON file)";
        return true;
      });
    } catch (const nlohmann::json::exception& e) {
      throw InputError(file + ": not an OpenCV JSON file (" + e.what() + ")");
    }
    LN_CHECK_INPUT(j.is_object()) << file << ": not an OpenCV JSON file (not an object)";
    for (const auto& [key, value] : j.items()) {
      Node n;
      n.is_map = value.is_object();
      if (n.is_map) {
        for (const auto& [field, v] : value.items()) {
          if (field == "data" && v.is_array()) {
            n.data_is_sequence = true;
            for (const auto& e : v) n.data.push_back(e.is_number() ? e.dump() : std::string());
          } else if (v.is_number()) {
            n.scalars[field] = v.dump();
          } else if (v.is_string()) {
            n.scalars[field] = v.get<std::string>();
          }
        }
      }
      nodes[key] = n;
    }
    return storage;
  }
  // YAML: OpenCV's `%YAML:1.0` directive is YAML 1.0's (yaml-cpp reads 1.2's): directive lines
  // are blanked, so that the parser's line numbers stay the file's.
  std::string yaml = text;
  for (std::size_t begin = 0; begin < yaml.size();) {
    std::size_t end = yaml.find('\n', begin);
    if (end == std::string::npos) end = yaml.size();
    if (yaml[begin] == '%') yaml.replace(begin, end - begin, std::string(end - begin, ' '));
    begin = end + 1;
  }
  YAML::Node root;
  try {
    root = YAML::Load(yaml);
  } catch (const YAML::DeepRecursion& e) {
    throw InputError(file + ": line " + std::to_string(e.mark.line + 1) + ": nested more than yaml-cpp's " +
                     std::to_string(e.depth()) + " levels (not an OpenCV YAML file)");
  } catch (const YAML::Exception& e) {
    throw InputError(file + ": line " + std::to_string(e.mark.line + 1) + ": not an OpenCV YAML file (" + e.msg +
                     ")");
  }
  LN_CHECK_INPUT(root.IsMap()) << file << ": not an OpenCV YAML file (its top level is not 'name: value' lines)";
  try {
    for (const auto& entry : root) {
      if (!entry.first.IsScalar()) continue;
      const YAML::Node& value = entry.second;
      Node n;
      n.is_map = value.IsMap();
      if (n.is_map) {
        for (const auto& f : value) {
          if (!f.first.IsScalar()) continue;
          const std::string field = f.first.Scalar();
          if (field == "data" && f.second.IsSequence()) {
            n.data_is_sequence = true;
            for (const auto& e : f.second) n.data.push_back(e.IsScalar() ? e.Scalar() : std::string());
          } else if (f.second.IsScalar()) {
            n.scalars[field] = f.second.Scalar();
          }
        }
      }
      nodes[entry.first.Scalar()] = n;
    }
  } catch (const YAML::Exception& e) {
    throw InputError(file + ": not an OpenCV YAML file (" + e.msg + ")");
  }
  return storage;
}

cv::Mat OpenCvStorage::Matrix(const std::string& name, bool required) const {
  const std::string what = file_ + ": matrix '" + name + "'";
  const auto it = nodes_.find(name);
  if (it == nodes_.end()) {
    LN_CHECK_INPUT(!required) << file_ << ": missing matrix '" << name << "'";
    return {};
  }
  const Node& n = it->second;
  LN_CHECK_INPUT(n.is_map) << what << ": expected an opencv-matrix (rows, cols, dt, data)";
  long r = 0, c = 0;
  const auto rows = n.scalars.find("rows"), cols = n.scalars.find("cols");
  LN_CHECK_INPUT(rows != n.scalars.end() && cols != n.scalars.end() && ParseInt(rows->second, &r) &&
                 ParseInt(cols->second, &c))
      << what << ": rows and cols must be integers";
  LN_CHECK_INPUT(r >= 1 && c >= 1 && r <= kMaxMatrixSide && c <= kMaxMatrixSide)
      << what << ": " << r << " x " << c << " is not the size of a calibration matrix (1.." << kMaxMatrixSide
      << " rows and columns)";
  const auto scalar_data = n.scalars.find("data");
  LN_CHECK_INPUT(n.data_is_sequence || (r * c == 1 && scalar_data != n.scalars.end()))
      << what << ": data must be a list of numbers";
  const std::vector<std::string> values =
      n.data_is_sequence ? n.data : std::vector<std::string>{scalar_data->second};
  LN_CHECK_INPUT(static_cast<long>(values.size()) == r * c)
      << what << ": " << r << " x " << c << " needs " << r * c << " values, data has " << values.size();
  cv::Mat m(static_cast<int>(r), static_cast<int>(c), CV_64F);
  for (std::size_t i = 0; i < values.size(); ++i) {
    double v = 0;
    LN_CHECK_INPUT(ParseNumber(values[i], &v)) << what << ": value " << i + 1 << " is not a number";
    m.at<double>(static_cast<int>(i)) = v;
  }
  return m;
}

}  // namespace lunarnav::calib
