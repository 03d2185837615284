// Options and outputs of the normalized-correlation stereo matcher.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "calib/triangulation.h"
#include "util/timer.h"

namespace lunarnav::stereo {

/// Which image the disparity map is referenced to (calib/triangulation.h).
using calib::ReferenceImage;
using calib::ReferenceImageFromString;
using calib::ToString;

/// Why a pixel has no disparity. Stored as these codes in rejection maps (docs/formats.md).
enum class Rejection : std::uint8_t {
  kAccepted = 0,        ///< Valid disparity.
  kNotEvaluated = 1,    ///< Outside the row band, or not on the (dx, dy) subsampling grid.
  kBorder = 2,          ///< The correlation window, or every searched disparity, leaves the image.
  kLowTexture = 3,      ///< Filter 1: sigma of the reference window < sigma_min.
  kLowCorrelation = 4,  ///< Filter 2: best correlation C < C_min.
  kAmbiguous = 5,       ///< Filter 3: (C - C') / C < M, C' the second-highest correlation peak.
  kRangeEdge = 6,       ///< The best correlation is at an end of the searched disparity range.
  kMedian = 7,          ///< Filter 4: the median filter found too few valid neighbours.
  kLeftRightMismatch = 8,  ///< Quality preset: the match seen from the other image disagrees.
  kSpeckle = 9,         ///< Quality preset: part of a small region disconnected from its surroundings.
  /// The search range was cut by the other image's edge and the surface to the left (right
  /// reference) already matches up to that edge: the true match lies beyond it (both presets).
  kBeyondBorder = 10,
  /// The match lies below the row's accepted disparities (row_accept_min_px): in the guard
  /// band searched beyond the window's far limit, farther than the map wants it.
  kBeyondFar = 11,
  /// The match lies above the row's accepted disparities (row_accept_max_px): in the guard
  /// band searched nearer than a requested window's near limit.
  kBeyondNear = 12,
  /// Quality preset with the aperture filter on: the census window's texture runs along the
  /// rows (its horizontal gradient weak, and weak beside its vertical one), so the match's
  /// position along the row is not fixed by the image (SemiGlobalOptions::aperture_ratio).
  kAperture = 13,
  /// Quality preset with an occlusion margin: the pixel lies within the margin before a drop
  /// of disparity on the side the other camera cannot see behind a nearer surface
  /// (SemiGlobalOptions::occlusion_margin_px).
  kOccludedEdge = 14
};
inline constexpr int kNumRejectionCodes = 15;
/// Short snake_case name of a code ("low_texture"), used in summaries.
std::string ToString(Rejection reason);

/// How matching costs are combined over the image (docs/stereo-matcher.md).
enum class Aggregation {
  kWindow,     ///< The paper's: normalized correlation summed over one window (sec. 3.2).
  kSemiGlobal  ///< Census cost aggregated along 4 or 8 image paths (semi-global matching).
};
std::string ToString(Aggregation aggregation);

/// The stages the quality preset adds to the paper's matcher (used with
/// Aggregation::kSemiGlobal).
struct SemiGlobalOptions {
  /// Half-sizes of the census window (the matching cost): (2x+1)(2y+1) - 1 <= 64 bits.
  int census_half_x_px = 4;
  int census_half_y_px = 3;
  /// Penalties of the path costs, in census bits: P1 for a one-pixel disparity change between
  /// neighbours (slanted surfaces), P2 for a larger one (depth edges). 0 <= P1 <= P2 <= 2000.
  int penalty_small = 7;
  int penalty_large = 100;
  /// Edge-aware P2: between neighbours whose grey levels (8-bit scale) differ by g, P2 becomes
  /// max(P1 + 1, P2 e / (e + g)), e this many levels: depth edges, which mostly are intensity
  /// edges, cost less to cross. 0 = a constant P2.
  int edge_levels = 0;
  /// Gradient term of the matching cost: to the census Hamming distance is added
  /// gradient_weight * min(|gx_ref - gx_tgt|, gradient_cap_levels), gx the horizontal Sobel
  /// derivative / 4 of the grey levels (8-bit scale): a step across two pixels, smoothed over
  /// three rows. Census compares each neighbour with the centre only; at a depth edge both
  /// surfaces' pixels vote alike, and the window's larger part wins (the nearer surface
  /// spreads). The derivative at the pixel itself says on which side of an intensity edge it
  /// lies. Truncated, it is robust to the cameras' gain and offset and to noise. Weight in
  /// census bits per grey level (multiples of 1/16), in [0, 16]; cap in 0..64 levels; the term
  /// adds at most 64 bits. 0 = census only.
  double gradient_weight = 0.0;
  int gradient_cap_levels = 0;
  /// Aggregation directions: 4 (horizontal, vertical) or 8 (and the diagonals).
  int num_paths = 8;
  /// Ambiguity on the aggregated cost S: reject when S2 < (1 + uniqueness) S1, S2 the lowest
  /// cost outside the best minimum's lobe (the disparities around it where S rises
  /// monotonically), so that a broad minimum is not its own rival. In [0, 1]; 0 = off.
  double uniqueness = 0.05;
  /// Left-right check: reject when the match found from the other image differs by more than
  /// this many pixels. < 0 = off. Needs step_x = 1 (skipped otherwise).
  int left_right_max_diff_px = 1;
  /// Speckle filter: connected regions (neighbours within speckle_range_px) of at most this
  /// many image pixels (grid cells times dx dy with partial subsampling) are rejected. 0 = off.
  int speckle_max_size_px = 100;
  double speckle_range_px = 2.0;
  /// Aperture filter: over the census window, the mean |d/dx| and |d/dy| of the reference
  /// (3 x 3 Sobel / 8: grey levels per pixel, 8-bit scale); a pixel is rejected when its
  /// horizontal gradient is below aperture_gradient and below aperture_ratio times its vertical
  /// one. Such a window holds edges and lines that run along the rows (a kerb seen across, tram
  /// rails, a window's frame, foreshortened stripes): shifted along the row it matches nearly
  /// as well, so the winner is set by the smoothness term, not by the image, and whole regions
  /// take a neighbour's disparity. Texture that is weak both ways is left to the low-texture
  /// filter and the aggregation. aperture_ratio in [0, 1], 0 = off; aperture_gradient in
  /// (0, 255] levels per pixel. Off in the preset; stereo-batch and map-loop turn it on with a
  /// rig (the map pipeline: docs/stereo-matcher.md).
  double aperture_ratio = 0.0;
  double aperture_gradient = 1.5;
  /// Occlusion margin: beside a nearer surface, the farther one is seen by the reference
  /// camera only (half-occluded) over as many pixels as the disparities differ, on the side
  /// away from the other camera (the right of the nearer surface with the right image as
  /// reference). There the census window straddles the depth edge, no true match exists, and
  /// the nearer surface's disparity spreads over the background: a post or a pedestrian
  /// mapped a cell wider than it stands. A match is rejected when, within this many pixels
  /// on that side, the disparity drops by more than speckle_range_px. In 0..64 px, 0 = off.
  /// Off in the preset; stereo-batch and map-loop use 4 (the census half-width) with a rig.
  int occlusion_margin_px = 0;
};

/// Parameters of the matcher. Defaults are the paper's (Krotkov & Hebert, sec. 3.2-3.4).
struct NccOptions {
  /// The named set of defaults these options started from ("paper" or "quality"); recorded.
  std::string preset = "paper";
  /// The paper's window correlation, or the quality preset's semi-global census matching.
  Aggregation aggregation = Aggregation::kWindow;
  SemiGlobalOptions semi_global;
  /// Significant bits of the grey levels: 8 for 8-bit images; for 16-bit images the depth the
  /// camera delivered (a PNG's sBIT, or the user's --bit-depth), 16 when unknown. 0 = from
  /// the image type.
  /// Every grey-level threshold (min_sigma here, the frame checks) is given for 8-bit data
  /// and scaled by (2^bits - 1) / 255.
  int bit_depth = 0;
  /// Half-width w_x of the correlation window, pixels (window is 2*w_x+1 wide). >= 0.
  int half_window_x_px = 25;
  /// Half-height w_y of the correlation window, pixels. >= 0.
  int half_window_y_px = 17;
  /// Subsampling steps (dx, dy) of partial subsampling (sec. 3.4): disparity is computed
  /// only at pixels with x = k*dx, y = k*dy (in the right image's columns for the paper's
  /// convention), and the window sums run over the pixels of the window on that grid.
  /// Every integer disparity is still searched. 1, 1 is full resolution.
  int step_x_px = 1;
  int step_y_px = 1;
  /// Inclusive disparity search range [d_min, d_max], pixels. d_min <= d_max.
  int min_disparity_px = 0;
  int max_disparity_px = 127;
  /// Per-row bands (window selection from the ground, calib::SelectGroundWindow): when not
  /// empty, one [lo, hi] per image row, inside [min_disparity_px, max_disparity_px]; semi-global
  /// aggregation searches only row y's band at row y (the window matcher, whose sums run over
  /// rows, searches the whole range). Rows of the band processed need lo <= hi.
  std::vector<std::pair<int, int>> row_disparity_px;
  /// With row_disparity_px: per image row, the least disparity accepted (the window's far
  /// limit). The band below it is searched as a guard, so that a pixel whose surface lies
  /// beyond the far limit finds its match there instead of a false one inside the window, and
  /// such a match is rejected as kBeyondFar. Empty = every disparity of the band is accepted.
  std::vector<int> row_accept_min_px;
  /// With row_disparity_px: per image row, the greatest disparity accepted (a requested
  /// window's near limit); the band above it is a near guard (ground nearer than the window
  /// seen in its lower rows), whose matches are rejected as kBeyondNear. Empty = no limit.
  std::vector<int> row_accept_max_px;
  /// With row_disparity_px: per image row, the ground's disparity (NaN where the row sees no
  /// ground); semi-global aggregation's vertical and diagonal paths then follow the ground's
  /// change of disparity between grid rows at no penalty (SgmInput::row_ground). Empty = none.
  std::vector<float> row_ground_disparity_px;
  /// Inclusive band of reference-image rows [y_min, y_max] to process (window selection,
  /// sec. 3.3). Unset = the whole image.
  std::optional<int> min_row;
  std::optional<int> max_row;
  /// Which image the map is referenced to.
  ReferenceImage reference = ReferenceImage::kRight;
  /// Filter 1: minimum standard deviation of the reference window's intensities, in grey
  /// levels of an 8-bit image (deeper images scale it by their bit depth). >= 0. With
  /// semi-global aggregation it is measured over the census window.
  double min_sigma = 2.0;
  /// Filter 2: minimum best normalized correlation C_min, in [-1, 1]. With semi-global
  /// aggregation, C is the normalized correlation over the window at the chosen disparity.
  double min_correlation = 0.5;
  /// Filter 3: ambiguity threshold M (0.10 = 10 %): reject when (C - C')/C < M, C' the
  /// second-highest peak of the correlation curve. In [0, 1]; 0 disables it.
  double ambiguity = 0.10;
  /// Filter 4: size k of the k x k median filter on the disparity map (on the subsampling
  /// grid), odd; 0 or 1 = off. Each disparity is replaced by the median of the valid ones
  /// in its neighbourhood; a pixel with fewer valid neighbours than half of the evaluated
  /// ones is rejected as an isolated match.
  int median_size = 3;
  /// The border rule (RejectMatchesBeyondTheBorder, disparity_filters.h): a pixel whose search
  /// range runs past the other image is rejected as kBeyondBorder when its match lies left of
  /// the surface to its left by more than this many pixels (right reference; mirrored for the
  /// left). The paper does not say what a pixel at the border does; < 0 = off, the paper's
  /// matcher searching what is left inside as if the range were complete. Both presets: 1.
  double border_tolerance_px = 1.0;
  /// Worker threads: 0 = run in the caller's TBB arena (all cores by default), 1 = serial.
  int num_threads = 0;

  /// Throws std::invalid_argument naming the offending option.
  void Validate() const;
  nlohmann::json ToJson() const;
};

/// Names of the presets: "paper" and "quality".
const std::vector<std::string>& PresetNames();
/// The options of a preset: "paper" the defaults above (sec. 3.2-3.4, bit for bit the
/// paper's matcher); "quality" semi-global census matching with the paper's confidence and
/// filters plus left-right and speckle checks (docs/stereo-matcher.md).
/// @throws std::invalid_argument for an unknown name.
NccOptions PresetOptions(const std::string& name);

/// Full scale of grey levels of `bits` significant bits (255 for 8), and the factor that
/// turns an 8-bit grey-level threshold into one for such data.
inline double GreyScaleFactor(int bits) { return (static_cast<double>(1u << bits) - 1.0) / 255.0; }

/// Counts and timing of one matched pair.
struct NccSummary {
  int width = 0, height = 0;
  int evaluated_pixels = 0;  ///< Grid pixels inside the row band (everything not kNotEvaluated).
  int accepted_pixels = 0;
  std::array<int, kNumRejectionCodes> pixels_by_reason{};  ///< Indexed by Rejection code.
  int band_min_row = 0, band_max_row = -1;  ///< Row band actually processed.
  int working_shift_bits = 0;  ///< Right shift applied to 16-bit data to keep sums exact.
  int bit_depth = 8;           ///< Significant bits the grey-level thresholds were scaled for.
  /// Semi-global with the ground's disparity per row (NccOptions::row_ground_disparity_px):
  /// the steps between grid rows whose paths follow the ground's change of 2 px or more.
  int ground_following_row_steps = 0;
  double match_seconds = 0;
  /// The matcher's stages in the order they ran (name, wall seconds): where match_seconds goes.
  util::StageTimes stage_seconds;
  /// e.g. "accepted 41.2% of 307200 px (low_texture 3.1%, ...) in 12.3 ms".
  std::string BriefReport() const;
  nlohmann::json ToJson() const;
};

/// The matcher's output, in the reference image's pixel grid (full image size).
struct NccResult {
  cv::Mat disparity_px;  ///< CV_32FC1, sub-pixel disparity; NaN where rejected or not evaluated.
  cv::Mat correlation;   ///< CV_32FC1, best correlation C wherever a search ran, else NaN.
  cv::Mat rejection;     ///< CV_8UC1, Rejection codes.
  NccSummary summary;
};

}  // namespace lunarnav::stereo
