// Window selection from distances (Krotkov & Hebert sec. 3.3): the planner asks for data in a
// distance interval I_Y = [Y_min, Y_max]; the stereo module turns it into the subimage rows
// [y_min, y_max] and the disparity range [d_min, d_max] that hold every point of the interval.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "calib/stereo_rig.h"
#include "calib/triangulation.h"

namespace lunarnav::calib {

/// The part of the world the planner wants measured, in the vehicle frame (X right, Y forward,
/// Z up, origin at the mast base): forward distances I_Y and the heights of the objects in the
/// scene (the paper's Z_min, Z_max; parts of taller objects are simply not computed). X is
/// free: the whole lateral extent the camera sees.
struct RegionOfInterest {
  double y_min_m = 4.2;   ///< Y_min, metres. The defaults are the paper's Figure 3 averages.
  double y_max_m = 7.5;   ///< Y_max, metres; >= y_min_m.
  double z_min_m = -0.5;  ///< Z_min, metres: the lowest point of interest (a ditch).
  double z_max_m = 1.0;   ///< Z_max, metres; >= z_min_m. (The paper gives no values for Z.)
  /// Throws std::invalid_argument naming the bad bound (not finite, min > max).
  void Validate() const;
  nlohmann::json ToJson() const;
};

/// Options of SelectWindow.
struct WindowSelectionOptions {
  /// Disparities added at each end of the range, pixels (>= 0). The matcher rejects a best
  /// match at either end of the searched range (the `range_edge` rule, needed for the
  /// parabolic fit); one more disparity at each end lets the points whose disparity rounds to
  /// an end of the band still be measured.
  int disparity_margin_px = 1;
  /// The vehicle's attitude when the pair was taken (pitch nose up, roll right side down,
  /// degrees, as poses give them): the region's Y and Z are then those of the level frame at
  /// the mast base (Z along gravity, Y the vehicle's heading) rather than of the vehicle frame,
  /// so that a vehicle pitched over a rock still searches the ground ahead. 0, 0: the vehicle
  /// frame (a level vehicle). Each in (-90, 90).
  double vehicle_pitch_deg = 0;
  double vehicle_roll_deg = 0;
  /// The rotation taking vehicle axes to the level frame's: Rx(pitch) Ry(roll) (the vehicle
  /// frame's pose in the world without its heading and position).
  Eigen::Matrix3d LevelFromVehicle() const;
  void Validate() const;
};

/// The subimage and disparity range of a region (all bounds inclusive).
struct ImageWindow {
  /// False when no point of the region projects into the reference image (the band is then
  /// empty: max < min).
  bool visible = false;
  int min_row = 0, max_row = -1;                    ///< Rows of the reference image.
  int min_disparity_px = 0, max_disparity_px = -1;  ///< Disparities to search (with the margin).
  /// The exact extremes over the region before rounding: rows and disparities, pixels.
  double row_extent[2] = {0, 0};
  double disparity_extent_px[2] = {0, 0};
  /// True when the region comes so near the camera that its disparities exceed what any
  /// pixel can match inside the other image (|d| > width - 1); the range is cut there.
  bool disparity_clipped = false;
  int image_width_px = 0, image_height_px = 0;

  int Rows() const { return visible ? max_row - min_row + 1 : 0; }
  int Disparities() const { return visible ? max_disparity_px - min_disparity_px + 1 : 0; }
  /// Share of the image's rows in the band, [0, 1].
  double RowFraction() const;
  /// Share of an inclusive disparity range [d_min, d_max] (e.g. the full search without window
  /// selection) that the band searches.
  double DisparityFraction(int full_min_px, int full_max_px) const;
  nlohmann::json ToJson() const;
};

/// Computes the row band and disparity range that contain every point of `region` visible in
/// the reference image of a rectified rig.
///
/// The paper projects the boundary points (x = 0 and x = dim_x, Y = Y_min/max, Z = Z_min/max)
/// into both images. That is exact only when the lines of constant Y and Z meet the image's
/// left and right edges inside the image. In general the region seen by the camera is the
/// polytope {Y_min <= Y <= Y_max, Z_min <= Z <= Z_max} cut by the four planes through the
/// optical centre and the image edges (x = -0.5, x = width - 0.5, y = -0.5, y = height - 0.5,
/// pixel centres at integers). Image row y is a ratio of affine functions of the point and the
/// disparity d = f B / depth + (c_left - c_right) a monotone function of the (affine) depth, so
/// both reach their extremes at the polytope's vertices: every intersection of three of those
/// planes that satisfies all the constraints. (A far plane at 10^5 m bounds the polytope when
/// the X axis's vanishing point lies inside the image; a near plane at 1 mm keeps it in front
/// of the camera.) The extremes are rounded outward to whole rows (the pixel a point falls
/// in) and whole disparities, the disparity range is widened by the margin, and rows are
/// clipped to the image.
/// @param rig  a rectified rig (std::invalid_argument otherwise).
/// @param reference  the image the disparity map is referenced to (rows are shared; the
///        lateral extent is that of this image).
ImageWindow SelectWindow(const StereoRig& rig, const RegionOfInterest& region, ReferenceImage reference,
                         const WindowSelectionOptions& options = {});

/// Options of SelectGroundWindow.
struct GroundWindowOptions {
  /// Heights of the objects to measure, metres (the region's Z_min, Z_max).
  double z_min_m = -0.5;
  double z_max_m = 1.0;
  /// The far limit: a ground point is measured while the range error of a disparity error of
  /// sigma_d_px (sigma_d Z^2 / (f B), along the ray) stays within this many metres. The
  /// default, one cell of the paper's 25 cm terrain map, with sigma_d = 1 px: farther, a
  /// point's error spans more than a cell.
  double max_range_error_m = 0.25;
  double sigma_d_px = 1.0;
  /// Each row also searches, below its band, the disparities of the same slab out to this
  /// many times the far limit's distance (a guard: the ground beyond the far limit, seen in
  /// the upper rows, finds its match there rather than a false one inside the band, and is
  /// then rejected), >= 1; 1 = no guard.
  double guard_distance_factor = 3.0;
  /// The guard also searches below the heights: its floor sinks below z_min_m by the tangent
  /// of this angle per metre of Y, degrees, in [0, 45). The region's heights are relative to
  /// the vehicle's base plane; a vehicle pitched up, or ground falling away beyond a crest,
  /// puts the ground of the upper rows below z_min_m there (2.8 deg of pitch on the way up to
  /// a crest), where the band alone forced a false match at its far end: a wall of points
  /// 20-30 cm tall (seed 7 of scripts/bench-terrain-map: 34 false obstacle cells of 56).
  /// Ground farther below is matched into the guard's lowest disparities (nearer its own than
  /// the band's) and rejected there too.
  double guard_tilt_deg = 2.0;
  /// A guard above each band, for objects taller than z_max_m standing in the region: each row
  /// also searches the disparities of the heights z_max_m to z_max_m + tall_guard_m at the
  /// region's distances, and what matches there is rejected (beyond_near). A post taller than
  /// the heights, whose upper part lies above a row's band, is then matched where it stands
  /// rather than smeared by the aggregation into the band's top beside it (raw KITTI drive
  /// 0005: a keep-right sign's post 1.1 m up at 6 m, its shadow matched 1 m behind it).
  /// Metres, in [0, 100]; 0: none. The default widens the upper rows' search (matching 6-22 %
  /// slower on the real drives) and keeps every simulated traverse's rocks.
  double tall_guard_m = 1.5;
  void Validate() const;
};

/// The part of the world a rig's stereo is worth running on, and the search it needs.
struct GroundWindow {
  GroundWindowOptions options;  ///< What it was made with (to make it again for another attitude).
  /// Y from the nearest ground both cameras see (the flat ground Z = 0 in the vehicle frame)
  /// to the far limit, Z from the options.
  RegionOfInterest region;
  double far_limit_depth_m = 0;      ///< Depth (rectified frame) at which the range error reaches the bound.
  double guard_y_max_m = 0;          ///< The guard's far end, Y (guard_distance_factor times the region's reach).
  double guard_distance_factor = 1;  ///< The guard's reach (GroundWindowOptions).
  double guard_tilt_deg = 0;         ///< How the guard's floor sinks below Z_min (GroundWindowOptions).
  /// SelectWindow over the region: the row band and the one disparity range that hold it
  /// (without the guard).
  ImageWindow window;
  int guard_min_disparity_px = 0;  ///< The least disparity of the bands, guard included.
  /// Per reference-image row (size: the image's height), the disparities of the region's
  /// points seen in that row and, below them, the guard's (with the margin, within
  /// [guard_min_disparity_px, window.max_disparity_px]); {0, -1} = none, which only rows
  /// outside the window's rows have.
  std::vector<std::pair<int, int>> row_disparity_px;
  /// Per row, the least disparity accepted (the region's far limit; the band extends below
  /// it by the guard); 0 for rows without a band.
  std::vector<int> row_accept_min_px;
  /// With a tall guard (GroundWindowOptions::tall_guard_m > 0): per row, the greatest
  /// disparity accepted (the band extends above it by the tall guard); empty without.
  std::vector<int> row_accept_max_px;
  int guard_max_disparity_px = 0;  ///< The greatest disparity of the bands, tall guard included.
  nlohmann::json ToJson() const;
};

/// Per reference-image row, the disparities of a region's points on that row's rays, and below
/// them a far guard (the heights up to the region's Z_max, out to guard_distance_factor times
/// the region's reach, above a floor that sinks below Z_min by tan(guard_tilt_deg) per metre
/// of Y).
struct RowBands {
  double guard_y_max_m = 0;  ///< The guard's far end, Y.
  /// Per row (size: the image's height): the band searched, guard included, within
  /// [guard_min_disparity_px, guard_max_disparity_px]; {0, -1} = none (rows outside the window).
  std::vector<std::pair<int, int>> row_disparity_px;
  /// Per row, the least disparity accepted (the region's far end); 0 for rows without a band.
  std::vector<int> row_accept_min_px;
  /// Per row, the greatest disparity accepted (the region's near end); above it, up to the
  /// band's end, the near guard.
  std::vector<int> row_accept_max_px;
  int guard_min_disparity_px = 0;  ///< The least disparity of the bands.
  int guard_max_disparity_px = 0;  ///< The greatest disparity of the bands.
};
/// The bands of `region` in `window` (SelectWindow's for that region): each column's ray
/// crosses the slab (Y and Z within the region, depth > 0) along a segment whose ends bound its
/// disparities; a row of the window whose pixel centres' rays miss the region takes the band of
/// the nearest row that has one. guard_distance_factor >= 1 and guard_tilt_deg = 0 (1, 0 = no
/// far guard); guard_tilt_deg in [0, 45). near_guard_factor >= 1: above each band, a near
/// guard, the heights from y_min_m / near_guard_factor (from the camera's Y) to the region
/// (1 = none; a requested window's lower rows see ground nearer than its interval).
/// tall_guard_m >= 0: above each band also the heights z_max_m to z_max_m + tall_guard_m at
/// the region's distances (GroundWindowOptions::tall_guard_m; 0 = none).
RowBands SelectRowBands(const StereoRig& rig, ReferenceImage reference, const RegionOfInterest& region,
                        const ImageWindow& window, double guard_distance_factor, double guard_tilt_deg = 0.0,
                        double near_guard_factor = 1.0, const WindowSelectionOptions& selection = {},
                        double tall_guard_m = 0.0);

/// stereo-batch's default search with a rig (docs/stereo-batch.md): the region of the ground
/// the rig sees, from the nearest ground point that projects inside both images to the far
/// limit, with the objects' heights; its window (SelectWindow), and per row the disparities of
/// the region's points on that row's rays (each ray crosses the slab Z_min <= Z <= Z_max,
/// Y_min <= Y <= Y_max along a segment whose ends bound its disparities).
/// @throws std::invalid_argument when the rig is not rectified or sees no ground.
GroundWindow SelectGroundWindow(const StereoRig& rig, ReferenceImage reference, const GroundWindowOptions& options,
                                const WindowSelectionOptions& selection = {});

}  // namespace lunarnav::calib
