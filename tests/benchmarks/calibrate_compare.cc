// calibrate_compare: the row error of chessboard corners re-detected in rectified images, for
// `calibrate` + `rectify` against OpenCV's own stereo pipeline (its stereo_calib sample:
// stereoCalibrate with its flags, then stereoRectify) on the same views. A measurement, not a
// test; scripts/bench-calibrate runs it on OpenCV's sample views.
//
//   calibrate_compare VIEWS_DIR SQUARE_M [RECTIFIED_DIR...]
//
// VIEWS_DIR holds left/ and right/ (calibrate's input); each RECTIFIED_DIR is rectify's output
// for those views. Prints, for OpenCV's pipeline at alpha 0 and 1 and for each RECTIFIED_DIR,
// the views whose board is re-detected in both rectified images and the mean and max
// |y_left - y_right| of their corners, pixels.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/chessboard.h"
#include "io/image_io.h"
#include "io/stereo_pairs.h"

namespace fs = std::filesystem;
using namespace lunarnav;

namespace {

struct RowError {
  int views = 0;
  double mean_px = 0, max_px = 0;
};

// Re-detects the board in rectified pairs and measures how far apart the rows of each corner are.
RowError MeasureRows(const std::vector<std::pair<cv::Mat, cv::Mat>>& pairs, const calib::ChessboardSpec& board) {
  RowError e;
  double sum = 0;
  std::size_t count = 0;
  for (const auto& [left, right] : pairs) {
    const auto l = calib::DetectChessboardCorners(left, board), r = calib::DetectChessboardCorners(right, board);
    if (!l || !r) continue;
    const calib::CornerOrderMatch match = calib::MatchRightCornerOrder(board, *l, *r);
    if (!match.right) continue;
    ++e.views;
    for (std::size_t k = 0; k < l->size(); ++k) {
      const double dy = std::abs((*l)[k].y - (*match.right)[k].y);
      sum += dy;
      e.max_px = std::max(e.max_px, dy);
      ++count;
    }
  }
  e.mean_px = count > 0 ? sum / static_cast<double>(count) : NAN;
  return e;
}

void Print(const std::string& name, const RowError& e) {
  std::printf("%-44s views %2d  row error mean %.3f px  max %.3f px\n", name.c_str(), e.views, e.mean_px, e.max_px);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: calibrate_compare VIEWS_DIR SQUARE_M [RECTIFIED_DIR...]\n");
    return 2;
  }
  const calib::ChessboardSpec board{9, 6, std::stod(argv[2])};
  std::vector<std::pair<cv::Mat, cv::Mat>> raw;
  for (const io::PairFiles& p : io::ListStereoPairs(argv[1])) {
    raw.emplace_back(io::ReadGreyImage(p.left), io::ReadGreyImage(p.right));
  }
  const cv::Size size = raw.at(0).first.size();

  // OpenCV's stereo_calib sample, step by step (samples/cpp/stereo_calib.cpp).
  std::vector<std::vector<cv::Point2f>> points[2];
  for (const auto& [left, right] : raw) {
    std::vector<cv::Point2f> c[2];
    bool found = true;
    for (int k = 0; k < 2 && found; ++k) {
      const cv::Mat& img = k == 0 ? left : right;
      found = cv::findChessboardCorners(img, cv::Size(board.cols, board.rows), c[k],
                                        cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE);
      if (found) {
        cv::cornerSubPix(img, c[k], cv::Size(11, 11), cv::Size(-1, -1),
                         cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 30, 0.01));
      }
    }
    if (!found) continue;
    points[0].push_back(c[0]);
    points[1].push_back(c[1]);
  }
  std::vector<std::vector<cv::Point3f>> object(points[0].size(), board.ObjectPointsM());
  cv::Mat m[2], d[2], r, t, e, f;
  m[0] = cv::initCameraMatrix2D(object, points[0], size, 0);
  m[1] = cv::initCameraMatrix2D(object, points[1], size, 0);
  const double rms = cv::stereoCalibrate(
      object, points[0], points[1], m[0], d[0], m[1], d[1], size, r, t, e, f,
      cv::CALIB_FIX_ASPECT_RATIO + cv::CALIB_ZERO_TANGENT_DIST + cv::CALIB_USE_INTRINSIC_GUESS +
          cv::CALIB_SAME_FOCAL_LENGTH + cv::CALIB_RATIONAL_MODEL + cv::CALIB_FIX_K3 + cv::CALIB_FIX_K4 +
          cv::CALIB_FIX_K5,
      cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-5));
  std::printf("OpenCV stereo_calib: %zu of %zu views, stereo RMS %.3f px, fx %.2f / %.2f px, baseline %.4f m\n",
              points[0].size(), raw.size(), rms, m[0].at<double>(0, 0), m[1].at<double>(0, 0), cv::norm(t));
  for (double alpha : {0.0, 1.0}) {
    cv::Mat r1, r2, p1, p2, q;
    cv::stereoRectify(m[0], d[0], m[1], d[1], size, r, t, r1, r2, p1, p2, q, cv::CALIB_ZERO_DISPARITY, alpha, size);
    cv::Mat map[2][2];
    cv::initUndistortRectifyMap(m[0], d[0], r1, p1, size, CV_16SC2, map[0][0], map[0][1]);
    cv::initUndistortRectifyMap(m[1], d[1], r2, p2, size, CV_16SC2, map[1][0], map[1][1]);
    std::vector<std::pair<cv::Mat, cv::Mat>> rectified;
    for (const auto& [left, right] : raw) {
      cv::Mat lr, rr;
      cv::remap(left, lr, map[0][0], map[0][1], cv::INTER_LINEAR);
      cv::remap(right, rr, map[1][0], map[1][1], cv::INTER_LINEAR);
      rectified.emplace_back(lr, rr);
    }
    char name[64];
    std::snprintf(name, sizeof(name), "OpenCV stereoRectify alpha %.0f (f %.1f px)", alpha, p1.at<double>(0, 0));
    Print(name, MeasureRows(rectified, board));
  }
  for (int i = 3; i < argc; ++i) {
    std::vector<std::pair<cv::Mat, cv::Mat>> rectified;
    for (const io::PairFiles& p : io::ListStereoPairs(argv[i])) {
      rectified.emplace_back(io::ReadGreyImage(p.left), io::ReadGreyImage(p.right));
    }
    Print(fs::path(argv[i]).filename().string(), MeasureRows(rectified, board));
  }
  return 0;
}
