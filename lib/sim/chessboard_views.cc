#include "sim/chessboard_views.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <random>

#include <Eigen/LU>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>
#include <tbb/parallel_for.h>

#include "calib/stereo_rig_io.h"
#include "io/atomic_file.h"
#include "io/image_io.h"
#include "io/json_io.h"
#include "util/check.h"

namespace lunarnav::sim {
namespace {

constexpr double kDeg = M_PI / 180.0;

cv::Mat ToCv(const Eigen::Matrix3d& m) {
  cv::Mat out;
  cv::eigen2cv(m, out);
  return out;
}

cv::Mat Distortion(const calib::CameraIntrinsics& c) {
  return c.distortion.empty() ? cv::Mat() : cv::Mat(c.distortion, true).reshape(1, 1);
}

// OpenCV's distortion model (k1 k2 p1 p2 [k3 [k4 k5 k6]]) on normalized coordinates.
Eigen::Vector2d Distort(const std::array<double, 8>& d, const Eigen::Vector2d& p) {
  const double x = p.x(), y = p.y(), r2 = x * x + y * y, r4 = r2 * r2, r6 = r4 * r2;
  const double radial = (1 + d[0] * r2 + d[1] * r4 + d[4] * r6) / (1 + d[5] * r2 + d[6] * r4 + d[7] * r6);
  return {x * radial + 2 * d[2] * x * y + d[3] * (r2 + 2 * x * x),
          y * radial + d[2] * (r2 + 2 * y * y) + 2 * d[3] * x * y};
}

// One camera of the rig, with its undistortion table: the normalized image coordinates
// (x/z, y/z) of the rays through the pixel corners (x - 0.5, y - 0.5), x = 0..W, y = 0..H.
struct Camera {
  calib::CameraIntrinsics intrinsics;
  int width = 0, height = 0;
  std::array<double, 8> dist{};  // k1 k2 p1 p2 k3 k4 k5 k6, zero-padded
  cv::Mat corner_rays;           // (H + 1) x (W + 1), CV_64FC2; filled by BuildRayTable
  double max_radius = 0;         // largest normalized radius of a ray inside the image

  Camera(const calib::CameraIntrinsics& c, int w, int h) : intrinsics(c), width(w), height(h) {
    for (std::size_t i = 0; i < c.distortion.size() && i < dist.size(); ++i) dist[i] = c.distortion[i];
    // The distortion is radially monotonic over the image for any sane lens, so the largest
    // radius is on the image border.
    for (int x = 0; x <= w; ++x) {
      for (int y : {0, h}) max_radius = std::max(max_radius, Ray(x - 0.5, y - 0.5).norm());
    }
    for (int y = 0; y <= h; ++y) {
      for (int x : {0, w}) max_radius = std::max(max_radius, Ray(x - 0.5, y - 0.5).norm());
    }
  }

  void BuildRayTable() {
    if (!corner_rays.empty()) return;
    corner_rays.create(height + 1, width + 1, CV_64FC2);
    tbb::parallel_for(0, height + 1, [&](int y) {
      cv::Vec2d* row = corner_rays.ptr<cv::Vec2d>(y);
      for (int x = 0; x <= width; ++x) {
        const Eigen::Vector2d r = Ray(x - 0.5, y - 0.5);
        row[x] = cv::Vec2d(r.x(), r.y());
      }
    });
  }

  // Projects camera-frame points; false when one is behind the camera, outside the image
  // less `margin`, or beyond the image's field of view (where a distortion polynomial may
  // fold back into the image).
  bool ProjectInside(const std::vector<cv::Point3d>& in_cam, double margin, std::vector<cv::Point2d>* px) const {
    for (const cv::Point3d& p : in_cam) {
      if (p.z <= 1e-3 || std::hypot(p.x / p.z, p.y / p.z) > max_radius) return false;
    }
    cv::projectPoints(in_cam, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), ToCv(intrinsics.K), Distortion(intrinsics), *px);
    for (const cv::Point2d& q : *px) {
      if (q.x < margin - 0.5 || q.y < margin - 0.5 || q.x > width - 0.5 - margin || q.y > height - 0.5 - margin) {
        return false;
      }
    }
    return true;
  }

  // The normalized ray through pixel (u, v): the distortion inverted by Newton's method
  // (to 1e-13, far below what any image can resolve).
  Eigen::Vector2d Ray(double u, double v) const {
    const Eigen::Matrix3d& k = intrinsics.K;
    const double yd = (v - k(1, 2)) / k(1, 1);
    const Eigen::Vector2d target((u - k(0, 2) - k(0, 1) * yd) / k(0, 0), yd);
    Eigen::Vector2d p = target;
    constexpr double kStep = 1e-7;
    for (int iteration = 0; iteration < 30; ++iteration) {
      const Eigen::Vector2d residual = Distort(dist, p) - target;
      if (residual.norm() < 1e-13) break;  // 1e-10 px for any focal length below 1000 px
      Eigen::Matrix2d jacobian;
      for (int i = 0; i < 2; ++i) {
        Eigen::Vector2d h = Eigen::Vector2d::Zero();
        h[i] = kStep;
        jacobian.col(i) = (Distort(dist, p + h) - Distort(dist, p - h)) / (2 * kStep);
      }
      p -= jacobian.partialPivLu().solve(residual);
    }
    return p;
  }
};

std::vector<cv::Point3d> Transform(const Eigen::Isometry3d& t, const std::vector<Eigen::Vector3d>& points) {
  std::vector<cv::Point3d> out;
  out.reserve(points.size());
  for (const Eigen::Vector3d& p : points) {
    const Eigen::Vector3d q = t * p;
    out.emplace_back(q.x(), q.y(), q.z());
  }
  return out;
}

// The outline of the white plate in the board frame, sampled densely enough that its
// distorted image cannot bulge out of the image between samples.
std::vector<Eigen::Vector3d> PlateOutline(const ChessboardViewsOptions& o) {
  const double s = o.board.square_size_m, m = s * (1.0 + o.border_squares);
  const double x0 = -m, x1 = (o.board.cols - 1) * s + m, y0 = -m, y1 = (o.board.rows - 1) * s + m;
  std::vector<Eigen::Vector3d> points;
  constexpr int kPerEdge = 16;
  for (int i = 0; i < kPerEdge; ++i) {
    const double a = static_cast<double>(i) / kPerEdge;
    points.emplace_back(x0 + a * (x1 - x0), y0, 0);
    points.emplace_back(x1, y0 + a * (y1 - y0), 0);
    points.emplace_back(x1 - a * (x1 - x0), y1, 0);
    points.emplace_back(x0, y1 - a * (y1 - y0), 0);
  }
  return points;
}

// The board's grey levels as separable pieces, so that each sample can be box-filtered
// exactly over its footprint. With s the square size, I the indicator of the squares'
// extent [-s, cols s] (per axis), P that of the plate (the squares plus the margin), and q
// the square wave (-1)^(floor(t/s) + 1) (the square left of / above corner 0 is black):
//   grey = background + (white - background) P(x)P(y) - a I(x)I(y) - a (Iq)(x)(Iq)(y),
// a = (white - black) / 2. Each 1-D factor is averaged over [t - w, t + w] through its
// antiderivative, so edges are anti-aliased analytically, without staircase artefacts.
struct BoardShader {
  double s, sq_lo_x, sq_hi_x, sq_lo_y, sq_hi_y, pl_lo_x, pl_hi_x, pl_lo_y, pl_hi_y;
  double background, white, amplitude;

  explicit BoardShader(const ChessboardViewsOptions& o)
      : s(o.board.square_size_m),
        sq_lo_x(-s), sq_hi_x(o.board.cols * s), sq_lo_y(-s), sq_hi_y(o.board.rows * s),
        pl_lo_x(-s * (1 + o.border_squares)), pl_hi_x((o.board.cols + o.border_squares) * s),
        pl_lo_y(-s * (1 + o.border_squares)), pl_hi_y((o.board.rows + o.border_squares) * s),
        background(o.background), white(o.white), amplitude((o.white - o.black) / 2) {}

  // Mean over [t - w, t + w] of the indicator of [lo, hi].
  static double BoxMean(double t, double w, double lo, double hi) {
    const double a = std::clamp(t - w, lo, hi), b = std::clamp(t + w, lo, hi);
    return (b - a) / (2 * w);
  }
  // Antiderivative of q restricted to [lo, hi] (a triangle wave between 0 and s).
  double SquareWaveIntegral(double t, double lo, double hi) const {
    const double u = std::clamp(t, lo, hi) / s + 1.0;
    const double k = std::floor(u), f = u - k;
    return s * ((static_cast<long long>(k) & 1) == 0 ? f : 1.0 - f);
  }
  double SquareWaveMean(double t, double w, double lo, double hi) const {
    return (SquareWaveIntegral(t + w, lo, hi) - SquareWaveIntegral(t - w, lo, hi)) / (2 * w);
  }
  // True when no edge of the pattern crosses the box [x0, x1] x [y0, y1]: the grey level is
  // constant over it. Square edges lie at multiples of s, the plate's edges apart.
  bool Uniform(double x0, double x1, double y0, double y1) const {
    auto crosses = [](double a, double b, double edge) { return a < edge && edge < b; };
    return std::floor(x0 / s) == std::floor(x1 / s) && std::floor(y0 / s) == std::floor(y1 / s) &&
           !crosses(x0, x1, pl_lo_x) && !crosses(x0, x1, pl_hi_x) && !crosses(y0, y1, pl_lo_y) &&
           !crosses(y0, y1, pl_hi_y);
  }
  // Mean grey level over the board-frame box [x - wx, x + wx] x [y - wy, y + wy].
  double Mean(double x, double y, double wx, double wy) const {
    const double plate = BoxMean(x, wx, pl_lo_x, pl_hi_x) * BoxMean(y, wy, pl_lo_y, pl_hi_y);
    const double squares = BoxMean(x, wx, sq_lo_x, sq_hi_x) * BoxMean(y, wy, sq_lo_y, sq_hi_y);
    const double checker = SquareWaveMean(x, wx, sq_lo_x, sq_hi_x) * SquareWaveMean(y, wy, sq_lo_y, sq_hi_y);
    return background + (white - background) * plate - amplitude * squares - amplitude * checker;
  }
};

cv::Mat RenderCamera(const Camera& cam, const Eigen::Isometry3d& cam_from_board, const ChessboardViewsOptions& o,
                     std::uint32_t noise_seed) {
  const Eigen::Matrix3d r = cam_from_board.linear();
  const Eigen::Vector3d origin = cam_from_board.translation(), ex = r.col(0), ey = r.col(1), n = r.col(2);
  const double n_dot_origin = n.dot(origin);  // the plane: n . X = n . origin
  // Board coordinates of the rays through the pixel corners; NaN where a ray misses the plane.
  cv::Mat board_xy(cam.corner_rays.size(), CV_64FC2);
  tbb::parallel_for(0, board_xy.rows, [&](int y) {
    const cv::Vec2d* ray = cam.corner_rays.ptr<cv::Vec2d>(y);
    cv::Vec2d* out = board_xy.ptr<cv::Vec2d>(y);
    for (int x = 0; x < board_xy.cols; ++x) {
      const double depth = n_dot_origin / (n.x() * ray[x][0] + n.y() * ray[x][1] + n.z());
      if (!(depth > 0) || !std::isfinite(depth)) {
        out[x] = cv::Vec2d(NAN, NAN);
        continue;
      }
      const Eigen::Vector3d d = Eigen::Vector3d(depth * ray[x][0], depth * ray[x][1], depth) - origin;
      out[x] = cv::Vec2d(ex.dot(d), ey.dot(d));
    }
  });
  const BoardShader shader(o);
  const int s = o.samples_per_axis;
  cv::Mat sum(cam.height, cam.width, CV_64FC1);
  tbb::parallel_for(0, cam.height, [&](int y) {
    const cv::Vec2d* top = board_xy.ptr<cv::Vec2d>(y);
    const cv::Vec2d* bottom = board_xy.ptr<cv::Vec2d>(y + 1);
    double* out = sum.ptr<double>(y);
    for (int x = 0; x < cam.width; ++x) {
      const cv::Vec2d p00 = top[x], p10 = top[x + 1], p01 = bottom[x], p11 = bottom[x + 1];
      if (!std::isfinite(p00[0] + p10[0] + p01[0] + p11[0])) {  // the plane's horizon: far off the board
        out[x] = o.background;
        continue;
      }
      // Within a pixel the board coordinates are bilinear in the pixel position; a sample's
      // footprint is bounded by the box of half-sizes wx, wy (board frame).
      const cv::Vec2d du = 0.5 * (p10 - p00 + p11 - p01), dv = 0.5 * (p01 - p00 + p11 - p10);
      const double wx = std::max(0.5 * (std::abs(du[0]) + std::abs(dv[0])) / s, 1e-12);
      const double wy = std::max(0.5 * (std::abs(du[1]) + std::abs(dv[1])) / s, 1e-12);
      // A pixel that no edge crosses (most of them) has the grey level of its centre.
      const double x0 = std::min({p00[0], p10[0], p01[0], p11[0]}), x1 = std::max({p00[0], p10[0], p01[0], p11[0]});
      const double y0 = std::min({p00[1], p10[1], p01[1], p11[1]}), y1 = std::max({p00[1], p10[1], p01[1], p11[1]});
      if (shader.Uniform(x0 - wx, x1 + wx, y0 - wy, y1 + wy)) {
        out[x] = shader.Mean(0.5 * (x0 + x1), 0.5 * (y0 + y1), 1e-12, 1e-12);
        continue;
      }
      double total = 0;
      for (int b = 0; b < s; ++b) {
        const double fy = (b + 0.5) / s;
        const cv::Vec2d left = p00 + fy * (p01 - p00), right = p10 + fy * (p11 - p10);
        for (int a = 0; a < s; ++a) {
          const cv::Vec2d q = left + ((a + 0.5) / s) * (right - left);
          total += shader.Mean(q[0], q[1], wx, wy);
        }
      }
      out[x] = total / (s * s);
    }
  });
  if (o.blur_sigma_px > 0) {
    cv::GaussianBlur(sum, sum, cv::Size(0, 0), o.blur_sigma_px, o.blur_sigma_px, cv::BORDER_REPLICATE);
  }
  if (o.noise_sigma > 0) {
    std::mt19937 rng(noise_seed);
    std::normal_distribution<double> noise(0.0, o.noise_sigma);
    for (int y = 0; y < sum.rows; ++y) {
      double* row = sum.ptr<double>(y);
      for (int x = 0; x < sum.cols; ++x) row[x] += noise(rng);
    }
  }
  cv::Mat image;
  sum.convertTo(image, CV_8UC1);  // rounds and saturates
  return image;
}

std::vector<cv::Point2d> ProjectCorners(const Camera& cam, const Eigen::Isometry3d& cam_from_board,
                                        const calib::ChessboardSpec& board) {
  // The board's corners in double precision (ObjectPointsM is float, as OpenCV wants it).
  std::vector<cv::Point3d> points;
  for (int j = 0; j < board.rows; ++j) {
    for (int i = 0; i < board.cols; ++i) {
      const Eigen::Vector3d q = cam_from_board * Eigen::Vector3d(i * board.square_size_m, j * board.square_size_m, 0);
      points.emplace_back(q.x(), q.y(), q.z());
    }
  }
  std::vector<cv::Point2d> px;
  cv::projectPoints(points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), ToCv(cam.intrinsics.K),
                    Distortion(cam.intrinsics), px);
  return px;
}

}  // namespace

void ChessboardViewsOptions::Validate() const {
  board.Validate();
  LN_CHECK_ARG(num_views >= 1 && num_views <= 10000) << "views: must be in [1, 10000], got " << num_views;
  LN_CHECK_ARG(min_distance_m > 0 && max_distance_m >= min_distance_m && std::isfinite(max_distance_m))
      << "distance range: need 0 < min <= max, got " << min_distance_m << ":" << max_distance_m;
  LN_CHECK_ARG(max_tilt_deg >= 0 && max_tilt_deg <= 60) << "max tilt: must be in [0, 60] deg";
  LN_CHECK_ARG(max_roll_deg >= 0 && max_roll_deg <= 180) << "max roll: must be in [0, 180] deg";
  LN_CHECK_ARG(border_squares >= 0 && border_squares <= 10) << "border: must be in [0, 10] squares";
  LN_CHECK_ARG(margin_px >= 0) << "margin: must be >= 0 px";
  LN_CHECK_ARG(samples_per_axis >= 1 && samples_per_axis <= 16) << "samples per axis: must be in [1, 16]";
  for (double g : {black, white, background}) {
    LN_CHECK_ARG(g >= 0 && g <= 255) << "grey levels: must be in [0, 255]";
  }
  LN_CHECK_ARG(blur_sigma_px >= 0 && blur_sigma_px <= 10) << "blur sigma: must be in [0, 10] px";
  LN_CHECK_ARG(noise_sigma >= 0 && std::isfinite(noise_sigma)) << "noise sigma: must be >= 0";
}

nlohmann::json ChessboardViewsOptions::ToJson() const {
  return {{"board", board.ToJson()},
          {"views", num_views},
          {"distance_range_m", {min_distance_m, max_distance_m}},
          {"max_tilt_deg", max_tilt_deg},
          {"max_roll_deg", max_roll_deg},
          {"border_squares", border_squares},
          {"margin_px", margin_px},
          {"samples_per_axis", samples_per_axis},
          {"grey_levels", {{"black", black}, {"white", white}, {"background", background}}},
          {"blur_sigma_px", blur_sigma_px},
          {"noise_sigma", noise_sigma},
          {"seed", seed}};
}

std::vector<ChessboardView> GenerateChessboardViews(const calib::StereoRig& rig,
                                                    const ChessboardViewsOptions& options) {
  options.Validate();
  rig.Validate("rig");
  Camera left(rig.left, rig.width_px, rig.height_px), right(rig.right, rig.width_px, rig.height_px);
  Eigen::Isometry3d right_from_left = Eigen::Isometry3d::Identity();
  right_from_left.linear() = rig.right_from_left_R;
  right_from_left.translation() = rig.right_from_left_t_m;
  const Eigen::Vector3d right_centre_in_left = -rig.right_from_left_R.transpose() * rig.right_from_left_t_m;
  const std::vector<Eigen::Vector3d> outline = PlateOutline(options);
  const calib::ChessboardSpec& board = options.board;
  const Eigen::Vector3d board_centre((board.cols - 1) * board.square_size_m / 2,
                                     (board.rows - 1) * board.square_size_m / 2, 0);
  const double fx = rig.left.K(0, 0), fy = rig.left.K(1, 1);
  const double w = rig.width_px, h = rig.height_px;
  const double min_cos_facing = std::cos(75.0 * kDeg);

  std::mt19937 rng(options.seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<int> cells(9);
  std::vector<ChessboardView> views(static_cast<std::size_t>(options.num_views));
  for (int k = 0; k < options.num_views; ++k) {
    if (k % 9 == 0) {
      std::iota(cells.begin(), cells.end(), 0);
      std::shuffle(cells.begin(), cells.end(), rng);
    }
    const int cell_x = cells[k % 9] % 3, cell_y = cells[k % 9] / 3;
    ChessboardView& view = views[static_cast<std::size_t>(k)];
    bool placed = false;
    for (int attempt = 0; attempt < 5000 && !placed; ++attempt) {
      const double z = options.min_distance_m + unit(rng) * (options.max_distance_m - options.min_distance_m);
      // The part of the left image that the right camera also sees at depth z (approximately:
      // the shift by the disparity), split into 3 x 3 cells.
      const double dx = -fx * rig.right_from_left_t_m.x() / z, dy = -fy * rig.right_from_left_t_m.y() / z;
      const double u0 = std::max(0.0, dx), u1 = std::min(w - 1, w - 1 + dx);
      const double v0 = std::max(0.0, dy), v1 = std::min(h - 1, h - 1 + dy);
      if (u1 <= u0 || v1 <= v0) continue;
      const double u = u0 + (cell_x + unit(rng)) / 3.0 * (u1 - u0);
      const double v = v0 + (cell_y + unit(rng)) / 3.0 * (v1 - v0);
      const Eigen::Vector2d ray = left.Ray(u, v);
      const Eigen::Vector3d centre = z * Eigen::Vector3d(ray.x(), ray.y(), 1.0);
      const double phi = 2 * M_PI * unit(rng);
      const double tilt = (0.3 + 0.7 * unit(rng)) * options.max_tilt_deg * kDeg;
      const double roll = (2 * unit(rng) - 1) * options.max_roll_deg * kDeg;
      const Eigen::Matrix3d r =
          (Eigen::AngleAxisd(tilt, Eigen::Vector3d(std::cos(phi), std::sin(phi), 0)) *
           Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()))
              .toRotationMatrix();
      Eigen::Isometry3d left_from_board = Eigen::Isometry3d::Identity();
      left_from_board.linear() = r;
      left_from_board.translation() = centre - r * board_centre;
      const Eigen::Isometry3d right_from_board = right_from_left * left_from_board;
      // Both cameras see the front of the board, not too obliquely.
      const Eigen::Vector3d normal = r.col(2);
      if (normal.dot(centre.normalized()) < min_cos_facing ||
          normal.dot((centre - right_centre_in_left).normalized()) < min_cos_facing) {
        continue;
      }
      std::vector<cv::Point2d> unused;
      if (!left.ProjectInside(Transform(left_from_board, outline), options.margin_px, &unused) ||
          !right.ProjectInside(Transform(right_from_board, outline), options.margin_px, &unused)) {
        continue;
      }
      view.left_from_board = left_from_board;
      view.left_corners_px = ProjectCorners(left, left_from_board, board);
      view.right_corners_px = ProjectCorners(right, right_from_board, board);
      placed = true;
    }
    LN_CHECK_ARG(placed) << "chessboard views: cannot place the " << board.cols << "x" << board.rows
                         << " board of " << board.square_size_m << " m squares inside both images at "
                         << options.min_distance_m << "-" << options.max_distance_m
                         << " m (make it smaller or farther)";
  }
  if (options.render_images) {
    left.BuildRayTable();
    right.BuildRayTable();
    for (int k = 0; k < options.num_views; ++k) {
      ChessboardView& view = views[static_cast<std::size_t>(k)];
      const std::uint32_t base = options.seed * 2654435761u + 2u * static_cast<std::uint32_t>(k);
      view.left = RenderCamera(left, view.left_from_board, options, base);
      view.right = RenderCamera(right, right_from_left * view.left_from_board, options, base + 1);
    }
  }
  return views;
}

std::string ChessboardViewStem(int index) {
  char stem[32];
  std::snprintf(stem, sizeof(stem), "view_%03d", index);
  return stem;
}

void WriteChessboardViews(const std::filesystem::path& dir, const calib::StereoRig& rig,
                          const ChessboardViewsOptions& options, const std::vector<ChessboardView>& views) {
  for (const ChessboardView& view : views) {
    LN_CHECK_ARG(!view.left.empty() && !view.right.empty()) << "chessboard views: not rendered";
  }
  io::CreateOutputDirectory(dir / "left");
  io::CreateOutputDirectory(dir / "right");
  auto corners_json = [](const std::vector<cv::Point2d>& corners) {
    nlohmann::json j = nlohmann::json::array();
    for (const cv::Point2d& p : corners) j.push_back({p.x, p.y});
    return j;
  };
  nlohmann::json truth_views = nlohmann::json::array();
  for (std::size_t k = 0; k < views.size(); ++k) {
    const ChessboardView& view = views[k];
    const std::string stem = ChessboardViewStem(static_cast<int>(k));
    io::WriteImageAtomic(dir / "left" / (stem + ".png"), view.left);
    io::WriteImageAtomic(dir / "right" / (stem + ".png"), view.right);
    const Eigen::Matrix3d r = view.left_from_board.linear();
    const Eigen::Vector3d t = view.left_from_board.translation();
    truth_views.push_back({{"stem", stem},
                           {"left_from_board", {{"R", {{r(0, 0), r(0, 1), r(0, 2)},
                                                       {r(1, 0), r(1, 1), r(1, 2)},
                                                       {r(2, 0), r(2, 1), r(2, 2)}}},
                                                {"t_m", {t.x(), t.y(), t.z()}}}},
                           {"left_corners_px", corners_json(view.left_corners_px)},
                           {"right_corners_px", corners_json(view.right_corners_px)}});
  }
  calib::WriteStereoRig(dir / "rig.json", rig);
  io::WriteJsonAtomic(dir / "truth.json", {{"format", "lunarnav.chessboard_truth/1"},
                                           {"options", options.ToJson()},
                                           {"views", truth_views}});
}

}  // namespace lunarnav::sim
