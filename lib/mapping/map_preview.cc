#include "mapping/map_preview.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include <opencv2/imgproc.hpp>

#include "util/format.h"

namespace lunarnav::mapping {

namespace {

std::string Metres(double v) { return util::Format("%.2f m", v); }

// A "nice" length near `target`: 1, 2 or 5 times a power of ten.
double NiceLength(double target) {
  const double p = std::pow(10.0, std::floor(std::log10(target)));
  for (double m : {5.0, 2.0, 1.0}) {
    if (m * p <= target) return m * p;
  }
  return p;
}

// The layers grown (NaN cells) to hold every point of the path with a margin of `margin_m`.
MapLayers PadToPath(const MapLayers& l, const std::vector<Eigen::Vector2d>& path, double margin_m) {
  int left = 0, right = 0, top = 0, bottom = 0;
  for (const Eigen::Vector2d& p : path) {
    left = std::max(left, static_cast<int>(std::ceil((l.x_west_m - (p.x() - margin_m)) / l.cell_m)));
    right = std::max(right, static_cast<int>(std::ceil((p.x() + margin_m - l.x_west_m) / l.cell_m)) - l.elevation_m.cols);
    top = std::max(top, static_cast<int>(std::ceil((p.y() + margin_m - l.y_north_m) / l.cell_m)));
    bottom = std::max(bottom, static_cast<int>(std::ceil((l.y_north_m - (p.y() - margin_m)) / l.cell_m)) - l.elevation_m.rows);
  }
  MapLayers out = l;
  const cv::Scalar nan(std::numeric_limits<double>::quiet_NaN());
  cv::copyMakeBorder(l.elevation_m, out.elevation_m, top, bottom, left, right, cv::BORDER_CONSTANT, nan);
  cv::copyMakeBorder(l.obstacle, out.obstacle, top, bottom, left, right, cv::BORDER_CONSTANT, nan);
  out.x_west_m -= left * l.cell_m;
  out.y_north_m += top * l.cell_m;
  return out;
}

}  // namespace

cv::Mat RenderMapPreview(const MapLayers& unpadded, const std::vector<Eigen::Vector2d>& path, int target_px) {
  const MapLayers l = unpadded.elevation_m.empty() ? unpadded : PadToPath(unpadded, path, 1.0);
  if (l.elevation_m.empty()) {
    cv::Mat empty(120, 400, CV_8UC3, cv::Scalar(235, 235, 235));
    cv::putText(empty, "empty map: no point fused", {20, 65}, cv::FONT_HERSHEY_SIMPLEX, 0.6, {0, 0, 0}, 1, cv::LINE_AA);
    return empty;
  }
  const int w = l.elevation_m.cols, h = l.elevation_m.rows;
  const int scale = std::max(1, target_px / std::max(w, h));
  const cv::Mat valid = l.elevation_m == l.elevation_m;  // not NaN
  double lo = 0, hi = 0;
  cv::minMaxLoc(l.elevation_m, &lo, &hi, nullptr, nullptr, valid);
  if (hi - lo < 1e-3) hi = lo + 1e-3;

  // Colour relief.
  cv::Mat grey;
  l.elevation_m.convertTo(grey, CV_8U, 255.0 / (hi - lo), -lo * 255.0 / (hi - lo));
  cv::Mat colour;
  cv::applyColorMap(grey, colour, cv::COLORMAP_VIRIDIS);
  // Hillshade: sun from the north-west, 45 deg above the horizon.
  const double az = 315.0 * M_PI / 180, alt = 45.0 * M_PI / 180;
  const Eigen::Vector3d sun(std::sin(az) * std::cos(alt), std::cos(az) * std::cos(alt), std::sin(alt));
  cv::Mat cells(h, w, CV_8UC3);
  for (int r = 0; r < h; ++r) {
    for (int c = 0; c < w; ++c) {
      if (!valid.at<uchar>(r, c)) {
        cells.at<cv::Vec3b>(r, c) = {225, 225, 225};
        continue;
      }
      auto e = [&](int rr, int cc) {
        rr = std::clamp(rr, 0, h - 1);
        cc = std::clamp(cc, 0, w - 1);
        const float v = l.elevation_m.at<float>(rr, cc);
        return std::isfinite(v) ? v : l.elevation_m.at<float>(r, c);
      };
      const double dzdx = (e(r, c + 1) - e(r, c - 1)) / (2 * l.cell_m), dzdy = (e(r - 1, c) - e(r + 1, c)) / (2 * l.cell_m);
      const double shade = std::clamp(Eigen::Vector3d(-dzdx, -dzdy, 1).normalized().dot(sun), 0.0, 1.0);
      const double k = 0.45 + 0.55 * shade / sun.z();
      const cv::Vec3b base = colour.at<cv::Vec3b>(r, c);
      cv::Vec3b out;
      for (int ch = 0; ch < 3; ++ch) out[ch] = cv::saturate_cast<uchar>(base[ch] * k);
      const float ob = l.obstacle.empty() ? 0.f : l.obstacle.at<float>(r, c);
      if (std::isfinite(ob) && ob > 0) out = {30, 30, 230};
      cells.at<cv::Vec3b>(r, c) = out;
    }
  }
  cv::Mat map;
  cv::resize(cells, map, {w * scale, h * scale}, 0, 0, cv::INTER_NEAREST);

  // Path.
  std::vector<cv::Point> pts;
  for (const Eigen::Vector2d& p : path) {
    pts.emplace_back(static_cast<int>(std::lround((p.x() - l.x_west_m) / l.cell_m * scale)),
                     static_cast<int>(std::lround((l.y_north_m - p.y()) / l.cell_m * scale)));
  }
  if (pts.size() >= 2) {
    cv::polylines(map, pts, false, {0, 0, 0}, 4, cv::LINE_AA);
    cv::polylines(map, pts, false, {255, 255, 255}, 2, cv::LINE_AA);
  }
  if (!pts.empty()) cv::circle(map, pts.back(), 5, {255, 255, 255}, cv::FILLED, cv::LINE_AA);

  // Canvas: map, legend on the right, scale bar below.
  const int legend_w = 170, bottom = 60, margin = 10;
  cv::Mat canvas(std::max(map.rows, 260) + bottom + 2 * margin, map.cols + legend_w + 2 * margin, CV_8UC3,
                 cv::Scalar(255, 255, 255));
  map.copyTo(canvas(cv::Rect(margin, margin, map.cols, map.rows)));
  const int lx = map.cols + 2 * margin, bar_h = 200, bar_w = 20;
  for (int y = 0; y < bar_h; ++y) {
    const auto v = static_cast<uchar>(std::lround(255.0 * (bar_h - 1 - y) / (bar_h - 1)));
    cv::Mat one(1, 1, CV_8U, cv::Scalar(v)), c;
    cv::applyColorMap(one, c, cv::COLORMAP_VIRIDIS);
    cv::line(canvas, {lx, margin + 20 + y}, {lx + bar_w, margin + 20 + y}, c.at<cv::Vec3b>(0, 0));
  }
  const auto font = cv::FONT_HERSHEY_SIMPLEX;
  cv::putText(canvas, "elevation", {lx, margin + 12}, font, 0.45, {0, 0, 0}, 1, cv::LINE_AA);
  cv::putText(canvas, Metres(hi), {lx + bar_w + 6, margin + 28}, font, 0.45, {0, 0, 0}, 1, cv::LINE_AA);
  cv::putText(canvas, Metres(lo), {lx + bar_w + 6, margin + 20 + bar_h}, font, 0.45, {0, 0, 0}, 1, cv::LINE_AA);
  cv::rectangle(canvas, cv::Rect(lx, margin + bar_h + 35, bar_w, 12), {30, 30, 230}, cv::FILLED);
  cv::putText(canvas, "obstacle", {lx + bar_w + 6, margin + bar_h + 46}, font, 0.45, {0, 0, 0}, 1, cv::LINE_AA);
  cv::line(canvas, {lx, margin + bar_h + 62}, {lx + bar_w, margin + bar_h + 62}, {0, 0, 0}, 3);
  cv::putText(canvas, "path", {lx + bar_w + 6, margin + bar_h + 67}, font, 0.45, {0, 0, 0}, 1, cv::LINE_AA);
  // Scale bar and north.
  const double bar_m = NiceLength(0.25 * map.cols / scale * l.cell_m);
  const int bar_px = static_cast<int>(std::lround(bar_m / l.cell_m * scale));
  const int by = margin + map.rows + 30;
  cv::rectangle(canvas, cv::Rect(margin, by, bar_px, 8), {0, 0, 0}, cv::FILLED);
  char text[64];
  std::snprintf(text, sizeof text, "%g m   (north up; cell %g m)", bar_m, l.cell_m);
  cv::putText(canvas, text, {margin + bar_px + 10, by + 9}, font, 0.45, {0, 0, 0}, 1, cv::LINE_AA);
  return canvas;
}

}  // namespace lunarnav::mapping
