// Rig files from the calibration formats users already have (docs/formats.md, "Imported
// calibrations"): OpenCV's stereo_calib YAML, a ROS camera_info YAML pair, a Kalibr camchain,
// a Middlebury 2014 calib.txt and a KITTI calib_cam_to_cam.txt. `calibrate --from FORMAT`.
#pragma once

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "calib/stereo_rig.h"

namespace lunarnav::calib {

/// A calibration format that `calibrate --from` reads.
enum class RigFormat {
  kOpenCv,      ///< intrinsics.yml + extrinsics.yml of OpenCV's stereo_calib sample.
  kRos,         ///< left.yaml + right.yaml: ROS camera_info (camera_calibration's files or a message).
  kKalibr,      ///< camchain.yaml of Kalibr (pinhole-radtan, cam0 = left, cam1 = right).
  kMiddlebury,  ///< calib.txt of the Middlebury 2014 stereo datasets (rectified).
  kKitti        ///< KITTI: the raw format's calib_cam_to_cam.txt or the odometry calib.txt (rectified).
};

/// Which of KITTI's two rectified pairs a KITTI calibration describes.
enum class KittiPair {
  kColour,  ///< cameras 2 (left) and 3 (right): P_rect_02/03, or the odometry P2/P3.
  kGrey     ///< cameras 0 (left) and 1 (right): P_rect_00/01, or the odometry P0/P1.
};
/// Name -> pair, for CLI11: colour, grey.
std::map<std::string, KittiPair> KittiPairNames();
std::string ToString(RigFormat format);
/// Name -> format, for CLI11's CheckedTransformer: opencv, ros, kalibr, middlebury, kitti.
std::map<std::string, RigFormat> RigFormatNames();
/// How many files the format takes (2 for opencv and ros, 1 for the others).
int RigFormatFileCount(RigFormat format);

struct RigImportOptions {
  RigFormat format = RigFormat::kOpenCv;
  /// The format's files, in the order RigFormatFileCount describes (left before right).
  std::vector<std::filesystem::path> files;
  MastPose mast;  ///< Written to the rig as given: no format holds it.
  /// opencv only (its files hold neither): the raw image size, and the metres per unit of T.
  /// (For kitti's odometry calib.txt, which holds no size, the image size: without it, the
  /// size of the first image in the pair's folder beside calib.txt, image_0/ or image_2/.)
  std::optional<std::pair<int, int>> image_size_px;
  double metres_per_unit = 1.0;
  /// kitti only: the pair to import.
  KittiPair kitti_pair = KittiPair::kColour;

  /// @throws std::invalid_argument naming the option (--from, --image-size, --square).
  void Validate() const;
  nlohmann::json ToJson() const;
};

/// Reads a ROS camera_info pair. Each file is either the YAML that ROS's camera_calibration
/// writes (image_width, image_height, camera_matrix, distortion_model, distortion_coefficients,
/// rectification_matrix, projection_matrix; each matrix as rows, cols, data) or a CameraInfo
/// message as YAML (width, height, distortion_model, D, K, R, P; d k r p in ROS 2). The rig
/// takes K and D as the raw cameras, R and P as the rectified geometry (OpenCV's R1 R2 P1 P2;
/// the right P's P[0][3] = -f' B with B in metres), and the pose between the raw cameras from
/// them: R = R_right^T R_left, t = R_right^T (P_right[0][3] / f', 0, 0).
/// @throws InputError naming the file and the field.
StereoRig ReadRosCameraInfoPair(const std::filesystem::path& left, const std::filesystem::path& right,
                                const MastPose& mast);

/// Reads a Kalibr camchain (cam0 the left camera, cam1 the right): camera_model pinhole,
/// intrinsics [fu fv pu pv], distortion_model radtan with distortion_coeffs [k1 k2 r1 r2]
/// (OpenCV's k1 k2 p1 p2), resolution [w h], and cam1.T_cn_cnm1, the 4x4 transform taking
/// cam0 coordinates to cam1 coordinates (metres): right_from_left. No rectified geometry.
/// @throws InputError naming the file and the field (another model is refused by name).
StereoRig ReadKalibrCamchain(const std::filesystem::path& camchain, const MastPose& mast);

/// Reads a Middlebury 2014 calib.txt: cam0, cam1 ([f 0 cx; 0 f cy; 0 0 1]), doffs (cx1 - cx0,
/// pixels), baseline (millimetres), width, height (other keys ignored). The images are
/// rectified, so the rig is its own rectification: no distortion, R = I, t = (-B, 0, 0), P_left
/// = [cam0 | 0], P_right = [cam1 | (-f B, 0, 0)]; triangulation's Z = f B / (d + doffs) is
/// Middlebury's own.
/// @throws InputError naming the file, the line and the key.
StereoRig ReadMiddleburyCalib(const std::filesystem::path& calib_txt, const MastPose& mast);

/// Reads a KITTI calibration for one of its rectified pairs (`pair`):
/// - the raw format's calib_cam_to_cam.txt: S_rect_0L (size), P_rect_0L (left) and P_rect_0R
///   (right), L, R = 2, 3 (colour) or 0, 1 (grey);
/// - the odometry format's calib.txt: PL and PR (L, R = 2, 3 or 0, 1), which hold no size:
///   `image_size_px`, or the size of the first image of the pair's folder beside calib.txt
///   (image_2/ or image_0/).
/// The projections are [f 0 cx f t_x; 0 f cy f t_y; 0 0 1 t_z] in the rectified frame of camera
/// 0. Each camera's centre there is t = K^-1 P[:, 3]; the baseline is the x offset between the
/// two (within 0.01 % of the usual (P_L[0][3] - P_R[0][3]) / f); their millimetre offsets along y
/// and z are dropped, with a note. Rectified like Middlebury's.
/// @throws InputError naming the file, the line and the key.
StereoRig ReadKittiCalib(const std::filesystem::path& calib_txt, const MastPose& mast, KittiPair pair,
                         const std::optional<std::pair<int, int>>& image_size_px = std::nullopt);

/// Reads the options' files in their format (ReadOpenCvCalibration for opencv).
StereoRig ImportRig(const RigImportOptions& options);

/// What RunRigImport wrote.
struct RigImportRun {
  StereoRig rig;
  std::filesystem::path rig_path, summary_path;
  double seconds = 0;
  std::string BriefReport() const;  ///< e.g. "imported middlebury calib.txt: rectified, baseline 0.1763 m".
};

/// `calibrate --from`: imports the files and writes the rig file and summary.json atomically
/// (mode "import", format, inputs, options, outputs, the rig's notes and its baseline).
RigImportRun RunRigImport(const RigImportOptions& options, const std::filesystem::path& rig_path,
                          const std::filesystem::path& summary_path, const nlohmann::json& invocation = nullptr);

}  // namespace lunarnav::calib
