// Rig files: lunarnav's JSON (docs/formats.md, "Rig file") and OpenCV's calibration YAML.
#pragma once

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "calib/stereo_rig.h"

namespace lunarnav::calib {

/// The rig as JSON ("format": "lunarnav.rig/1").
nlohmann::json StereoRigToJson(const StereoRig& rig);

/// Parses and validates a rig. Unknown fields, missing fields, wrong shapes and impossible
/// values are InputErrors naming `source` and the field.
StereoRig StereoRigFromJson(const nlohmann::json& j, const std::string& source);

StereoRig ReadStereoRig(const std::filesystem::path& path);
void WriteStereoRig(const std::filesystem::path& path, const StereoRig& rig);

/// Imports OpenCV's stereo calibration, as its stereo_calib sample writes it: M1 D1 M2 D2 in
/// `intrinsics`, R T (and, if present, R1 R2 P1 P2 from stereoRectify) in `extrinsics`.
/// The files do not hold the image size, and T (and P2's baseline term) is in the units of the
/// calibration target's squares: give both.
/// @param metres_per_unit  metres per unit of T (the square size, when the sample's default
///        square size of 1 was used). > 0.
StereoRig ReadOpenCvCalibration(const std::filesystem::path& intrinsics,
                                const std::filesystem::path& extrinsics, int width_px,
                                int height_px, double metres_per_unit, const MastPose& mast);

}  // namespace lunarnav::calib
