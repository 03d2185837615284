// The box experiment of Krotkov & Hebert (1995) sec. 3.4, Figure 4: boxes whose front faces
// are parallel to the X axis at known distances; E_Y is the RMS difference between the
// measured Y of the points on a face and the face's true (tape-measured) Y.
#pragma once

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "evaluation/disparity_eval.h"
#include "evaluation/table.h"

namespace lunarnav::evaluation {

/// A box face as a tape measure gives it, in the vehicle frame (X right, Y forward, Z up, m).
struct BoxFace {
  int index = 0;
  double front_y_m = 0;
  double x_min_m = 0, x_max_m = 0, z_min_m = 0, z_max_m = 0;
};

/// A box list (format "lunarnav.boxes/1", docs/formats.md): `boxes` for every frame, and
/// per-frame lists under `frames` (stem -> faces) when the vehicle moved.
struct BoxList {
  std::vector<BoxFace> boxes;
  std::map<std::string, std::vector<BoxFace>> frames;
  /// The faces of frame `stem`: its own list if there is one, else `boxes`.
  const std::vector<BoxFace>& For(const std::string& stem) const;
};
/// @throws InputError naming the file and the entry.
BoxList ReadBoxList(const std::filesystem::path& path);

/// The Y gate of a box evaluation without per-pixel truth: what lies beyond or in front of a
/// face inside its X-Z extent is another surface; 10 % is half the spacing of the paper's
/// boxes at 5 m, and 8 px of disparity error at 8 m.
constexpr double kDefaultYGateFraction = 0.10;

struct BoxesEvalOptions {
  /// Points within this margin (m) of a face's X or Z edges are not used: the edge pixels mix
  /// the face with what lies beside, above or below it.
  double edge_margin_m = 0.05;
  /// When set, a face's point is dropped (and counted in FaceErrors::gated_out) when its
  /// measured Y is more than this fraction of the true Y from the true Y; in (0, 1). Unset:
  /// no gate with per-pixel truth, kDefaultYGateFraction without (EffectiveYGate).
  std::optional<double> y_gate_fraction;
  void Validate() const;
  /// The gate in force: y_gate_fraction, or without per-pixel truth kDefaultYGateFraction.
  std::optional<double> EffectiveYGate(bool with_truth) const;
};

/// What a simulated frame's pixels truly see, on the rectified right image's full grid
/// (simulate stereo's truth/labels and truth/xyz).
struct BoxTruth {
  cv::Mat labels;  ///< CV_16UC1: 0 sky, 1 terrain, 2 + k box k (BoxFace::index k).
  cv::Mat xyz;     ///< CV_32FC3: the true point in the vehicle frame, metres.
};

/// Sums over the points of one face in one or more maps.
struct FaceErrors {
  long points = 0;
  double sum_error = 0, sum_sq_error = 0;  ///< Of (measured Y - true Y), metres.
  long gated_out = 0;                      ///< Points of the face the Y gate dropped (not in `points`).
  void Add(const FaceErrors& other);
  double Rms() const;   ///< E_Y; NaN without points.
  double Mean() const;  ///< The bias; NaN without points.
  double GatedOutShare() const;  ///< gated_out / (points + gated_out); NaN when both are 0.
};

/// The errors of each face (same order as `faces`) in one XYZ map (CV_32FC3, vehicle frame,
/// NaN where there is no point; the full image or the samples of `grid`, as disparity maps).
/// With `truth`, a face's points are the pixels whose label is the face's box and whose true
/// point lies on the front face (true Y within 1 mm of front_y_m: exact for a level vehicle
/// heading north, as the boxes preset; a tilted face has few such pixels) inside its X-Z
/// extent less the edge margin; without, the points whose measured X and Z lie inside that extent. Either
/// way the Y gate in force (BoxesEvalOptions::EffectiveYGate) then drops and counts points.
/// @throws std::invalid_argument for bad options, maps of the wrong type, or a truth whose
///         size is not the grid's image.
std::vector<FaceErrors> EvaluateBoxFaces(const cv::Mat& xyz, const std::vector<BoxFace>& faces,
                                         const BoxesEvalOptions& options, const BoxTruth* truth = nullptr,
                                         const SampleGrid& grid = {});

/// One run of stereo-batch (one subsampling) scored over all its frames: per box distance
/// (the true Y rounded to the centimetre), the pooled errors.
struct BoxRunResult {
  std::string name;        ///< e.g. "dx5_dy4".
  int step_x = 1, step_y = 1;
  std::map<long, FaceErrors> by_distance_cm;
};

/// Figure 4's table: one row per distance, E_Y, bias, points and the share of points the Y
/// gate dropped per run, and the predicted error of the rig for a one-pixel disparity error
/// where given (distance -> metres). The notes say how points were selected (`with_truth`)
/// and which gate was in force.
Table BoxesTable(const std::vector<BoxRunResult>& runs, const std::map<long, double>& predicted_m,
                 const BoxesEvalOptions& options = {}, bool with_truth = false);

/// The inputs and options of `evaluate boxes` (docs/evaluate.md).
struct BoxesCommand {
  std::vector<std::filesystem::path> runs;  ///< stereo-batch output directories run with --rig.
  std::filesystem::path boxes;              ///< The box list.
  std::filesystem::path rig;                ///< Rectified rig for the predicted error; empty for none.
  /// simulate stereo's truth directory (labels/<stem>.png, xyz/<stem>.exr): select each face's
  /// points by the truth; empty for none (tape-measured boxes: the Y gate separates surfaces).
  std::filesystem::path truth;
  std::filesystem::path output_dir;
  double sigma_d_px = 1.0;  ///< Disparity error of the predicted curve (px), > 0.
  BoxesEvalOptions options;
};

/// `evaluate boxes`: every run's XYZ maps scored against the box list; writes the boxes
/// table and figure and summary.json (`summary_head` plus inputs, options, counts, table,
/// figures).
/// @return kExitOk, or kExitBatchPartial when some maps could not be scored.
/// @throws std::invalid_argument for bad options or a rig that is not rectified; InputError for
///         an unreadable box list, rig or run.
int RunBoxesCommand(const BoxesCommand& command, const nlohmann::json& summary_head);

}  // namespace lunarnav::evaluation
