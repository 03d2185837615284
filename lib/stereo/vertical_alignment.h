// The residual vertical misalignment of rectified pairs: measured from the pairs themselves and
// taken out before matching (stereo-batch --vertical-alignment; docs/stereo-batch.md).
//
// Rectification puts a scene point on the same row of both images only as well as the
// calibration is right. On KITTI's rectified pairs a point of the road lies up to 1.3 px lower
// in the one image than in the other, by an amount that changes across the image (a relative
// roll and a curvature). A matcher that searches along rows then compares each row with texture
// a fraction of a row away; where that texture runs obliquely, as the lines of a road do towards
// its vanishing point, the best match along the row moves sideways by the offset over the line's
// slope. On a road the lines lean one way on each side of the image and the offsets change sign
// from side to side, so the errors add up: the ground comes out too near, more so towards the
// image's sides (0.6 px of disparity on the median, 2-14 cm of height on KITTI: docs/terrain-map.md).
//
// Measured where the matcher found a match: over a small window with texture in both directions,
// each pixel carried to the other image by its own disparity (so that a slanted surface, whose
// columns shift by different amounts from row to row, lines up along the rows: a translation-only
// tracker such as Lucas-Kanade's is biased there), Gauss-Newton steps find the shift (down the
// rows, and along them: the matches themselves lean towards the offset on oblique texture) that
// best lines up the two windows, to a few hundredths of a pixel; each window gives one sample.
// A cubic surface over the image is fitted to the samples of a few pairs spread over the run
// (least squares, iteratively trimmed of outliers); both images are then resampled by half of it
// in opposite directions (the rows meet half-way, as the project's rectification turns each
// camera half-way), before matching. stereo::StereoBatchRun measures in rounds, each on the
// pairs resampled by the rounds before.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "calib/triangulation.h"

namespace lunarnav::stereo {

/// One measurement: at image position (x_px, y_px) (half-way between the point's positions in
/// the two images), the point's row in the other image minus its row in the reference image.
struct VerticalSample {
  float x_px = 0, y_px = 0, offset_px = 0;
};

/// The other image's row minus the reference image's row of the same scene point, over the
/// image: a cubic in u and v (c0 + c1 u + c2 v + c3 u^2 + c4 u v + c5 v^2 + c6 u^3 + c7 u^2 v +
/// c8 u v^2 + c9 v^3), with u and v the column and
/// row scaled to [-1, 1] over the image and clamped to the span the samples covered (the
/// surface is not extrapolated).
inline constexpr int kVerticalTerms = 10;

struct VerticalMisalignment {
  int width_px = 0, height_px = 0;
  std::array<double, kVerticalTerms> coefficients{};
  double u_min = -1, u_max = 1, v_min = -1, v_max = 1;

  double OffsetPx(double x_px, double y_px) const;
  /// The largest |offset| over the image (on a 33 x 33 grid of positions and the corners).
  double MaxAbsOffsetPx() const;
  /// The sum of two surfaces (a correction measured after this one was applied), spanning both.
  VerticalMisalignment Plus(const VerticalMisalignment& residual) const;
  nlohmann::json ToJson() const;
  /// The surface ToJson wrote, checked (ten finite coefficients of at most 50 px, spans within
  /// [-1, 1], a positive size). @throws InputError naming `source` and what is wrong.
  static VerticalMisalignment FromJson(const nlohmann::json& j, const std::string& source);
};

/// How the samples are taken.
struct VerticalMeasureOptions {
  int stride_px = 4;            ///< Every stride-th pixel of the image, in x and y.
  int window_px = 9;            ///< The window each sample is measured over (odd).
  /// The reference window's texture in its weakest direction: the smaller eigenvalue of its
  /// gradients' mean outer product, (8-bit grey levels per pixel)^2. A window with texture in one
  /// direction only (a line) does not fix a row.
  double min_texture = 4.0;
  int iterations = 8;           ///< Gauss-Newton steps at most.
  double max_offset_px = 2.0;   ///< A sample farther than this off its row is not one,
  double max_shift_px = 1.0;    ///< nor one farther than this along it from the match.
};

/// Samples of one matched pair. `left` and `right` are the pair's images (any depth: scaled to
/// 8 bits by `bits` significant bits); `disparity` the matcher's map (CV_32F, the images' size,
/// NaN where invalid or between the points of its grid, origin (0, 0) and steps `step_x_px`,
/// `step_y_px`); `reference` the image it refers to.
std::vector<VerticalSample> MeasureVerticalOffsets(const cv::Mat& left, const cv::Mat& right, int bits,
                                                   const cv::Mat& disparity, int step_x_px, int step_y_px,
                                                   calib::ReferenceImage reference,
                                                   const VerticalMeasureOptions& options = {});

/// What the fit found.
struct VerticalFitReport {
  int samples = 0, samples_kept = 0;
  double median_abs_offset_px = 0;  ///< Of the samples, before the fit.
  double residual_px = 0;           ///< Robust standard deviation of the kept samples about the surface.
  /// The surface's size where it was measured: the 95th percentile of |offset| at the kept
  /// samples (the image-wide maximum also takes its corners, where few samples hold it).
  double surface_p95_abs_px = 0;
};

/// Fewer samples than this measure nothing.
inline constexpr int kMinVerticalSamples = 200;

/// The surface through `samples` (at least kMinVerticalSamples; else none) of images of `size`.
std::optional<VerticalMisalignment> FitVerticalMisalignment(const std::vector<VerticalSample>& samples, cv::Size size,
                                                            VerticalFitReport* report = nullptr);

/// Resamples pairs so that the misalignment's rows meet half-way (bicubic, rows only).
class VerticalResampler {
 public:
  VerticalResampler(const VerticalMisalignment& misalignment, calib::ReferenceImage reference);
  /// Resamples both images in place (of the misalignment's size; any depth OpenCV's remap takes).
  void Apply(cv::Mat* left, cv::Mat* right) const;
  /// The images' size it resamples.
  cv::Size size() const { return reference_map1_.size(); }

 private:
  calib::ReferenceImage reference_;
  cv::Mat reference_map1_, reference_map2_, other_map1_, other_map2_;
};

}  // namespace lunarnav::stereo
