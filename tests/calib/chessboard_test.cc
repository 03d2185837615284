#include "calib/chessboard.h"

#include <gtest/gtest.h>

#include <algorithm>

#include <opencv2/imgproc.hpp>

namespace lunarnav::calib {
namespace {

// A fronto-parallel board of `spec` drawn with square side `square_px` pixels, its first
// inner corner at `origin` (pixel centres at integers: a square covering pixels [a, a + s)
// has its edges at a - 0.5 and a + s - 0.5). Also returns the exact corners in board order.
cv::Mat DrawBoard(const ChessboardSpec& spec, int square_px, cv::Point origin, std::vector<cv::Point2d>* corners) {
  cv::Mat image(240, 320, CV_8UC1, cv::Scalar(200));
  for (int j = -1; j < spec.rows; ++j) {
    for (int i = -1; i < spec.cols; ++i) {
      if ((i + j) % 2 != 0) continue;  // the square up-left of corner 0 is black, as in OpenCV's pattern
      cv::rectangle(image, cv::Rect(origin.x + i * square_px, origin.y + j * square_px, square_px, square_px),
                    cv::Scalar(30), cv::FILLED);
    }
  }
  cv::GaussianBlur(image, image, cv::Size(0, 0), 0.8);
  corners->clear();
  for (int j = 0; j < spec.rows; ++j) {
    for (int i = 0; i < spec.cols; ++i) {
      corners->emplace_back(origin.x + i * square_px - 0.5, origin.y + j * square_px - 0.5);
    }
  }
  return image;
}

TEST(ChessboardSpec, ObjectPointsAreInDetectionOrder) {
  ChessboardSpec spec{9, 6, 0.05};
  const std::vector<cv::Point3f> points = spec.ObjectPointsM();
  ASSERT_EQ(points.size(), 54u);
  EXPECT_FLOAT_EQ(points[1].x, 0.05f);   // along a row first
  EXPECT_FLOAT_EQ(points[9].y, 0.05f);   // then the next row
  EXPECT_FLOAT_EQ(points[53].x, 0.4f);
  EXPECT_FLOAT_EQ(points[53].y, 0.25f);
  EXPECT_NO_THROW(spec.Validate());
  EXPECT_THROW((ChessboardSpec{2, 6, 0.1}.Validate()), std::invalid_argument);
  EXPECT_THROW((ChessboardSpec{9, 6, 0.0}.Validate()), std::invalid_argument);
  EXPECT_THROW((ChessboardSpec{9, 6, 1e300}.Validate()), std::invalid_argument);  // OpenCV asserted on it
}

TEST(DetectChessboardCorners, FindsTheCornersToASmallFractionOfAPixel) {
  const ChessboardSpec spec;
  std::vector<cv::Point2d> exact;
  const cv::Mat image = DrawBoard(spec, 20, cv::Point(50, 40), &exact);
  const auto found = DetectChessboardCorners(image, spec);
  ASSERT_TRUE(found.has_value());
  ASSERT_EQ(found->size(), exact.size());
  for (std::size_t i = 0; i < exact.size(); ++i) {
    EXPECT_LT(cv::norm(cv::Point2d((*found)[i]) - exact[i]), 0.1) << i;
  }
  // 16-bit images are scaled to 8 bits first.
  cv::Mat wide;
  image.convertTo(wide, CV_16U, 257.0);
  const auto found16 = DetectChessboardCorners(wide, spec);
  ASSERT_TRUE(found16.has_value());
  EXPECT_LT(cv::norm((*found16)[0] - (*found)[0]), 1e-3);
}

TEST(DetectChessboardCorners, OrdersTheCornersLeftToRightTopToBottomForAnUpsideDownBoard) {
  const ChessboardSpec spec;
  std::vector<cv::Point2d> exact;
  cv::Mat image = DrawBoard(spec, 20, cv::Point(50, 40), &exact);
  cv::rotate(image, image, cv::ROTATE_180);  // the board turned by 180 deg: same image ordering
  const auto found = DetectChessboardCorners(image, spec);
  ASSERT_TRUE(found.has_value());
  for (std::size_t i = 0; i < exact.size(); ++i) {
    // Pixel p maps to (W - 1 - p.x, H - 1 - p.y); the corners are then listed from the
    // rotated last corner, so that the first row still runs left to right, top row first.
    const cv::Point2d rotated(319 - exact[exact.size() - 1 - i].x, 239 - exact[exact.size() - 1 - i].y);
    EXPECT_LT(cv::norm(cv::Point2d((*found)[i]) - rotated), 0.1) << i;
  }
  EXPECT_LT((*found)[0].x, (*found)[8].x);
  EXPECT_LT((*found)[0].y, (*found)[9].y);
}

// A board's corners seen fronto-parallel: column i, row j at origin + step * (i, j).
std::vector<cv::Point2f> Grid(const ChessboardSpec& spec, cv::Point2f origin, float step) {
  std::vector<cv::Point2f> corners;
  for (int j = 0; j < spec.rows; ++j) {
    for (int i = 0; i < spec.cols; ++i) corners.push_back(origin + step * cv::Point2f(i, j));
  }
  return corners;
}

TEST(SymmetricCornerOrders, AreTheGridsSymmetriesIdentityFirst) {
  const ChessboardSpec spec;  // 9 x 6: four orders
  const std::vector<std::vector<int>> orders = SymmetricCornerOrders(spec);
  ASSERT_EQ(orders.size(), 4u);
  for (int k = 0; k < 54; ++k) EXPECT_EQ(orders[0][k], k);
  EXPECT_EQ(orders[1][0], 53);  // the 180-degree turn starts at the last corner
  EXPECT_EQ(orders[2][0], 8);   // a mirror image starts at the end of the first row
  EXPECT_EQ(orders[3][0], 45);  // the other at the start of the last row
  for (const std::vector<int>& order : orders) {
    std::vector<int> sorted = order;
    std::sort(sorted.begin(), sorted.end());
    for (int k = 0; k < 54; ++k) ASSERT_EQ(sorted[k], k);  // a permutation
  }
  EXPECT_EQ(SymmetricCornerOrders(ChessboardSpec{5, 5, 0.1}).size(), 8u);
}

TEST(CanonicalCornerOrder, PointsTheFirstRowRightwardsWithoutMirroring) {
  const ChessboardSpec spec;
  const std::vector<cv::Point2f> upright = Grid(spec, {40, 30}, 20);
  std::vector<cv::Point2f> turned(upright.rbegin(), upright.rend());
  const std::vector<cv::Point2f> canonical = CanonicalCornerOrder(spec, turned);
  for (std::size_t k = 0; k < upright.size(); ++k) EXPECT_EQ(canonical[k], upright[k]) << k;
}

TEST(MatchRightCornerOrder, RestoresTheLeftOrderFromAnySymmetricOrder) {
  const ChessboardSpec spec;
  std::vector<cv::Point2f> left = Grid(spec, {200, 100}, 25);
  // The board turned 90 deg in the image (rows vertical), as held near-vertical.
  for (cv::Point2f& p : left) p = cv::Point2f(400 - (p.y - 100), 100 + (p.x - 200));
  // The right image: shifted by a disparity that varies a little over the board (tilt).
  std::vector<cv::Point2f> right;
  for (const cv::Point2f& p : left) right.push_back(p + cv::Point2f(-120 - 0.1f * (p.y - 100), 0.3f));
  for (const std::vector<int>& order : SymmetricCornerOrders(spec)) {
    std::vector<cv::Point2f> detected;
    for (int k : order) detected.push_back(right[static_cast<std::size_t>(k)]);
    const CornerOrderMatch match = MatchRightCornerOrder(spec, left, detected);
    ASSERT_TRUE(match.right.has_value()) << match.reason;
    for (std::size_t k = 0; k < right.size(); ++k) EXPECT_EQ((*match.right)[k], right[k]) << k;
    EXPECT_LT(match.spread_px, 10.0);
    EXPECT_GT(match.runner_up_spread_px, 2 * match.spread_px);
  }
  // A right board shrunk to a tenth: no order is clearly right.
  std::vector<cv::Point2f> collapsed;
  for (const cv::Point2f& p : left) collapsed.push_back(cv::Point2f(300, 200) + 0.1f * (p - cv::Point2f(300, 200)));
  const CornerOrderMatch undecided = MatchRightCornerOrder(spec, left, collapsed);
  EXPECT_FALSE(undecided.right.has_value());
  EXPECT_NE(undecided.reason.find("orientation undecided"), std::string::npos);
}

TEST(DetectChessboardCorners, ReturnsNothingWithoutABoard) {
  const ChessboardSpec spec;
  std::vector<cv::Point2d> exact;
  const cv::Mat image = DrawBoard(spec, 20, cv::Point(50, 40), &exact);
  EXPECT_FALSE(DetectChessboardCorners(cv::Mat(240, 320, CV_8UC1, cv::Scalar(128)), spec).has_value());
  // A board with other dimensions is not this one.
  EXPECT_FALSE(DetectChessboardCorners(image, ChessboardSpec{10, 6, 0.1}).has_value());
}

}  // namespace
}  // namespace lunarnav::calib
