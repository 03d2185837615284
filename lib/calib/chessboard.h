// The planar chessboard target of `calibrate`: its geometry and the detection of its inner
// corners in an image (OpenCV's findChessboardCorners, refined by cornerSubPix).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

namespace lunarnav::calib {

/// A chessboard of `cols` x `rows` inner corners (a 9x6 board has 10 x 7 squares).
///
/// Board frame: origin at the first inner corner, x along a row of `cols` corners, y along a
/// column of `rows` corners, z = 0 on the board. Corner k = j * cols + i (row j, column i)
/// lies at (i s, j s, 0) for square size s; this is the order findChessboardCorners returns.
struct ChessboardSpec {
  int cols = 9;                ///< Inner corners per row, >= 3.
  int rows = 6;                ///< Inner corners per column, >= 3.
  double square_size_m = 0.1;  ///< Side of one square, metres, > 0.

  /// @throws std::invalid_argument naming the option (--board, --square).
  void Validate() const;
  int CornerCount() const { return cols * rows; }
  /// The inner corners in the board frame, metres, in detection order.
  std::vector<cv::Point3f> ObjectPointsM() const;
  nlohmann::json ToJson() const;
};

/// Finds the board's inner corners in a grey image and refines them to sub-pixel accuracy.
///
/// findChessboardCorners with adaptive thresholding, image normalisation and the fast check
/// (which rejects images without a board quickly), then cornerSubPix with a window of
/// half-size 5 px shrunk to a third of the smallest corner spacing for small boards, so the
/// window never reaches the next corner. 16-bit images are scaled to 8 bits first.
/// Corners are returned in the order CanonicalCornerOrder gives (the first row's direction
/// pointing as far to the image's right as the board's symmetries allow). That order is
/// only a convention for one image: MatchRightCornerOrder puts the two images of a view in
/// one order, whatever the board's in-plane rotation.
/// @param image  CV_8UC1 or CV_16UC1.
/// @return the corners in pixels (centres at integers), in board order; std::nullopt when the
///         board is not found completely.
std::optional<std::vector<cv::Point2f>> DetectChessboardCorners(const cv::Mat& image,
                                                                const ChessboardSpec& board);

/// The orderings of the corner grid that map the board onto itself: corner k of the
/// reordered list is corner order[k] of the original. For a board of cols != rows there are
/// four (the identity, the 180-degree turn, and the two mirror images, which OpenCV's
/// detector can return for a board seen from behind or when the colours of its corner
/// squares do not fix the start); for a square board eight (with the quarter turns and the
/// transposes). The identity comes first.
std::vector<std::vector<int>> SymmetricCornerOrders(const ChessboardSpec& board);

/// `corners` put in the one of the board's rotations (identity or 180 deg, and the quarter
/// turns of a square board; never a mirror image) whose first row points most nearly along
/// the image's +x. For a board seen near-vertical the choice is arbitrary but harmless:
/// calibration gives every view its own pose, so only the two images of one view must
/// agree (MatchRightCornerOrder).
std::vector<cv::Point2f> CanonicalCornerOrder(const ChessboardSpec& board, const std::vector<cv::Point2f>& corners);

/// How the right image's corners were matched to the left image's.
struct CornerOrderMatch {
  /// The right image's corners in the left image's order (the same physical corner at the
  /// same index); std::nullopt when the order cannot be decided (then `reason` says why).
  std::optional<std::vector<cv::Point2f>> right;
  std::string reason;
  /// The spread (RMS about their mean, pixels) of the left-to-right corner displacements for
  /// the chosen order and for the best other symmetric order.
  double spread_px = 0, runner_up_spread_px = 0;
};

/// Puts the right image's corners of a stereo view in the left image's order.
///
/// The two cameras of a stereo rig look the same way from nearby points, so the same
/// physical corner moves between the images by a displacement (the disparity, plus a little
/// for the rotation between the cameras) that varies slowly over the board; any other
/// symmetric order pairs each corner with its image in another part of the board, and its
/// displacements spread over the board's extent. The order of SymmetricCornerOrders with the
/// smallest spread of displacements (RMS about their mean) is chosen. It is refused as
/// undecidable when the runner-up's spread is less than `min_ratio` times the chosen one's
/// (a board seen so obliquely, or so near, that the disparity varies across it by as much
/// as its own size).
/// @param min_ratio  > 1; 2 by default.
CornerOrderMatch MatchRightCornerOrder(const ChessboardSpec& board, const std::vector<cv::Point2f>& left,
                                       const std::vector<cv::Point2f>& right, double min_ratio = 2.0);

}  // namespace lunarnav::calib
