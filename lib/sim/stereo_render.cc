#include "sim/stereo_render.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <tbb/parallel_for.h>

#include "sim/random.h"
#include "util/check.h"
#include "util/timer.h"

namespace lunarnav::sim {
namespace {

constexpr double kMaxRange = 1000.0;  // metres; rays end here
constexpr std::uint64_t kNoiseSalt = 0x4E4F4953;  // "NOIS"

// Unit-depth ray directions (x, y, 1) in a raw camera's frame for every sub-pixel sample of
// the image: S*S samples per pixel, row-major pixels, samples row-major within a pixel.
std::vector<Eigen::Vector3f> RawRays(const calib::CameraIntrinsics& camera, int width, int height, int s) {
  std::vector<cv::Point2d> pixels;
  pixels.reserve(static_cast<std::size_t>(width) * height * s * s);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      for (int sy = 0; sy < s; ++sy) {
        for (int sx = 0; sx < s; ++sx) {
          pixels.emplace_back(x + (sx + 0.5) / s - 0.5, y + (sy + 0.5) / s - 0.5);
        }
      }
    }
  }
  cv::Mat k, d;
  cv::eigen2cv(camera.K, k);
  if (!camera.distortion.empty()) d = cv::Mat(camera.distortion, true).reshape(1, 1);
  std::vector<cv::Point2d> normalised;
  // Iterate the inverse distortion to convergence, as calib::Rectifier does.
  const cv::TermCriteria converged(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100, 1e-12);
  cv::undistortPoints(pixels, normalised, k, d, cv::noArray(), cv::noArray(), converged);
  std::vector<Eigen::Vector3f> rays(normalised.size());
  for (std::size_t i = 0; i < rays.size(); ++i) {
    rays[i] = Eigen::Vector3f(static_cast<float>(normalised[i].x), static_cast<float>(normalised[i].y), 1.0f);
  }
  return rays;
}

}  // namespace

std::string ToString(CameraMode mode) { return mode == CameraMode::kRaw ? "raw" : "rectified"; }

CameraMode CameraModeFromString(const std::string& name) {
  if (name == "raw") return CameraMode::kRaw;
  if (name == "rectified") return CameraMode::kRectified;
  LN_CHECK_ARG(false) << "camera mode: raw or rectified, got '" << name << "'";
  return CameraMode::kRaw;
}

void StereoRenderOptions::Validate() const {
  LN_CHECK_ARG(samples_per_axis >= 1 && samples_per_axis <= 8)
      << "samples per axis: must be in 1..8, got " << samples_per_axis;
  for (const CameraExposure* e : {&left_exposure, &right_exposure}) {
    LN_CHECK_ARG(std::isfinite(e->gain) && e->gain > 0 && std::isfinite(e->offset))
        << "exposure: gain must be > 0 and offset finite";
  }
  LN_CHECK_ARG(std::isfinite(noise_sigma) && noise_sigma >= 0) << "noise sigma: must be >= 0";
}

nlohmann::json StereoRenderOptions::ToJson() const {
  return {{"mode", ToString(mode)},
          {"rays_per_pixel", samples_per_axis * samples_per_axis},
          {"left_exposure", {{"gain", left_exposure.gain}, {"offset", left_exposure.offset}}},
          {"right_exposure", {{"gain", right_exposure.gain}, {"offset", right_exposure.offset}}},
          {"noise_sigma", noise_sigma},
          {"quantize", quantize},
          {"seed", seed}};
}

nlohmann::json StereoFrameStats::ToJson() const {
  return {{"pixels", pixels},   {"sky", sky},           {"occluded", occluded},
          {"outside", outside}, {"disparity", disparity}, {"render_s", render_s}};
}

struct StereoRenderer::Rays {
  std::vector<Eigen::Vector3f> left, right;  // raw mode only
};

StereoRenderer::StereoRenderer(const calib::StereoRig& rig, const StereoRenderOptions& options)
    : rig_(rig), options_(options) {
  options_.Validate();
  LN_CHECK_ARG(rig_.rectified.has_value()) << "stereo renderer: the rig must be rectified (calib::RectifyRig)";
  rig_.Validate("rig");
  auto rays = std::make_shared<Rays>();
  if (options_.mode == CameraMode::kRaw) {
    const int s = options_.samples_per_axis;
    rays->left = RawRays(rig_.left, rig_.width_px, rig_.height_px, s);
    rays->right = RawRays(rig_.right, rig_.width_px, rig_.height_px, s);
  }
  rays_ = std::move(rays);
}

int StereoRenderer::ImageWidth() const {
  return options_.mode == CameraMode::kRaw ? rig_.width_px : rig_.rectified->width_px;
}

int StereoRenderer::ImageHeight() const {
  return options_.mode == CameraMode::kRaw ? rig_.height_px : rig_.rectified->height_px;
}

StereoFrame StereoRenderer::Render(const Scene& scene, const VehiclePose& pose, std::uint64_t frame_index) const {
  util::Timer timer;
  const calib::RectifiedGeometry& g = *rig_.rectified;
  const Eigen::Isometry3d world_from_vehicle = pose.WorldFromVehicle();
  const Eigen::Isometry3d world_from_left = world_from_vehicle * rig_.VehicleFromLeft();
  const Eigen::Isometry3d world_from_right = world_from_vehicle * rig_.VehicleFromRight();
  const int s = options_.samples_per_axis;
  const int width = ImageWidth(), height = ImageHeight();

  StereoFrame frame;
  frame.pose = pose;
  const int image_type = options_.quantize ? CV_8UC1 : CV_32FC1;
  frame.left.create(height, width, image_type);
  frame.right.create(height, width, image_type);

  // The rectified pair: focal length, principal points.
  const double f = g.P_left(0, 0);
  const double cx_l = g.P_left(0, 2), cx_r = g.P_right(0, 2), cy = g.P_left(1, 2);

  for (int camera = 0; camera < 2; ++camera) {
    const bool left = camera == 0;
    const Eigen::Isometry3d& world_from_camera = left ? world_from_left : world_from_right;
    const Eigen::Vector3d centre = world_from_camera.translation();
    // Raw rays are in the camera frame; rectified rays in the rectified frame.
    const Eigen::Matrix3d world_from_ray =
        options_.mode == CameraMode::kRaw
            ? world_from_camera.linear()
            : Eigen::Matrix3d(world_from_camera.linear() * (left ? g.rect_from_left : g.rect_from_right).transpose());
    const std::vector<Eigen::Vector3f>* raw = left ? &rays_->left : &rays_->right;
    const double fx = options_.mode == CameraMode::kRaw ? (left ? rig_.left.K(0, 0) : rig_.right.K(0, 0)) : f;
    const double cx = left ? cx_l : cx_r;
    const CameraExposure& exposure = left ? options_.left_exposure : options_.right_exposure;
    cv::Mat& image = left ? frame.left : frame.right;
    tbb::parallel_for(0, height, [&](int y) {
      for (int x = 0; x < width; ++x) {
        double sum = 0;
        for (int k = 0; k < s * s; ++k) {
          Eigen::Vector3d ray;
          if (options_.mode == CameraMode::kRaw) {
            ray = (*raw)[(static_cast<std::size_t>(y) * width + x) * s * s + k].cast<double>();
          } else {
            const double px = x + ((k % s) + 0.5) / s - 0.5, py = y + ((k / s) + 0.5) / s - 0.5;
            ray = Eigen::Vector3d((px - cx) / f, (py - cy) / f, 1.0);
          }
          const Eigen::Vector3d direction = world_from_ray * ray;
          const SurfaceHit hit = scene.Trace(centre, direction, 1e-6, kMaxRange);
          // Footprint of one sample on the surface: its angular spacing times the range,
          // stretched by the obliqueness of the surface (limited to 4x).
          double footprint = 0;
          if (hit.label != SurfaceHit::kSky) {
            const double range = hit.t * direction.norm();
            const double cos_incidence = std::abs(hit.normal.dot(direction.normalized()));
            footprint = range / (fx * s) / std::sqrt(std::max(cos_incidence, 1.0 / 16));
          }
          sum += scene.Radiance(hit, footprint);
        }
        double grey = exposure.gain * 255.0 * sum / (s * s) + exposure.offset;
        if (options_.noise_sigma > 0) {
          const std::uint64_t bits =
              HashCoords(options_.seed ^ kNoiseSalt, static_cast<std::int64_t>(frame_index), camera, y, x);
          grey += options_.noise_sigma * GaussianFromBits(bits);
        }
        if (options_.quantize) {
          image.ptr<std::uint8_t>(y)[x] = static_cast<std::uint8_t>(std::clamp(std::lround(grey), 0L, 255L));
        } else {
          image.ptr<float>(y)[x] = static_cast<float>(grey);
        }
      }
    });
  }

  if (options_.compute_truth) {
    const int tw = g.width_px, th = g.height_px;
    frame.truth_disparity_px.create(th, tw, CV_32FC1);
    frame.truth_xyz_m.create(th, tw, CV_32FC3);
    frame.truth_label.create(th, tw, CV_16UC1);
    const Eigen::Matrix3d world_from_rect_right = world_from_right.linear() * g.rect_from_right.transpose();
    const Eigen::Vector3d right_centre = world_from_right.translation();
    const Eigen::Vector3d left_centre = world_from_left.translation();
    const Eigen::Isometry3d vehicle_from_world = world_from_vehicle.inverse();
    // World point -> rectified left camera frame.
    const Eigen::Matrix3d rect_left_from_world = g.rect_from_left * world_from_left.linear().transpose();
    const float nan = std::numeric_limits<float>::quiet_NaN();
    std::vector<StereoFrameStats> row_stats(th);
    tbb::parallel_for(0, th, [&](int y) {
      StereoFrameStats& st = row_stats[y];
      auto* d_row = frame.truth_disparity_px.ptr<float>(y);
      auto* xyz_row = frame.truth_xyz_m.ptr<cv::Vec3f>(y);
      auto* label_row = frame.truth_label.ptr<std::uint16_t>(y);
      for (int x = 0; x < tw; ++x) {
        ++st.pixels;
        const Eigen::Vector3d direction = world_from_rect_right * Eigen::Vector3d((x - cx_r) / f, (y - cy) / f, 1.0);
        const SurfaceHit hit = scene.Trace(right_centre, direction, 1e-6, kMaxRange);
        label_row[x] = static_cast<std::uint16_t>(hit.label);
        d_row[x] = nan;
        if (hit.label == SurfaceHit::kSky) {
          xyz_row[x] = cv::Vec3f(nan, nan, nan);
          ++st.sky;
          continue;
        }
        const Eigen::Vector3d p_vehicle = vehicle_from_world * hit.point;
        xyz_row[x] = cv::Vec3f(static_cast<float>(p_vehicle.x()), static_cast<float>(p_vehicle.y()),
                               static_cast<float>(p_vehicle.z()));
        const Eigen::Vector3d p_rect_left = rect_left_from_world * (hit.point - left_centre);
        if (!(p_rect_left.z() > 0)) {
          ++st.outside;
          continue;
        }
        const double x_l = f * p_rect_left.x() / p_rect_left.z() + cx_l;
        if (!(x_l >= -0.5 && x_l <= tw - 0.5)) {
          ++st.outside;
          continue;
        }
        // Visible from the left camera when nothing lies between the point and its centre
        // (the segment's ends are kept clear of the surface by a millimetre).
        const Eigen::Vector3d to_left = left_centre - hit.point;
        const double length = to_left.norm();
        if (scene.Occluded(hit.point, to_left, 1e-3 / length, 1.0 - 1e-3 / length)) {
          ++st.occluded;
          continue;
        }
        d_row[x] = static_cast<float>(x_l - x);
        ++st.disparity;
      }
    });
    for (const StereoFrameStats& st : row_stats) {
      frame.stats.pixels += st.pixels;
      frame.stats.sky += st.sky;
      frame.stats.occluded += st.occluded;
      frame.stats.outside += st.outside;
      frame.stats.disparity += st.disparity;
    }
  }
  frame.stats.render_s = timer.ElapsedSeconds();
  return frame;
}

StereoFrame RenderStereoFrame(const Scene& scene, const calib::StereoRig& rig, const VehiclePose& pose,
                              const StereoRenderOptions& options, std::uint64_t frame_index) {
  return StereoRenderer(rig, options).Render(scene, pose, frame_index);
}

}  // namespace lunarnav::sim
