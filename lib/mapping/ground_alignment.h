// Attitude from the ground: each stereo pair's view of terrain the map already holds is a
// measurement of the vehicle's height, pitch and roll relative to that map (Krotkov & Hebert
// sec. 3 and 4 together). Dead reckoning's attitude comes from inclinometers, which read the
// vehicle's accelerations as tilt and are low-passed (0.5-1 deg off at the frame times on a
// rocky drive: 9-17 cm of height at 10 m); a pair placed with such a pose disagrees with the
// pairs before it, and the map grows false steps where they overlap. Before a pair is fused,
// its points (a sample of its pixels) are compared cell by cell with the ground the pairs
// before it mapped, and a robust fit of the height differences to a plane through the
// vehicle (an offset and two slopes) gives the rotation about the vehicle and the vertical
// shift that bring the pair onto the map; the corrected pose places the pair.
//
// The reference is the aligner's own: per cell of the map's lattice, the mean of each aligned
// pair's samples in it (one observation per pair), so alignment runs before fusion and does
// not depend on how the fusion is split across threads; pairs are aligned in time order.
#pragma once

#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "mapping/frame_poses.h"

namespace lunarnav::mapping {

struct GroundAlignmentOptions {
  int stride_px = 4;            ///< Every stride-th pixel of every stride-th row is sampled, >= 1.
  /// The samples used: horizontally this far from the vehicle, metres.
  double min_range_m = 1.0, max_range_m = 12.0;
  int min_samples_per_cell = 3;  ///< A pair's own height of a cell needs this many samples, >= 1.
  int min_cells = 30;            ///< Cells shared with the reference for a fit, >= 3.
  /// The robust loss's scale floor, metres (the scale is max(this, 1.48 MAD of the residuals)), > 0.
  double robust_m = 0.03;
  /// A correction larger than these is refused: a tilt of more than max_tilt_deg or a shift of
  /// more than max_shift_m is no inclinometer error (a low-passed inclinometer lags a wheel
  /// climbing a rock by 5-6 deg), but a pair that matched something else than the ground in
  /// common. The pair keeps its pose, says so (GroundAlignment::contradicts) and stays out of
  /// the reference.
  double max_tilt_deg = 15.0, max_shift_m = 0.5;
  /// The fraction of the fitted correction applied, in (0, 1]: below 1, the inclinometers'
  /// absolute attitude keeps a hold on a chain of corrections.
  double gain = 1.0;
  /// The tilt's prior (radians, RMS): with ground in common that spreads along the view it
  /// weighs nothing; with a band of one distance (map-loop's requests) it picks the least tilt
  /// that explains the shift there, > 0.
  double tilt_prior_rad = 2.0 * M_PI / 180.0;
  void Validate() const;  ///< std::invalid_argument naming the field.
  nlohmann::json ToJson() const;
};

/// What aligning one pair did.
struct GroundAlignment {
  std::string stem;
  bool applied = false;
  /// The fit asked for more than the largest correction: the pair's pose (or its points)
  /// contradicts the map.
  bool contradicts = false;
  std::string reason;          ///< Why not, when not applied ("no ground in common", ...).
  int cells = 0;               ///< Cells shared with the reference.
  double shift_m = 0;          ///< Vertical shift at the vehicle, metres.
  double tilt_x_deg = 0, tilt_y_deg = 0;  ///< Rotation about the world's x and y axes, degrees.
  double rms_before_m = 0, rms_after_m = 0;  ///< Robust RMS of the cells' differences (inliers).
  nlohmann::json ToJson() const;
};

class GroundAligner {
 public:
  GroundAligner(double cell_m, const GroundAlignmentOptions& options);

  /// Adds a cell height of earlier data (a resumed map) to the reference: one observation.
  void AddReference(double x_m, double y_m, double z_m);

  /// Aligns a pair given its estimated pose and its vehicle-frame points (a sample of its
  /// pixels, finite), then adds its samples, placed by the returned pose, to the reference.
  /// @return the pose to place the pair with (the estimated one when no correction applies).
  FramePose Align(const FramePose& estimated, const std::vector<Eigen::Vector3f>& vehicle_points,
                  GroundAlignment* record);

  const GroundAlignmentOptions& options() const { return options_; }

 private:
  struct Sum {
    double z = 0;
    int pairs = 0;
  };
  std::uint64_t Key(double x, double y) const;
  double cell_m_;
  GroundAlignmentOptions options_;
  std::unordered_map<std::uint64_t, Sum> reference_;
};

/// The pose whose world-from-vehicle transform is `world_from_vehicle` (heading, pitch and roll
/// of the convention of FramePose::WorldFromVehicle), keeping `like`'s stem and time.
FramePose PoseFromTransform(const Eigen::Isometry3d& world_from_vehicle, const FramePose& like);

/// A pair's points sampled for alignment: every stride-th pixel of every stride-th row of a
/// vehicle-frame XYZ array (CV_32FC3), finite ones only.
std::vector<Eigen::Vector3f> SampleXyz(const cv::Mat& xyz_vehicle, int stride_px);

}  // namespace lunarnav::mapping
