// Test helper: stereo-batch-like XYZ maps of a known world surface seen from known poses.
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <functional>
#include <limits>
#include <opencv2/core.hpp>

#include "mapping/frame_poses.h"

namespace lunarnav::mapping::testing {

/// A world surface: z = height(x, y), metres.
using HeightFn = std::function<double(double x_m, double y_m)>;

/// An XYZ map (CV_32FC3, vehicle frame) of `height` seen from the level pose `pose` (heading
/// and position only): `cols` x `rows` points on a regular grid of vehicle X in [x0, x1],
/// Y in [y0, y1], each at the surface's height under it, in a camera's order: row 0 the
/// farthest (the top of an image), the last row the nearest.
inline cv::Mat SurfaceXyz(const HeightFn& height, const FramePose& pose, int cols = 160, int rows = 120,
                          double x0 = -3, double x1 = 3, double y0 = 2, double y1 = 10) {
  cv::Mat xyz(rows, cols, CV_32FC3);
  const Eigen::Isometry3d world_from_vehicle = pose.WorldFromVehicle();
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const double x = x0 + (x1 - x0) * (c + 0.5) / cols, y = y1 - (y1 - y0) * (r + 0.5) / rows;
      const Eigen::Vector3d w = world_from_vehicle * Eigen::Vector3d(x, y, 0);
      const double z = height(w.x(), w.y()) - pose.z_m;
      xyz.at<cv::Vec3f>(r, c) = cv::Vec3f(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z));
    }
  }
  return xyz;
}

/// As SurfaceXyz, but each point is where the ray from `camera` (vehicle frame) towards the
/// grid point on the vehicle's ground plane first meets the surface: what a camera sees, with
/// what stands in front hiding what lies behind. NaN where the ray meets nothing within 1.5
/// times its grid point's distance.
inline cv::Mat RenderedXyz(const HeightFn& height, const FramePose& pose, const Eigen::Vector3d& camera, int cols = 160,
                           int rows = 120, double x0 = -3, double x1 = 3, double y0 = 2, double y1 = 10) {
  cv::Mat xyz(rows, cols, CV_32FC3, cv::Scalar::all(std::numeric_limits<float>::quiet_NaN()));
  const Eigen::Isometry3d world_from_vehicle = pose.WorldFromVehicle();
  auto below = [&](const Eigen::Vector3d& v) {  // the ray's point v (vehicle frame) at or under the surface
    const Eigen::Vector3d w = world_from_vehicle * v;
    return w.z() <= height(w.x(), w.y());
  };
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const double x = x0 + (x1 - x0) * (c + 0.5) / cols, y = y1 - (y1 - y0) * (r + 0.5) / rows;
      const Eigen::Vector3d target(x, y, 0), step = (target - camera) * 0.002;
      Eigen::Vector3d at = camera;
      for (int k = 0; k < 750; ++k, at += step) {
        if (!below(at + step)) continue;
        Eigen::Vector3d lo = at, hi = at + step;  // bisect to the surface
        for (int b = 0; b < 30; ++b) {
          const Eigen::Vector3d mid = 0.5 * (lo + hi);
          (below(mid) ? hi : lo) = mid;
        }
        xyz.at<cv::Vec3f>(r, c) =
            cv::Vec3f(static_cast<float>(hi.x()), static_cast<float>(hi.y()), static_cast<float>(hi.z()));
        break;
      }
    }
  }
  return xyz;
}

/// A box of height `h_m` on flat ground at height `ground_m` over x in [bx0, bx1), y in [by0, by1).
inline HeightFn BoxOnPlane(double ground_m, double bx0, double bx1, double by0, double by1, double h_m) {
  return [=](double x, double y) { return x >= bx0 && x < bx1 && y >= by0 && y < by1 ? ground_m + h_m : ground_m; };
}

}  // namespace lunarnav::mapping::testing
