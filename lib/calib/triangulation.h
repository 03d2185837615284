// Disparity to 3-D points in the vehicle frame, and the error a disparity error causes
// (Krotkov & Hebert sec. 3.2).
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "calib/stereo_rig.h"

namespace lunarnav::calib {

/// Which image a disparity map is referenced to. Either way d = x_left - x_right.
enum class ReferenceImage {
  kRight,  ///< The paper's convention: the map is in right-image pixels, x_l = x_r + d.
  kLeft    ///< The map is in left-image pixels, x_r = x_l - d.
};
std::string ToString(ReferenceImage reference);
/// "right" or "left"; throws std::invalid_argument otherwise.
ReferenceImage ReferenceImageFromString(const std::string& name);

/// Triangulates a disparity map of the rectified pair.
///
/// With the rectified projections P_l = [f 0 c_l 0; 0 f c_y 0; 0 0 1 0] and
/// P_r = [f 0 c_r -f B; ...], a pixel (x, y) with disparity d lies at depth
/// Z = f B / (d - (c_l - c_r)) in the rectified left frame, X = (x - c) Z / f (+ B for a
/// right-referenced map, whose rays start at the right camera), Y = (y - c_y) Z / f; the
/// point is then taken to the vehicle frame through the rectifying rotation and the mast.
/// Works for maps of any grid (subsampled maps are NaN off the grid).
/// @param rig  a rectified rig (rig.rectified set); throws std::invalid_argument otherwise.
/// @param disparity_px  CV_32FC1 in the rectified size; NaN or +-inf = no disparity.
/// @return CV_32FC3 (X, Y, Z) metres in the vehicle frame; NaN where there is no point
///         (no disparity, or a disparity at or beyond infinity).
cv::Mat TriangulateDisparity(const StereoRig& rig, const cv::Mat& disparity_px, ReferenceImage reference);

/// The X, Y, Z error (metres, vehicle frame, absolute per axis) that a disparity error of
/// sigma_d_px causes at each point: |dP/dd| sigma_d, with dP/dd = -(Z / (f B)) (P - C_ref),
/// C_ref the reference camera's centre (the error runs along the viewing ray; its size grows
/// as the square of the distance). Same layout as TriangulateDisparity.
cv::Mat PredictXyzSigma(const StereoRig& rig, const cv::Mat& disparity_px, ReferenceImage reference,
                        double sigma_d_px);

/// Where a vehicle-frame point appears in the rectified pair: the reference image's pixel
/// (x, y) and the disparity d = x_left - x_right; depth_m is its depth in the rectified frame
/// (<= 0: behind the cameras, x y d then meaningless). The pixel may lie outside the image.
struct RectifiedProjection {
  double x_px = 0, y_px = 0, disparity_px = 0, depth_m = 0;
};
RectifiedProjection ProjectToRectified(const StereoRig& rig, const Eigen::Vector3d& point_vehicle,
                                       ReferenceImage reference);

/// PredictXyzSigma for one vehicle-frame point (in front of the cameras; the point need not be
/// inside the image): |dP/dd| sigma_d per axis, metres. The same value PredictXyzSigma gives
/// at the point's pixel and disparity.
Eigen::Vector3d PredictPointSigma(const StereoRig& rig, const Eigen::Vector3d& point_vehicle,
                                  ReferenceImage reference, double sigma_d_px);

/// Per row of the rectified reference image, the disparity of the ground the vehicle stands on
/// (the plane Z = 0 of the vehicle frame) on the image's centre column; NaN for rows whose ray
/// there meets no ground ahead (at or above the horizon). The ground's disparity is affine in
/// the pixel, so neighbouring rows differ by its slope (SgmInput::row_ground).
std::vector<float> GroundDisparityByRow(const StereoRig& rig, ReferenceImage reference);

}  // namespace lunarnav::calib
