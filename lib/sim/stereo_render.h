// Stereo pairs of a simulated scene by CPU ray casting, with exact ground truth
// (Krotkov & Hebert sec. 3.1-3.4: the rig, the vehicle frame, the right-referenced disparity).
//
// Cameras come from a calib::StereoRig placed on the vehicle (VehicleFromLeft/Right) at a
// VehiclePose in the world. Two geometries:
//  - kRaw: each camera with its own intrinsics and OpenCV lens distortion, and the rig's
//    small rotation between the cameras; pixel rays come from undistorting the pixel
//    position. These images need rectification (calib::Rectifier) before matching.
//  - kRectified: the ideal rectified pair of the rig's rectified geometry (P_left, P_right,
//    rect_from_left), as a matcher sees it after rectification.
// Each pixel integrates S x S rays on a regular sub-pixel grid (pixel centres at integer
// coordinates), so sub-pixel disparity is real.
//
// Ground truth always lives on the rectified right image's grid (what `rectify` produces and
// stereo-batch matches, in either mode), from the ray through each pixel's centre:
//  - truth_xyz_m: the surface point in the vehicle frame (metres), NaN for sky;
//  - truth_disparity_px: x_l - x_r, the paper's convention x_l = x_r + d, with x_l the point
//    projected by P_left; NaN for sky, where the point is hidden from the rectified left
//    camera (a shadow ray to its centre hits a surface) or projects outside its image
//    (x_l outside [-0.5, width - 0.5]);
//  - truth_label: SurfaceHit labels (0 sky, 1 terrain, 2 + k box k).
// Triangulating truth_disparity_px with calib::TriangulateDisparity (reference right) gives
// truth_xyz_m back.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "calib/stereo_rig.h"
#include "sim/scene.h"
#include "sim/vehicle_pose.h"

namespace lunarnav::sim {

/// Which camera geometry the images are rendered in.
enum class CameraMode {
  kRaw,       ///< Distorted, unrectified cameras of the rig ("raw").
  kRectified  ///< The ideal rectified pair ("rectified").
};
std::string ToString(CameraMode mode);
/// "raw" or "rectified"; std::invalid_argument otherwise.
CameraMode CameraModeFromString(const std::string& name);

/// Photometric response of one camera: grey = gain * 255 * radiance + offset (8-bit grey
/// levels), the auto-iris difference between the cameras.
struct CameraExposure {
  double gain = 1.0;    ///< > 0.
  double offset = 0.0;  ///< Grey levels.
};

struct StereoRenderOptions {
  CameraMode mode = CameraMode::kRaw;
  /// S: rays per pixel are an S x S grid of sub-pixel positions, 1..8 (default 4 rays).
  int samples_per_axis = 2;
  CameraExposure left_exposure{1.0, 0.0};
  CameraExposure right_exposure{0.94, 5.0};  ///< A mild auto-iris difference.
  /// Gaussian sensor noise, standard deviation in grey levels, >= 0 (0 = off); independent
  /// per pixel and camera.
  double noise_sigma = 1.0;
  /// true: CV_8UC1 images (rounded, clamped to 0..255); false: CV_32FC1 grey levels
  /// (unrounded, unclamped).
  bool quantize = true;
  /// Whether to compute the truth maps (about a quarter of the render time).
  bool compute_truth = true;
  std::uint64_t seed = 1;  ///< Noise seed (with the frame index).

  void Validate() const;  ///< std::invalid_argument naming the field.
  nlohmann::json ToJson() const;
};

/// Counts over the truth maps (rectified right grid).
struct StereoFrameStats {
  long pixels = 0;
  long sky = 0;          ///< No surface.
  long occluded = 0;     ///< Hidden from the rectified left camera.
  long outside = 0;      ///< Visible but projecting outside the left image.
  long disparity = 0;    ///< Finite truth disparity.
  double render_s = 0;   ///< Wall-clock time of the render.
  nlohmann::json ToJson() const;
};

/// One rendered pair and its ground truth (see the file comment for the truth definitions).
struct StereoFrame {
  cv::Mat left, right;          ///< Raw or rectified per mode; CV_8UC1 or CV_32FC1.
  cv::Mat truth_disparity_px;   ///< CV_32FC1, rectified right grid, NaN where invalid.
  cv::Mat truth_xyz_m;          ///< CV_32FC3 vehicle frame, rectified right grid, NaN for sky.
  cv::Mat truth_label;          ///< CV_16UC1 SurfaceHit labels, rectified right grid.
  VehiclePose pose;
  StereoFrameStats stats;
};

/// Renders pairs of one rig with fixed options; reuse it across the frames of a sequence.
/// Thread-safe: Render may run concurrently. Output does not depend on the thread count.
class StereoRenderer {
 public:
  /// @param rig  a rectified rig (calib::RectifyRig; throws std::invalid_argument otherwise).
  StereoRenderer(const calib::StereoRig& rig, const StereoRenderOptions& options);

  /// Renders the pair seen from `pose` (rows in parallel on the current TBB arena).
  /// @param frame_index  selects the noise of this frame (with options.seed).
  StereoFrame Render(const Scene& scene, const VehiclePose& pose, std::uint64_t frame_index = 0) const;

  const calib::StereoRig& rig() const { return rig_; }
  const StereoRenderOptions& options() const { return options_; }
  /// Size of the rendered images: the raw size (kRaw) or the rectified size (kRectified).
  int ImageWidth() const;
  int ImageHeight() const;

 private:
  struct Rays;  // raw mode: the undistorted ray of every sub-pixel sample, computed once
  calib::StereoRig rig_;
  StereoRenderOptions options_;
  std::shared_ptr<const Rays> rays_;
};

/// One pair: StereoRenderer(rig, options).Render(scene, pose, frame_index).
StereoFrame RenderStereoFrame(const Scene& scene, const calib::StereoRig& rig, const VehiclePose& pose,
                              const StereoRenderOptions& options, std::uint64_t frame_index = 0);

}  // namespace lunarnav::sim
