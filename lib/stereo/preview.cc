#include "stereo/preview.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include <opencv2/imgproc.hpp>

#include "util/check.h"

namespace lunarnav::stereo {
namespace {

// Turbo, sampled once.
const cv::Mat& TurboTable() {
  static const cv::Mat table = [] {
    cv::Mat ramp(1, 256, CV_8UC1);
    for (int i = 0; i < 256; ++i) ramp.at<std::uint8_t>(0, i) = static_cast<std::uint8_t>(i);
    cv::Mat colours;
    cv::applyColorMap(ramp, colours, cv::COLORMAP_TURBO);
    return colours;
  }();
  return table;
}

std::string Format(double v, int digits) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.*f", digits, v);
  return buffer;
}

}  // namespace

cv::Vec3b RejectionColour(Rejection reason) {
  switch (reason) {
    case Rejection::kAccepted: return {0, 0, 0};
    case Rejection::kNotEvaluated: return {0, 0, 0};
    case Rejection::kBorder: return {90, 90, 90};          // dark grey
    case Rejection::kLowTexture: return {255, 255, 255};   // white
    case Rejection::kLowCorrelation: return {30, 80, 140};  // brown
    case Rejection::kAmbiguous: return {255, 0, 255};      // magenta
    case Rejection::kRangeEdge: return {0, 140, 255};      // orange
    case Rejection::kMedian: return {0, 255, 255};         // yellow
    case Rejection::kLeftRightMismatch: return {40, 40, 200};  // dark red
    case Rejection::kSpeckle: return {0, 100, 0};          // dark green
    case Rejection::kBeyondBorder: return {160, 0, 80};    // purple
    case Rejection::kBeyondFar: return {200, 160, 0};      // teal
    case Rejection::kBeyondNear: return {130, 200, 120};   // sage
    case Rejection::kAperture: return {230, 216, 173};     // light blue
    case Rejection::kOccludedEdge: return {0, 215, 255};   // gold
  }
  return {0, 0, 0};
}

cv::Vec3b DisparityColour(double d, double d_min, double d_max) {
  const double t = d_max > d_min ? (d - d_min) / (d_max - d_min) : 0.0;
  const int index = static_cast<int>(std::lround(255.0 * std::clamp(t, 0.0, 1.0)));
  return TurboTable().at<cv::Vec3b>(0, index);
}

cv::Mat DisparityPreview(const NccResult& result, const cv::Mat& reference, int bit_depth, int step_x, int step_y,
                         double d_min, double d_max) {
  LN_CHECK(reference.size() == result.disparity_px.size());
  LN_CHECK(step_x >= 1 && step_y >= 1);
  const int width = reference.cols, height = reference.rows;
  cv::Mat grey;
  reference.convertTo(grey, CV_8U, 255.0 / ((1u << bit_depth) - 1.0));
  constexpr int kLegendRows = 58;
  cv::Mat out(height + kLegendRows, width, CV_8UC3, cv::Scalar(255, 255, 255));
  for (int y = 0; y < height; ++y) {
    const int gy = y / step_y * step_y;
    const auto* g = grey.ptr<std::uint8_t>(y);
    const auto* d = result.disparity_px.ptr<float>(gy);
    const auto* r = result.rejection.ptr<std::uint8_t>(gy);
    auto* o = out.ptr<cv::Vec3b>(y);
    for (int x = 0; x < width; ++x) {
      const int gx = x / step_x * step_x;
      const auto reason = static_cast<Rejection>(r[gx]);
      if (reason == Rejection::kAccepted && std::isfinite(d[gx])) {
        o[x] = DisparityColour(d[gx], d_min, d_max);
      } else if (reason == Rejection::kNotEvaluated) {
        o[x] = cv::Vec3b(g[x], g[x], g[x]);
      } else {
        const cv::Vec3b c = RejectionColour(reason);
        for (int k = 0; k < 3; ++k) o[x][k] = static_cast<std::uint8_t>((3 * c[k] + g[x]) / 4);
      }
    }
  }
  // Legend, first line: the colour bar and its scale.
  const double font = 0.4;
  const cv::Scalar ink(0, 0, 0);
  const int bar_x = 8, bar_w = std::max(32, std::min(256, width / 3)), bar_y = height + 6, bar_h = 12;
  for (int i = 0; i < bar_w; ++i) {
    const cv::Vec3b c = DisparityColour(d_min + (d_max - d_min) * i / (bar_w - 1.0), d_min, d_max);
    cv::line(out, {bar_x + i, bar_y}, {bar_x + i, bar_y + bar_h}, cv::Scalar(c[0], c[1], c[2]));
  }
  cv::putText(out, Format(d_min, 0), {bar_x, bar_y + bar_h + 12}, cv::FONT_HERSHEY_SIMPLEX, 0.35, ink);
  const std::string hi = Format(d_max, 0);
  cv::putText(out, hi, {bar_x + bar_w - 7 * static_cast<int>(hi.size()), bar_y + bar_h + 12}, cv::FONT_HERSHEY_SIMPLEX,
              0.35, ink);
  cv::putText(out, "disparity (px)", {bar_x + bar_w + 8, bar_y + 11}, cv::FONT_HERSHEY_SIMPLEX, font, ink);
  // Second line: the reasons present, with their share of the evaluated pixels.
  const NccSummary& s = result.summary;
  const double evaluated = std::max(1, s.evaluated_pixels);
  int x = bar_x;
  const int y = height + 50;
  for (int code = static_cast<int>(Rejection::kBorder); code < kNumRejectionCodes; ++code) {
    if (s.pixels_by_reason[code] == 0) continue;
    const auto reason = static_cast<Rejection>(code);
    const std::string label = ToString(reason) + " " + Format(100.0 * s.pixels_by_reason[code] / evaluated, 1) + "%";
    int baseline = 0;
    const cv::Size size = cv::getTextSize(label, cv::FONT_HERSHEY_SIMPLEX, font, 1, &baseline);
    if (x + 14 + size.width > width) break;  // no room left: the rest are in summary.json
    const cv::Vec3b c = RejectionColour(reason);
    cv::rectangle(out, cv::Rect(x, y - 9, 10, 10), cv::Scalar(c[0], c[1], c[2]), cv::FILLED);
    cv::rectangle(out, cv::Rect(x, y - 9, 10, 10), ink, 1);
    cv::putText(out, label, {x + 14, y}, cv::FONT_HERSHEY_SIMPLEX, font, ink);
    x += 14 + size.width + 12;
  }
  return out;
}

}  // namespace lunarnav::stereo
