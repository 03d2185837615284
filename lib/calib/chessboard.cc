#include "calib/chessboard.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
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
  // 1e300 m reached OpenCV's extrinsics as an assertion (exit 3, "calibration failed").
  LN_CHECK_ARG(square_size_m <= 10) << "--square: a square of at most 10 m, got " << square_size_m << " m";
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
  return CanonicalCornerOrder(board, corners);
}

std::vector<std::vector<int>> SymmetricCornerOrders(const ChessboardSpec& board) {
  const int cols = board.cols, rows = board.rows;
  // Each symmetry maps the grid position (i, j) of a new index to the one of the old list.
  using Map = std::pair<int, int> (*)(int, int, int, int);
  std::vector<Map> maps = {
      [](int i, int j, int, int) { return std::pair{i, j}; },
      [](int i, int j, int c, int r) { return std::pair{c - 1 - i, r - 1 - j}; },
      [](int i, int j, int c, int) { return std::pair{c - 1 - i, j}; },
      [](int i, int j, int, int r) { return std::pair{i, r - 1 - j}; },
  };
  if (cols == rows) {
    maps.push_back([](int i, int j, int, int) { return std::pair{j, i}; });
    maps.push_back([](int i, int j, int c, int) { return std::pair{j, c - 1 - i}; });
    maps.push_back([](int i, int j, int, int r) { return std::pair{r - 1 - j, i}; });
    maps.push_back([](int i, int j, int c, int r) { return std::pair{r - 1 - j, c - 1 - i}; });
  }
  std::vector<std::vector<int>> orders;
  for (Map map : maps) {
    std::vector<int> order(static_cast<std::size_t>(cols * rows));
    for (int j = 0; j < rows; ++j) {
      for (int i = 0; i < cols; ++i) {
        const auto [oi, oj] = map(i, j, cols, rows);
        order[static_cast<std::size_t>(j * cols + i)] = oj * cols + oi;
      }
    }
    orders.push_back(std::move(order));
  }
  return orders;
}

namespace {

std::vector<cv::Point2f> Reordered(const std::vector<cv::Point2f>& corners, const std::vector<int>& order) {
  std::vector<cv::Point2f> out(order.size());
  for (std::size_t k = 0; k < order.size(); ++k) out[k] = corners[static_cast<std::size_t>(order[k])];
  return out;
}

// Whether an order is a rotation of the grid (not a mirror image): the signed area of the
// triangle (corner 0, end of the first row, start of the second row) keeps its sign.
double Handedness(const ChessboardSpec& board, const std::vector<cv::Point2f>& c) {
  const cv::Point2f a = c[static_cast<std::size_t>(board.cols - 1)] - c[0];
  const cv::Point2f b = c[static_cast<std::size_t>(board.cols)] - c[0];
  return a.x * b.y - a.y * b.x;
}

}  // namespace

std::vector<cv::Point2f> CanonicalCornerOrder(const ChessboardSpec& board, const std::vector<cv::Point2f>& corners) {
  LN_CHECK_ARG(static_cast<int>(corners.size()) == board.CornerCount())
      << "expected " << board.CornerCount() << " corners, got " << corners.size();
  const double handedness = Handedness(board, corners);
  std::vector<cv::Point2f> best = corners;
  double best_dx = -std::numeric_limits<double>::infinity();
  for (const std::vector<int>& order : SymmetricCornerOrders(board)) {
    std::vector<cv::Point2f> candidate = Reordered(corners, order);
    if (Handedness(board, candidate) * handedness < 0) continue;  // a mirror image
    // The direction of the first row, normalised so that rows of any length compare.
    const cv::Point2f row = candidate[static_cast<std::size_t>(board.cols - 1)] - candidate[0];
    const double dx = row.x / std::max(1e-9, std::hypot(double{row.x}, double{row.y}));
    if (dx > best_dx + 1e-9) {
      best_dx = dx;
      best = std::move(candidate);
    }
  }
  return best;
}

CornerOrderMatch MatchRightCornerOrder(const ChessboardSpec& board, const std::vector<cv::Point2f>& left,
                                       const std::vector<cv::Point2f>& right, double min_ratio) {
  LN_CHECK_ARG(min_ratio > 1) << "corner order: the ratio must exceed 1";
  const std::size_t n = static_cast<std::size_t>(board.CornerCount());
  LN_CHECK_ARG(left.size() == n && right.size() == n) << "expected " << n << " corners per image";
  CornerOrderMatch match;
  double best = std::numeric_limits<double>::infinity(), second = best;
  std::vector<cv::Point2f> best_order;
  for (const std::vector<int>& order : SymmetricCornerOrders(board)) {
    std::vector<cv::Point2f> candidate = Reordered(right, order);
    std::vector<cv::Point2f> displacement(n);
    for (std::size_t k = 0; k < n; ++k) displacement[k] = candidate[k] - left[k];
    cv::Mat mean, stddev;
    cv::meanStdDev(displacement, mean, stddev);
    const double spread = std::hypot(stddev.at<double>(0), stddev.at<double>(1));
    if (spread < best) {
      second = best;
      best = spread;
      best_order = std::move(candidate);
    } else if (spread < second) {
      second = spread;
    }
  }
  match.spread_px = best;
  match.runner_up_spread_px = second;
  if (!(second >= min_ratio * best)) {
    char text[200];
    std::snprintf(text, sizeof(text),
                  "board orientation undecided: the corner displacements between the images spread by %.1f px "
                  "in the best order and %.1f px in the next (needs a factor %.1f)",
                  best, second, min_ratio);
    match.reason = text;
    return match;
  }
  match.right = std::move(best_order);
  return match;
}

}  // namespace lunarnav::calib
