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
/// Corners are returned with the first row's direction pointing from image left to right
/// wherever the board is seen roughly upright (OpenCV may return either of the two
/// orders; this makes the order of the two images of a stereo view agree).
/// @param image  CV_8UC1 or CV_16UC1.
/// @return the corners in pixels (centres at integers), in board order; std::nullopt when the
///         board is not found completely.
std::optional<std::vector<cv::Point2f>> DetectChessboardCorners(const cv::Mat& image,
                                                                const ChessboardSpec& board);

}  // namespace lunarnav::calib
