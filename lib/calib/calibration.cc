#include "calib/calibration.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "calib/rectify.h"
#include "calib/stereo_rig_io.h"
#include "io/atomic_file.h"
#include "io/image_io.h"
#include "io/json_io.h"
#include "io/stereo_pairs.h"
#include "util/check.h"
#include "util/log.h"
#include "util/parallel.h"
#include "util/progress.h"
#include "util/timer.h"
#include "util/summary.h"

namespace lunarnav::calib {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

CameraIntrinsics IntrinsicsFrom(const cv::Mat& k, const cv::Mat& d) {
  CameraIntrinsics c;
  cv::cv2eigen(k, c.K);
  // OpenCV leaves tiny round-off below the diagonal of K; the rig file wants exact zeros.
  c.K(1, 0) = c.K(2, 0) = c.K(2, 1) = 0;
  c.K(2, 2) = 1;
  const cv::Mat flat = d.reshape(1, 1);
  for (int i = 0; i < 5 && i < flat.cols; ++i) c.distortion.push_back(flat.at<double>(0, i));
  return c;
}

// A number for the table: fixed, or "-" for NaN.
std::string Cell(double value, int precision = 3) {
  if (!std::isfinite(value)) return "-";
  char text[32];
  std::snprintf(text, sizeof(text), "%.*f", precision, value);
  return text;
}

json NumberOrNull(double value) { return std::isfinite(value) ? json(value) : json(nullptr); }

}  // namespace

void CalibrationOptions::Validate() const {
  board.Validate();
  LN_CHECK_ARG(min_views >= 3) << "--min-views: must be >= 3, got " << min_views;
  LN_CHECK_ARG(std::isfinite(flag_view_rms_px) && flag_view_rms_px > 0)
      << "--flag-rms: must be > 0 px, got " << flag_view_rms_px;
  LN_CHECK_ARG(num_threads >= 0) << "--threads: must be >= 0";
  LN_CHECK_ARG(std::isfinite(drop_mad_factor) && drop_mad_factor > 0)
      << "--drop-k: must be > 0, got " << drop_mad_factor;
  LN_CHECK_ARG(std::isfinite(drop_min_rms_px) && drop_min_rms_px > 0)
      << "--drop-min-rms: must be > 0 px, got " << drop_min_rms_px;
  LN_CHECK_ARG(std::isfinite(max_rms_px) && max_rms_px > 0) << "--max-rms: must be > 0 px, got " << max_rms_px;
  LN_CHECK_ARG(std::isfinite(order_min_ratio) && order_min_ratio > 1)
      << "--order-ratio: must be > 1, got " << order_min_ratio;
  LN_CHECK_ARG(std::isfinite(mast.height_m) && std::isfinite(mast.lateral_offset_m) &&
               std::isfinite(mast.forward_offset_m))
      << "--mast-height, --lateral, --forward: must be finite";
  LN_CHECK_ARG(std::isfinite(mast.tilt_deg) && mast.tilt_deg > -90 && mast.tilt_deg < 90)
      << "--tilt: must be in (-90, 90) deg, got " << mast.tilt_deg;
}

json CalibrationOptions::ToJson() const {
  return {{"board", board.ToJson()},
          {"mast", {{"height_m", mast.height_m},
                    {"tilt_deg", mast.tilt_deg},
                    {"lateral_offset_m", mast.lateral_offset_m},
                    {"forward_offset_m", mast.forward_offset_m}}},
          {"min_views", min_views},
          {"estimate_k3", estimate_k3},
          {"fix_intrinsics", fix_intrinsics},
          {"flag_view_rms_px", flag_view_rms_px},
          {"drop_outliers", drop_outliers},
          {"drop_mad_factor", drop_mad_factor},
          {"drop_min_rms_px", drop_min_rms_px},
          {"max_rms_px", max_rms_px},
          {"order_min_ratio", order_min_ratio}};
}

std::string ToString(ViewReport::Status status) {
  switch (status) {
    case ViewReport::Status::kUsed: return "used";
    case ViewReport::Status::kSkipped: return "skipped";
    case ViewReport::Status::kDropped: return "dropped";
    case ViewReport::Status::kFailed: return "failed";
  }
  return "?";
}

std::string CalibrationResult::BriefReport() const {
  std::ostringstream s;
  s << views_listed << " view" << (views_listed == 1 ? "" : "s") << ": " << views_used << " used, "
    << views_skipped << " skipped, " << views_dropped << " dropped, " << views_failed
    << " failed; RMS reprojection error "
    << Cell(rms_stereo_px) << " px; row error after rectification mean " << Cell(mean_row_error_px)
    << " px, max " << Cell(max_row_error_px) << " px";
  return s.str();
}

std::string CalibrationResult::Table() const {
  std::ostringstream s;
  char line[256];
  std::snprintf(line, sizeof(line), "%-24s %-8s %10s %10s %10s %10s  %s\n", "view", "status", "rms_l_px",
                "rms_r_px", "row_mean", "row_max", "note");
  s << line;
  for (const ViewReport& v : views) {
    std::snprintf(line, sizeof(line), "%-24s %-8s %10s %10s %10s %10s  %s\n", v.stem.c_str(),
                  ToString(v.status).c_str(), Cell(v.rms_left_px).c_str(), Cell(v.rms_right_px).c_str(),
                  Cell(v.mean_row_error_px).c_str(), Cell(v.max_row_error_px).c_str(), v.reason.c_str());
    s << line;
  }
  const Eigen::Matrix3d &kl = rig.left.K, &kr = rig.right.K;
  s << "views: " << views_listed << " listed, " << views_used << " used, " << views_skipped << " skipped, "
    << views_dropped << " dropped, " << views_failed << " failed\n";
  if (views_dropped > 0) {
    s << "outliers dropped after " << calibrations - 1 << " recalibration" << (calibrations == 2 ? "" : "s")
      << ": stereo RMS " << Cell(first_rms_stereo_px) << " px before, " << Cell(rms_stereo_px) << " px after\n";
  }
  s << "RMS reprojection error: stereo " << Cell(rms_stereo_px) << " px (left alone " << Cell(rms_left_px)
    << ", right alone " << Cell(rms_right_px) << ")\n";
  s << "row error after rectification: mean " << Cell(mean_row_error_px) << " px, max "
    << Cell(max_row_error_px) << " px\n";
  s << "left:  fx " << Cell(kl(0, 0), 2) << " fy " << Cell(kl(1, 1), 2) << " cx " << Cell(kl(0, 2), 2) << " cy "
    << Cell(kl(1, 2), 2) << " px\n";
  s << "right: fx " << Cell(kr(0, 0), 2) << " fy " << Cell(kr(1, 1), 2) << " cx " << Cell(kr(0, 2), 2) << " cy "
    << Cell(kr(1, 2), 2) << " px\n";
  s << "baseline: " << Cell(rig.BaselineM(), 4) << " m\n";
  return s.str();
}

json CalibrationResult::ToJson() const {
  json views_json = json::array();
  json skipped = json::array();
  json dropped = json::array();
  for (const ViewReport& v : views) {
    json entry = {{"stem", v.stem}, {"status", ToString(v.status)}};
    if (v.status == ViewReport::Status::kDropped) {
      entry["rms_left_px"] = NumberOrNull(v.rms_left_px);
      entry["rms_right_px"] = NumberOrNull(v.rms_right_px);
      entry["row_error_mean_px"] = NumberOrNull(v.mean_row_error_px);
      entry["row_error_max_px"] = NumberOrNull(v.max_row_error_px);
      entry["reason"] = v.reason;
      dropped.push_back({{"stem", v.stem}, {"reason", v.reason}});
      skipped.push_back({{"stem", v.stem}, {"status", ToString(v.status)}, {"reason", v.reason}});
    } else if (v.status == ViewReport::Status::kUsed) {
      entry["rms_left_px"] = NumberOrNull(v.rms_left_px);
      entry["rms_right_px"] = NumberOrNull(v.rms_right_px);
      entry["row_error_mean_px"] = NumberOrNull(v.mean_row_error_px);
      entry["row_error_max_px"] = NumberOrNull(v.max_row_error_px);
      if (!v.reason.empty()) entry["note"] = v.reason;
    } else {
      entry["reason"] = v.reason;
      skipped.push_back({{"stem", v.stem}, {"status", ToString(v.status)}, {"reason", v.reason}});
    }
    views_json.push_back(std::move(entry));
  }
  return {{"counts", {{"views_listed", views_listed},
                      {"views_used", views_used},
                      {"views_skipped", views_skipped},
                      {"views_dropped", views_dropped},
                      {"views_failed", views_failed}}},
          {"calibrations", calibrations},
          {"first_rms_stereo_px", NumberOrNull(first_rms_stereo_px)},
          {"rms_reprojection_px", {{"stereo", NumberOrNull(rms_stereo_px)},
                                   {"left_alone", NumberOrNull(rms_left_px)},
                                   {"right_alone", NumberOrNull(rms_right_px)}}},
          {"row_error_after_rectification_px", {{"mean", NumberOrNull(mean_row_error_px)},
                                                {"max", NumberOrNull(max_row_error_px)}}},
          {"baseline_m", rig.BaselineM()},
          {"not_used", skipped},
          {"dropped", dropped},
          {"views", views_json}};
}

namespace {

// One run of calibrateCamera x 2 + stereoCalibrate on a set of views.
struct Solution {
  StereoRig rig;
  double rms_stereo_px = NAN, rms_left_px = NAN, rms_right_px = NAN;
  std::vector<double> view_rms_left_px, view_rms_right_px;  // per view of the set
  // Per view, the larger RMS of its two images with the intrinsics of each camera's own
  // calibration and only the pose between the cameras fitted: what outliers are judged by.
  std::vector<double> screen_view_rms_px;
};

Solution Solve(const CalibrationOptions& options, const cv::Size& image_size,
               const std::vector<const StereoCorners*>& views) {
  std::vector<std::vector<cv::Point3f>> object(views.size(), options.board.ObjectPointsM());
  std::vector<std::vector<cv::Point2f>> left_points, right_points;
  for (const StereoCorners* v : views) {
    left_points.push_back(v->left);
    right_points.push_back(v->right);
  }
  int model_flags = 0;
  if (!options.estimate_k3) model_flags |= cv::CALIB_FIX_K3;
  const cv::TermCriteria criteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-12);
  Solution s;
  cv::Mat k_left, d_left, k_right, d_right, r, t, e, f, per_view;
  try {
    std::vector<cv::Mat> rvecs, tvecs;
    s.rms_left_px =
        cv::calibrateCamera(object, left_points, image_size, k_left, d_left, rvecs, tvecs, model_flags, criteria);
    s.rms_right_px = cv::calibrateCamera(object, right_points, image_size, k_right, d_right, rvecs, tvecs,
                                         model_flags, criteria);
    // The pose alone first, each camera keeping its own intrinsics: a view whose two images
    // disagree cannot pull the intrinsics there, so its error stands out (the screening error).
    s.rms_stereo_px = cv::stereoCalibrate(object, left_points, right_points, k_left, d_left, k_right, d_right,
                                          image_size, r, t, e, f, per_view, model_flags | cv::CALIB_FIX_INTRINSIC,
                                          criteria);
    for (int k = 0; k < per_view.rows; ++k) {
      s.screen_view_rms_px.push_back(std::max(per_view.at<double>(k, 0), per_view.at<double>(k, 1)));
    }
    if (!options.fix_intrinsics) {
      s.rms_stereo_px = cv::stereoCalibrate(object, left_points, right_points, k_left, d_left, k_right, d_right,
                                            image_size, r, t, e, f, per_view,
                                            model_flags | cv::CALIB_USE_INTRINSIC_GUESS, criteria);
    }
  } catch (const cv::Exception& ex) {
    throw InputError("calibration failed (the views may be degenerate, e.g. all boards parallel): " + ex.msg);
  }
  LN_CHECK_INPUT(std::isfinite(s.rms_stereo_px) && cv::checkRange(k_left) && cv::checkRange(k_right) &&
                 cv::checkRange(t) && cv::checkRange(r))
      << "calibration failed: the solution is not finite";
  StereoRig& rig = s.rig;
  rig.width_px = image_size.width;
  rig.height_px = image_size.height;
  rig.left = IntrinsicsFrom(k_left, d_left);
  rig.right = IntrinsicsFrom(k_right, d_right);
  cv::cv2eigen(r, rig.right_from_left_R);
  cv::cv2eigen(t, rig.right_from_left_t_m);
  rig.mast = options.mast;
  for (int k = 0; k < per_view.rows; ++k) {
    s.view_rms_left_px.push_back(per_view.at<double>(k, 0));
    s.view_rms_right_px.push_back(per_view.at<double>(k, 1));
  }
  return s;
}

double ViewError(const Solution& s, std::size_t k) {
  return std::max(s.view_rms_left_px[k], s.view_rms_right_px[k]);
}

double Median(std::vector<double> values) {
  const std::size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(mid), values.end());
  double m = values[mid];
  if (values.size() % 2 == 0) {
    m = 0.5 * (m + *std::max_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(mid)));
  }
  return m;
}

// The views with the largest errors, "left05 (12.3 px), left03 (4.1 px)", for messages.
std::string WorstViews(const Solution& s, const std::vector<const StereoCorners*>& views, std::size_t count) {
  std::vector<std::size_t> index(views.size());
  for (std::size_t k = 0; k < index.size(); ++k) index[k] = k;
  std::sort(index.begin(), index.end(),
            [&](std::size_t a, std::size_t b) { return ViewError(s, a) > ViewError(s, b); });
  std::ostringstream text;
  for (std::size_t k = 0; k < std::min(count, index.size()); ++k) {
    if (k > 0) text << ", ";
    text << views[index[k]]->stem << " (" << Cell(ViewError(s, index[k]), 2) << " px)";
  }
  return text.str();
}

// Throws an InputError in calibration terms when the solution is not a usable rig.
void CheckConverged(const CalibrationOptions& options, const Solution& s,
                    const std::vector<const StereoCorners*>& views) {
  std::ostringstream problem;
  const Eigen::Matrix3d &kl = s.rig.left.K, &kr = s.rig.right.K;
  const Eigen::Vector3d& t = s.rig.right_from_left_t_m;
  if (!(kl(0, 0) > 0 && kl(1, 1) > 0 && kr(0, 0) > 0 && kr(1, 1) > 0)) {
    problem << "a non-positive focal length (left fx " << Cell(kl(0, 0), 1) << " fy " << Cell(kl(1, 1), 1)
            << ", right fx " << Cell(kr(0, 0), 1) << " fy " << Cell(kr(1, 1), 1) << " px)";
  } else if (!(s.rms_stereo_px <= options.max_rms_px)) {
    problem << "a stereo RMS reprojection error of " << Cell(s.rms_stereo_px, 2) << " px, above the bound of "
            << Cell(options.max_rms_px, 2) << " px (--max-rms)";
  } else if (!(std::abs(t.x()) > std::abs(t.y()))) {
    problem << "a baseline that is not horizontal (right camera centre offset " << Cell(t.x(), 3) << ", "
            << Cell(t.y(), 3) << ", " << Cell(t.z(), 3) << " m): the rows cannot be made epipolar lines";
  } else {
    try {
      s.rig.Validate("calibration result");
      const StereoRig rectified = RectifyRig(s.rig);
      const RectifiedGeometry& g = *rectified.rectified;
      if (!(g.P_left(0, 0) > 0 && std::abs(g.P_right(0, 3)) > 0)) problem << "a degenerate rectification";
    } catch (const InputError& e) {
      problem << "an unusable rig (" << e.what() << ")";
    }
  }
  if (problem.tellp() == 0) return;
  std::string text = problem.str();
  if (text.find("RMS") == std::string::npos) text += " at a stereo RMS of " + Cell(s.rms_stereo_px, 2) + " px";
  throw InputError("calibration did not converge: " + std::to_string(views.size()) + " views give " + text +
                   "; the views with the largest errors: " + WorstViews(s, views, 3) +
                   ". Check their detections (docs/calibrate.md), remove them, or take more views");
}

}  // namespace

void CalibrationResult::Recount() {
  views_listed = static_cast<int>(views.size());
  views_used = views_skipped = views_dropped = views_failed = 0;
  for (const ViewReport& v : views) {
    switch (v.status) {
      case ViewReport::Status::kUsed: ++views_used; break;
      case ViewReport::Status::kSkipped: ++views_skipped; break;
      case ViewReport::Status::kDropped: ++views_dropped; break;
      case ViewReport::Status::kFailed: ++views_failed; break;
    }
  }
}

CalibrationResult CalibrateStereoRig(const CalibrationOptions& options, const cv::Size& image_size,
                                     const std::vector<StereoCorners>& views) {
  options.Validate();
  LN_CHECK_ARG(image_size.width > 0 && image_size.height > 0) << "image size: must be positive";
  const std::size_t n_corners = static_cast<std::size_t>(options.board.CornerCount());
  CalibrationResult result;
  result.views.resize(views.size());
  // The two images of every view in one order; views whose order cannot be decided are skipped.
  std::vector<StereoCorners> ordered(views.size());
  std::vector<std::size_t> active;  // indices into views of the views in the calibration
  for (std::size_t k = 0; k < views.size(); ++k) {
    const StereoCorners& v = views[k];
    LN_CHECK_ARG(v.left.size() == n_corners && v.right.size() == n_corners)
        << "view " << v.stem << ": expected " << n_corners << " corners per image";
    ViewReport& report = result.views[k];
    report.stem = v.stem;
    const CornerOrderMatch match = MatchRightCornerOrder(options.board, v.left, v.right, options.order_min_ratio);
    if (!match.right) {
      report.status = ViewReport::Status::kSkipped;
      report.reason = match.reason;
      LN_LOG(Warning) << "view " << v.stem << ": " << match.reason << "; skipped";
      continue;
    }
    ordered[k] = {v.stem, v.left, *match.right};
    report.status = ViewReport::Status::kUsed;
    active.push_back(k);
  }
  LN_CHECK_INPUT(static_cast<int>(active.size()) >= options.min_views)
      << "the board was found, in an orientation that could be decided, in both images of only " << active.size()
      << " view" << (active.size() == 1 ? "" : "s") << "; at least " << options.min_views << " are needed";

  auto pointers = [&] {
    std::vector<const StereoCorners*> p;
    for (std::size_t k : active) p.push_back(&ordered[k]);
    return p;
  };
  Solution solution = Solve(options, image_size, pointers());
  result.first_rms_stereo_px = solution.rms_stereo_px;
  result.calibrations = 1;
  // Outliers: drop the worst view while it stands far above the others, and calibrate again.
  while (options.drop_outliers && static_cast<int>(active.size()) > options.min_views) {
    std::vector<double> errors;
    for (std::size_t k = 0; k < active.size(); ++k) errors.push_back(solution.screen_view_rms_px[k]);
    const double median = Median(errors);
    std::vector<double> deviations;
    for (double e : errors) deviations.push_back(std::abs(e - median));
    const double mad = Median(deviations);
    const double threshold = std::max(median + options.drop_mad_factor * 1.4826 * mad, options.drop_min_rms_px);
    const std::size_t worst =
        static_cast<std::size_t>(std::max_element(errors.begin(), errors.end()) - errors.begin());
    if (!(errors[worst] > threshold)) break;
    ViewReport& report = result.views[active[worst]];
    report.status = ViewReport::Status::kDropped;
    report.rms_left_px = solution.view_rms_left_px[worst];
    report.rms_right_px = solution.view_rms_right_px[worst];
    report.reason = "outlier: reprojection error " + Cell(errors[worst], 2) + " px > " + Cell(threshold, 2) +
                    " px (median " + Cell(median, 2) + " + " + Cell(options.drop_mad_factor, 1) +
                    " x 1.4826 x MAD " + Cell(mad, 2) + ") in calibration " + std::to_string(result.calibrations);
    LN_LOG(Warning) << "view " << report.stem << ": " << report.reason << "; dropped";
    active.erase(active.begin() + static_cast<std::ptrdiff_t>(worst));
    solution = Solve(options, image_size, pointers());
    ++result.calibrations;
  }
  CheckConverged(options, solution, pointers());

  result.rig = solution.rig;
  result.rms_stereo_px = solution.rms_stereo_px;
  result.rms_left_px = solution.rms_left_px;
  result.rms_right_px = solution.rms_right_px;
  for (std::size_t a = 0; a < active.size(); ++a) {
    ViewReport& report = result.views[active[a]];
    report.rms_left_px = solution.view_rms_left_px[a];
    report.rms_right_px = solution.view_rms_right_px[a];
    if (std::max(report.rms_left_px, report.rms_right_px) > options.flag_view_rms_px) {
      report.reason = "high reprojection error: check the detection";
    }
  }

  // Row error: corners of both images mapped into the rectified geometry (dropped views too,
  // for the table; the totals are over the used views).
  const Rectifier rectifier(RectifyRig(result.rig));
  double row_sum = 0, row_max = 0;
  std::size_t row_count = 0;
  for (std::size_t k = 0; k < views.size(); ++k) {
    ViewReport& report = result.views[k];
    if (report.status == ViewReport::Status::kSkipped) continue;
    std::vector<cv::Point2d> left_raw(ordered[k].left.begin(), ordered[k].left.end());
    std::vector<cv::Point2d> right_raw(ordered[k].right.begin(), ordered[k].right.end());
    const std::vector<cv::Point2d> left_rect = rectifier.RectifyPoints(left_raw, true);
    const std::vector<cv::Point2d> right_rect = rectifier.RectifyPoints(right_raw, false);
    double sum = 0, max = 0;
    for (std::size_t i = 0; i < left_rect.size(); ++i) {
      const double dy = std::abs(left_rect[i].y - right_rect[i].y);
      sum += dy;
      max = std::max(max, dy);
    }
    report.mean_row_error_px = sum / static_cast<double>(left_rect.size());
    report.max_row_error_px = max;
    if (report.status != ViewReport::Status::kUsed) continue;
    row_sum += sum;
    row_count += left_rect.size();
    row_max = std::max(row_max, max);
  }
  result.mean_row_error_px = row_sum / static_cast<double>(row_count);
  result.max_row_error_px = row_max;
  result.Recount();
  return result;
}

CalibrationRun RunCalibration(const CalibrationOptions& options, const fs::path& input_dir,
                              const fs::path& rig_path, const fs::path& summary_path, const json& invocation) {
  options.Validate();
  util::Timer total_timer;
  const std::vector<io::PairFiles> listing = io::ListStereoPairs(input_dir);
  LN_CHECK_INPUT(!listing.empty())
      << input_dir.string() << ": no image pairs in left/ and right/ (PNG, PGM, TIFF or JPEG)";

  // Detection, one view per task; the outcome of view k lands in slot k.
  struct Detection {
    ViewReport report;
    cv::Size size;
    std::optional<std::vector<cv::Point2f>> left, right;
  };
  std::vector<Detection> detections(listing.size());
  util::ProgressBar progress(listing.size(), "views", options.show_progress);
  util::Timer detect_timer;
  util::ParallelForEachItem(listing.size(), options.num_threads, [&](std::size_t k) {
    const io::PairFiles& pair = listing[k];
    Detection& d = detections[k];
    d.report.stem = pair.stem;
    try {
      LN_CHECK_INPUT(pair.problem.empty()) << pair.problem;
      const cv::Mat left = io::ReadGreyImage(pair.left);
      const cv::Mat right = io::ReadGreyImage(pair.right);
      LN_CHECK_INPUT(left.size() == right.size())
          << pair.right.string() << ": size " << right.cols << "x" << right.rows << " differs from the left image's "
          << left.cols << "x" << left.rows;
      d.size = left.size();
      d.left = DetectChessboardCorners(left, options.board);
      d.right = DetectChessboardCorners(right, options.board);
      if (d.left && d.right) {
        d.report.status = ViewReport::Status::kUsed;
      } else {
        d.report.status = ViewReport::Status::kSkipped;
        d.report.reason = !d.left && !d.right ? "board not found in either image"
                          : !d.left           ? "board not found in the left image"
                                              : "board not found in the right image";
      }
    } catch (const InputError& e) {
      d.report.status = ViewReport::Status::kFailed;
      d.report.reason = e.what();
    }
    progress.Increment();
  });
  const double detect_seconds = detect_timer.ElapsedSeconds();

  // The image size is the first readable view's; views of another size are failed.
  cv::Size image_size;
  for (Detection& d : detections) {
    if (d.report.status == ViewReport::Status::kFailed) continue;
    if (image_size.empty()) image_size = d.size;
    if (d.size != image_size) {
      d.report.status = ViewReport::Status::kFailed;
      d.report.reason = "image size " + std::to_string(d.size.width) + "x" + std::to_string(d.size.height) +
                        " differs from the first view's " + std::to_string(image_size.width) + "x" +
                        std::to_string(image_size.height);
    }
  }
  std::vector<StereoCorners> usable;
  int skipped = 0, failed = 0;
  for (const Detection& d : detections) {
    switch (d.report.status) {
      case ViewReport::Status::kUsed: usable.push_back({d.report.stem, *d.left, *d.right}); break;
      case ViewReport::Status::kDropped:  // not decided before the calibration
      case ViewReport::Status::kSkipped:
        ++skipped;
        LN_LOG(Warning) << "view " << d.report.stem << ": " << d.report.reason << "; skipped";
        break;
      case ViewReport::Status::kFailed:
        ++failed;
        LN_LOG(Error) << "view " << d.report.stem << ": " << d.report.reason;
        break;
    }
  }
  LN_CHECK_INPUT(static_cast<int>(usable.size()) >= options.min_views)
      << input_dir.string() << ": the " << options.board.cols << "x" << options.board.rows
      << " board was found in both images of only " << usable.size() << " of " << listing.size() << " views ("
      << skipped << " skipped, " << failed << " failed); at least " << options.min_views << " are needed";

  util::Timer calibrate_timer;
  CalibrationRun run;
  CalibrationResult calibrated = CalibrateStereoRig(options, image_size, usable);
  run.calibrate_seconds = calibrate_timer.ElapsedSeconds();
  // Merge the used views' reports with the others, in name order.
  CalibrationResult& result = run.result;
  result = calibrated;
  result.views.clear();
  std::size_t next_used = 0;
  for (const Detection& d : detections) {
    result.views.push_back(d.report.status == ViewReport::Status::kUsed ? calibrated.views[next_used++] : d.report);
  }
  result.Recount();

  run.rig_path = rig_path;
  run.summary_path = summary_path;
  run.detect_seconds = detect_seconds;
  for (const fs::path& p : {rig_path, summary_path}) {
    if (!p.parent_path().empty()) io::CreateOutputDirectory(p.parent_path());
  }
  WriteStereoRig(rig_path, result.rig);
  run.seconds = total_timer.ElapsedSeconds();

  json j = util::SummaryHead("calibrate", invocation);
  j["inputs"] = {{"input_dir", input_dir.string()}};
  j["outputs"] = {{"rig", rig_path.string()}};
  j["options"] = options.ToJson();
  j["threads"] = util::EffectiveThreadCount(options.num_threads);
  j["image_size_px"] = {image_size.width, image_size.height};
  j.update(result.ToJson());
  j["timings_s"] = {{"total", run.seconds}, {"detect", run.detect_seconds}, {"calibrate", run.calibrate_seconds}};
  io::WriteJsonAtomic(summary_path, j);
  return run;
}

}  // namespace lunarnav::calib
