// OpenCV's calibration files (cv::FileStorage's YAML, XML and JSON, as OpenCV's stereo_calib
// sample and users' scripts write them) read without OpenCV's parser: its recursive parsers
// died (SIGSEGV) or looped on hostile text, and a scanner of our own in front of them
// disagreed with them. Each form is read by a parser that bounds its own depth: yaml-cpp (its
// depth guard), expat (a stream parser; the reader stops it past kMaxDepth) and nlohmann-json
// (a depth callback); the matrices are then built from what was read, each checked before
// anything is allocated.
#pragma once

#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace lunarnav::calib {

/// The top-level nodes of an OpenCV FileStorage text, as read: each node's fields (rows,
/// cols, data ...) as texts, for the matrices a caller asks for.
class OpenCvStorage {
 public:
  /// The deepest nesting read (a matrix is three levels deep in XML).
  static constexpr int kMaxDepth = 64;

  /// Parses `text` (XML when its first character, after blanks and a byte-order mark, is
  /// '<'; JSON when '{'; YAML otherwise, its `%YAML:1.0` directive allowed).
  /// @throws InputError naming `file` (and the line where the parser says) when the text is
  ///         not such a file, or nests more than kMaxDepth levels.
  static OpenCvStorage Parse(const std::string& text, const std::string& file);

  /// The matrix `name` (an opencv-matrix: rows, cols and as many data values, 1 to 16 each
  /// way), double, row-major, the values as written whatever `dt` declares; empty when the
  /// file has no such node and it is not `required`.
  /// @throws InputError naming the file and the matrix when it is missing but required, not a
  ///         matrix, of another size than its data, or holds a value that is not a number.
  cv::Mat Matrix(const std::string& name, bool required) const;

 private:
  struct Node {
    bool is_map = false;
    std::map<std::string, std::string> scalars;  ///< rows, cols, dt, data when a scalar
    bool data_is_sequence = false;
    std::vector<std::string> data;               ///< data's elements ("" for one that is no scalar)
  };
  std::string file_;
  std::map<std::string, Node> nodes_;
};

}  // namespace lunarnav::calib
