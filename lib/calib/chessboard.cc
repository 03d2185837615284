#include "calib/chessboard.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "util/check.h"

namespace lunarnav::calib {

void ChessboardSpec::Validate() const {
  LN_CHECK_ARG(cols >= 3 && rows >= 3 && cols <= 100 && rows <= 100)
      << "--board: expected COLSxROWS inner corners, each 3..100, got " << cols << "x" << rows;
  LN_CHECK_ARG(std::isfinite(square_size_m) && square_size_m > 0)
      << "--square: the square size must be positive (metres), got " << square_size_m;
}

std::vector<cv::Point3f> ChessboardSpec::ObjectPointsM() const {
  std::vector<cv::Point3f> points;
  points.reserve(static_cast<std::size_t>(CornerCount()));
  for (int j = 0; j < rows; ++j) {
    for (int i = 0; i < cols; ++i) {
      points.emplace_back(static_cast<float>(i * square_size_m), static_cast<float>(j * square_size_m), 0.0f);
    }
  }
  return points;
}

nlohmann::json ChessboardSpec::ToJson() const {
  return {{"inner_corners", {cols, rows}}, {"square_size_m", square_size_m}};
}

std::optional<std::vector<cv::Point2f>> DetectChessboardCorners(const cv::Mat& image,
                                                                const ChessboardSpec& board) {
  LN_CHECK(image.type() == CV_8UC1 || image.type() == CV_16UC1) << "expected a grey 8- or 16-bit image";
  cv::Mat grey = image;
  if (image.depth() == CV_16U) image.convertTo(grey, CV_8U, 1.0 / 257.0);
  const cv::Size pattern(board.cols, board.rows);
  std::vector<cv::Point2f> corners;
  const int flags = cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_FAST_CHECK;
  if (!cv::findChessboardCorners(grey, pattern, corners, flags) ||
      static_cast<int>(corners.size()) != board.CornerCount()) {
    return std::nullopt;
  }
  // The refinement window must stay inside the four squares around a corner.
  double spacing = std::numeric_limits<double>::infinity();
  for (int j = 0; j < board.rows; ++j) {
    for (int i = 0; i < board.cols; ++i) {
      const cv::Point2f& c = corners[static_cast<std::size_t>(j * board.cols + i)];
      if (i + 1 < board.cols) spacing = std::min(spacing, cv::norm(corners[j * board.cols + i + 1] - c));
      if (j + 1 < board.rows) spacing = std::min(spacing, cv::norm(corners[(j + 1) * board.cols + i] - c));
    }
  }
  const int half = std::clamp(static_cast<int>(spacing / 3.0), 2, 5);
  cv::cornerSubPix(grey, corners, cv::Size(half, half), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-4));
  if (corners[static_cast<std::size_t>(board.cols - 1)].x < corners[0].x) {
    std::reverse(corners.begin(), corners.end());
  }
  return corners;
}

}  // namespace lunarnav::calib
