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
          {"flag_view_rms_px", flag_view_rms_px}};
}

std::string ToString(ViewReport::Status status) {
  switch (status) {
    case ViewReport::Status::kUsed: return "used";
    case ViewReport::Status::kSkipped: return "skipped";
    case ViewReport::Status::kFailed: return "failed";
  }
  return "?";
}

std::string CalibrationResult::BriefReport() const {
  std::ostringstream s;
  s << views_listed << " view" << (views_listed == 1 ? "" : "s") << ": " << views_used << " used, "
    << views_skipped << " skipped, " << views_failed << " failed; RMS reprojection error "
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
    << views_failed << " failed\n";
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
  for (const ViewReport& v : views) {
    json entry = {{"stem", v.stem}, {"status", ToString(v.status)}};
    if (v.status == ViewReport::Status::kUsed) {
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
                      {"views_failed", views_failed}}},
          {"rms_reprojection_px", {{"stereo", NumberOrNull(rms_stereo_px)},
                                   {"left_alone", NumberOrNull(rms_left_px)},
                                   {"right_alone", NumberOrNull(rms_right_px)}}},
          {"row_error_after_rectification_px", {{"mean", NumberOrNull(mean_row_error_px)},
                                                {"max", NumberOrNull(max_row_error_px)}}},
          {"baseline_m", rig.BaselineM()},
          {"not_used", skipped},
          {"views", views_json}};
}

CalibrationResult CalibrateStereoRig(const CalibrationOptions& options, const cv::Size& image_size,
                                     const std::vector<StereoCorners>& views) {
  options.Validate();
  LN_CHECK_ARG(image_size.width > 0 && image_size.height > 0) << "image size: must be positive";
  LN_CHECK_INPUT(static_cast<int>(views.size()) >= options.min_views)
      << "the board was found in both images of only " << views.size() << " view"
      << (views.size() == 1 ? "" : "s") << "; at least " << options.min_views << " are needed";
  const std::size_t n_corners = static_cast<std::size_t>(options.board.CornerCount());
  std::vector<std::vector<cv::Point3f>> object(views.size(), options.board.ObjectPointsM());
  std::vector<std::vector<cv::Point2f>> left_points, right_points;
  for (const StereoCorners& v : views) {
    LN_CHECK_ARG(v.left.size() == n_corners && v.right.size() == n_corners)
        << "view " << v.stem << ": expected " << n_corners << " corners per image";
    left_points.push_back(v.left);
    right_points.push_back(v.right);
  }

  int model_flags = 0;
  if (!options.estimate_k3) model_flags |= cv::CALIB_FIX_K3;
  const cv::TermCriteria criteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-12);
  CalibrationResult result;
  cv::Mat k_left, d_left, k_right, d_right, r, t, e, f, per_view;
  try {
    std::vector<cv::Mat> rvecs, tvecs;
    result.rms_left_px =
        cv::calibrateCamera(object, left_points, image_size, k_left, d_left, rvecs, tvecs, model_flags, criteria);
    result.rms_right_px = cv::calibrateCamera(object, right_points, image_size, k_right, d_right, rvecs, tvecs,
                                              model_flags, criteria);
    const int stereo_flags =
        model_flags | (options.fix_intrinsics ? cv::CALIB_FIX_INTRINSIC : cv::CALIB_USE_INTRINSIC_GUESS);
    result.rms_stereo_px = cv::stereoCalibrate(object, left_points, right_points, k_left, d_left, k_right, d_right,
                                               image_size, r, t, e, f, per_view, stereo_flags, criteria);
  } catch (const cv::Exception& ex) {
    throw InputError("calibration failed (the views may be degenerate, e.g. all boards parallel): " + ex.msg);
  }
  LN_CHECK_INPUT(std::isfinite(result.rms_stereo_px) && cv::checkRange(k_left) && cv::checkRange(k_right) &&
                 cv::checkRange(t))
      << "calibration failed: the solution is not finite";

  StereoRig& rig = result.rig;
  rig.width_px = image_size.width;
  rig.height_px = image_size.height;
  rig.left = IntrinsicsFrom(k_left, d_left);
  rig.right = IntrinsicsFrom(k_right, d_right);
  cv::cv2eigen(r, rig.right_from_left_R);
  cv::cv2eigen(t, rig.right_from_left_t_m);
  rig.mast = options.mast;
  rig.Validate("calibration result");

  // Row error: corners of both images mapped into the rectified geometry.
  const Rectifier rectifier(RectifyRig(rig));
  double row_sum = 0, row_max = 0;
  std::size_t row_count = 0;
  result.views.resize(views.size());
  for (std::size_t k = 0; k < views.size(); ++k) {
    ViewReport& report = result.views[k];
    report.stem = views[k].stem;
    report.status = ViewReport::Status::kUsed;
    report.rms_left_px = per_view.at<double>(static_cast<int>(k), 0);
    report.rms_right_px = per_view.at<double>(static_cast<int>(k), 1);
    if (std::max(report.rms_left_px, report.rms_right_px) > options.flag_view_rms_px) {
      report.reason = "high reprojection error: check the detection";
    }
    std::vector<cv::Point2d> left_raw(views[k].left.begin(), views[k].left.end());
    std::vector<cv::Point2d> right_raw(views[k].right.begin(), views[k].right.end());
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
    row_sum += sum;
    row_count += left_rect.size();
    row_max = std::max(row_max, max);
  }
  result.mean_row_error_px = row_sum / static_cast<double>(row_count);
  result.max_row_error_px = row_max;
  result.views_listed = result.views_used = static_cast<int>(views.size());
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
  result.views_listed = static_cast<int>(listing.size());
  result.views_used = static_cast<int>(usable.size());
  result.views_skipped = skipped;
  result.views_failed = failed;

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
