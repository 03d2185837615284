#include "stereo/ncc_options.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <sstream>
#include <stdexcept>

#include "util/check.h"

namespace lunarnav::stereo {

std::string ToString(Rejection reason) {
  switch (reason) {
    case Rejection::kAccepted: return "accepted";
    case Rejection::kNotEvaluated: return "not_evaluated";
    case Rejection::kBorder: return "border";
    case Rejection::kLowTexture: return "low_texture";
    case Rejection::kLowCorrelation: return "low_correlation";
    case Rejection::kAmbiguous: return "ambiguous";
    case Rejection::kRangeEdge: return "range_edge";
    case Rejection::kMedian: return "median";
    case Rejection::kLeftRightMismatch: return "left_right";
    case Rejection::kSpeckle: return "speckle";
    case Rejection::kBeyondBorder: return "beyond_border";
    case Rejection::kBeyondFar: return "beyond_far";
    case Rejection::kBeyondNear: return "beyond_near";
    case Rejection::kAperture: return "aperture";
    case Rejection::kOccludedEdge: return "occluded_edge";
  }
  return "unknown";
}

std::string ToString(Aggregation aggregation) {
  return aggregation == Aggregation::kWindow ? "window" : "semi_global";
}

const std::vector<std::string>& PresetNames() {
  static const std::vector<std::string> names = {"paper", "quality"};
  return names;
}

NccOptions PresetOptions(const std::string& name) {
  NccOptions o;  // the paper's
  if (name == "paper") return o;
  LN_CHECK_ARG(name == "quality") << "preset: unknown preset '" << name << "' (paper, quality)";
  o.preset = "quality";
  o.aggregation = Aggregation::kSemiGlobal;
  // The paper's confidence, over a window small enough for slanted ground; the aggregated
  // cost does the work the large window did.
  o.half_window_x_px = 3;
  o.half_window_y_px = 3;
  o.min_sigma = 0.5;        // only truly flat windows: the paths carry matches across weak texture
  o.min_correlation = 0.0;  // the windows at the match must at least correlate positively
  o.ambiguity = 0.0;        // replaced by the lobe-aware test on the aggregated cost
  o.median_size = 3;        // smoothing only: the speckle filter removes isolated matches
  o.semi_global.penalty_small = 15;
  o.semi_global.penalty_large = 240;
  o.semi_global.edge_levels = 16;  // a grey-level step of 16 halves P2
  o.semi_global.gradient_weight = 2.0;    // up to 16 census bits from the gradient difference
  o.semi_global.gradient_cap_levels = 8;
  o.semi_global.uniqueness = 0.08;
  o.semi_global.left_right_max_diff_px = 3;
  o.semi_global.speckle_max_size_px = 100;
  o.semi_global.speckle_range_px = 2.0;
  return o;
}

void NccOptions::Validate() const {
  LN_CHECK_ARG(half_window_x_px >= 0 && half_window_y_px >= 0)
      << "window: half-sizes must be >= 0, got " << half_window_x_px << "x" << half_window_y_px;
  LN_CHECK_ARG(half_window_x_px <= 500 && half_window_y_px <= 500)
      << "window: half-sizes must be <= 500";
  LN_CHECK_ARG(half_window_x_px > 0 || half_window_y_px > 0)
      << "window: 0x0 is a single pixel, which has no correlation; give at least one half-size >= 1";
  LN_CHECK_ARG(step_x_px >= 1 && step_y_px >= 1)
      << "step: must be >= 1, got " << step_x_px << "x" << step_y_px;
  LN_CHECK_ARG(step_x_px <= 64 && step_y_px <= 64) << "step: must be <= 64";
  LN_CHECK_ARG(min_disparity_px <= max_disparity_px)
      << "disparity: MIN must be <= MAX, got " << min_disparity_px << ":" << max_disparity_px;
  LN_CHECK_ARG(max_disparity_px - min_disparity_px < 16384)
      << "disparity: range must hold at most 16384 values";
  LN_CHECK_ARG(std::abs(min_disparity_px) < 100000 && std::abs(max_disparity_px) < 100000)
      << "disparity: values must be within +-100000";
  for (std::size_t y = 0; y < row_disparity_px.size(); ++y) {
    const auto [lo, hi] = row_disparity_px[y];
    const bool empty_row = hi < lo && (!min_row || static_cast<int>(y) < *min_row || static_cast<int>(y) > *max_row);
    LN_CHECK_ARG(empty_row || (lo <= hi && lo >= min_disparity_px && hi <= max_disparity_px))
        << "per-row disparity band of row " << y << ": " << lo << ":" << hi << " is not inside "
        << min_disparity_px << ":" << max_disparity_px;
  }
  LN_CHECK_ARG(row_accept_min_px.empty() || row_accept_min_px.size() == row_disparity_px.size())
      << "per-row accepted disparities: " << row_accept_min_px.size() << " rows, the bands " << row_disparity_px.size();
  LN_CHECK_ARG(row_accept_max_px.empty() || row_accept_max_px.size() == row_disparity_px.size())
      << "per-row accepted disparities: " << row_accept_max_px.size() << " rows, the bands " << row_disparity_px.size();
  LN_CHECK_ARG(row_ground_disparity_px.empty() || row_ground_disparity_px.size() == row_disparity_px.size())
      << "per-row ground disparities: " << row_ground_disparity_px.size() << " rows, the bands "
      << row_disparity_px.size();
  LN_CHECK_ARG(min_row.has_value() == max_row.has_value())
      << "rows: give both MIN and MAX";
  if (min_row) {
    LN_CHECK_ARG(*min_row >= 0 && *min_row <= *max_row)
        << "rows: need 0 <= MIN <= MAX, got " << *min_row << ":" << *max_row;
  }
  LN_CHECK_ARG(std::isfinite(min_sigma) && min_sigma >= 0)
      << "sigma-min: must be >= 0, got " << min_sigma;
  LN_CHECK_ARG(std::isfinite(min_correlation) && min_correlation >= -1 && min_correlation <= 1)
      << "c-min: must be in [-1, 1], got " << min_correlation;
  LN_CHECK_ARG(std::isfinite(ambiguity) && ambiguity >= 0 && ambiguity <= 1)
      << "ambiguity: must be in [0, 1], got " << ambiguity;
  LN_CHECK_ARG(median_size == 0 || (median_size % 2 == 1 && median_size <= 15))
      << "median: size must be 0 (off) or odd and <= 15, got " << median_size;
  LN_CHECK_ARG(num_threads >= 0) << "threads: must be >= 0";
  LN_CHECK_ARG(!std::isnan(border_tolerance_px) && border_tolerance_px <= 1000)
      << "border-tolerance: must be <= 1000 px (< 0 = off), got " << border_tolerance_px;
  LN_CHECK_ARG(bit_depth == 0 || (bit_depth >= 1 && bit_depth <= 16))
      << "bit-depth: must be in 1..16 (0 = from the image type), got " << bit_depth;
  if (aggregation == Aggregation::kSemiGlobal) {
    const SemiGlobalOptions& g = semi_global;
    LN_CHECK_ARG(g.census_half_x_px >= 0 && g.census_half_y_px >= 0 &&
                 (2 * g.census_half_x_px + 1) * (2 * g.census_half_y_px + 1) - 1 <= 64 &&
                 (g.census_half_x_px > 0 || g.census_half_y_px > 0))
        << "census: half-sizes X x Y need 1 <= (2X+1)(2Y+1) - 1 <= 64 bits, got " << g.census_half_x_px << "x"
        << g.census_half_y_px;
    LN_CHECK_ARG(g.penalty_small >= 0 && g.penalty_large >= g.penalty_small && g.penalty_large <= 2000)
        << "penalties: need 0 <= P1 <= P2 <= 2000, got " << g.penalty_small << ", " << g.penalty_large;
    LN_CHECK_ARG(g.edge_levels >= 0 && g.edge_levels <= 255)
        << "p2-edge: must be in 0..255 grey levels, got " << g.edge_levels;
    LN_CHECK_ARG(std::isfinite(g.gradient_weight) && g.gradient_weight >= 0 && g.gradient_weight <= 16)
        << "gradient-weight: must be in [0, 16] census bits per grey level, got " << g.gradient_weight;
    LN_CHECK_ARG(g.gradient_cap_levels >= 0 && g.gradient_cap_levels <= 64)
        << "gradient-cap: must be in 0..64 grey levels, got " << g.gradient_cap_levels;
    LN_CHECK_ARG(g.gradient_weight * g.gradient_cap_levels <= 64)
        << "gradient-weight x gradient-cap: the gradient term may add at most 64 census bits, got "
        << g.gradient_weight * g.gradient_cap_levels;
    LN_CHECK_ARG(g.num_paths == 4 || g.num_paths == 8) << "paths: must be 4 or 8, got " << g.num_paths;
    LN_CHECK_ARG(std::isfinite(g.uniqueness) && g.uniqueness >= 0 && g.uniqueness <= 1)
        << "uniqueness: must be in [0, 1], got " << g.uniqueness;
    LN_CHECK_ARG(g.left_right_max_diff_px <= 1000) << "lr-check: must be <= 1000 px";
    LN_CHECK_ARG(g.speckle_max_size_px >= 0) << "speckle-size: must be >= 0";
    LN_CHECK_ARG(std::isfinite(g.speckle_range_px) && g.speckle_range_px >= 0)
        << "speckle-range: must be >= 0, got " << g.speckle_range_px;
    LN_CHECK_ARG(max_disparity_px - min_disparity_px < 2048)
        << "disparity: semi-global matching searches at most 2048 disparities";
    LN_CHECK_ARG(std::isfinite(g.aperture_ratio) && g.aperture_ratio >= 0 && g.aperture_ratio <= 1)
        << "aperture: RATIO must be in [0, 1] (0 = off), got " << g.aperture_ratio;
    LN_CHECK_ARG(std::isfinite(g.aperture_gradient) && g.aperture_gradient > 0 && g.aperture_gradient <= 255)
        << "aperture: GRADIENT must be in (0, 255] grey levels per pixel, got " << g.aperture_gradient;
    LN_CHECK_ARG(g.occlusion_margin_px >= 0 && g.occlusion_margin_px <= 64)
        << "occlusion-margin: must be in 0..64 px (0 = off), got " << g.occlusion_margin_px;
  }
}

nlohmann::json NccOptions::ToJson() const {
  nlohmann::json j;
  j["preset"] = preset;
  j["aggregation"] = ToString(aggregation);
  if (aggregation == Aggregation::kSemiGlobal) {
    const SemiGlobalOptions& g = semi_global;
    j["semi_global"] = {{"census_half_window_px", {g.census_half_x_px, g.census_half_y_px}},
                        {"p1", g.penalty_small},
                        {"p2", g.penalty_large},
                        {"p2_edge_levels", g.edge_levels},
                        {"gradient_weight", g.gradient_weight},
                        {"gradient_cap_levels", g.gradient_cap_levels},
                        {"paths", g.num_paths},
                        {"uniqueness", g.uniqueness},
                        {"left_right_max_diff_px", g.left_right_max_diff_px},
                        {"speckle_max_size_px", g.speckle_max_size_px},
                        {"speckle_range_px", g.speckle_range_px},
                        {"aperture", g.aperture_ratio > 0
                                         ? nlohmann::json{{"ratio", g.aperture_ratio},
                                                          {"gradient_levels_per_px", g.aperture_gradient}}
                                         : nlohmann::json("off")},
                        {"occlusion_margin_px", g.occlusion_margin_px}};
  }
  j["bit_depth"] = bit_depth == 0 ? nlohmann::json("from image type") : nlohmann::json(bit_depth);
  j["half_window_px"] = {half_window_x_px, half_window_y_px};
  j["step_px"] = {step_x_px, step_y_px};
  j["disparity_range_px"] = {min_disparity_px, max_disparity_px};
  if (!row_disparity_px.empty()) {
    // Their shape and a fingerprint (FNV-1a of the bounds): resuming with other bands redoes
    // the pairs, and a sidecar stays small.
    std::uint64_t fnv = 1469598103934665603ull;
    long searched = 0;
    int rows = 0, widest = 0;
    for (const auto& [lo, hi] : row_disparity_px) {
      for (const int v : {lo, hi}) {
        for (int b = 0; b < 4; ++b) fnv = (fnv ^ ((static_cast<std::uint32_t>(v) >> (8 * b)) & 0xffu)) * 1099511628211ull;
      }
      if (hi < lo) continue;
      ++rows;
      searched += hi - lo + 1;
      widest = std::max(widest, hi - lo + 1);
    }
    for (const std::vector<int>* accept : {&row_accept_min_px, &row_accept_max_px}) {
      for (const int v : *accept) {
        for (int b = 0; b < 4; ++b) fnv = (fnv ^ ((static_cast<std::uint32_t>(v) >> (8 * b)) & 0xffu)) * 1099511628211ull;
      }
    }
    std::ostringstream hex;
    hex << std::hex << fnv;
    j["row_disparity_bands"] = {{"rows", rows},
                                {"mean_px", rows > 0 ? static_cast<double>(searched) / rows : 0.0},
                                {"widest_px", widest},
                                {"fnv1a", hex.str()}};
  }
  j["rows"] = min_row ? nlohmann::json{*min_row, *max_row} : nlohmann::json(nullptr);
  j["reference"] = ToString(reference);
  j["sigma_min_grey8"] = min_sigma;
  j["c_min"] = min_correlation;
  j["border_tolerance_px"] = border_tolerance_px >= 0 ? nlohmann::json(border_tolerance_px) : nlohmann::json("off");
  j["ambiguity"] = ambiguity;
  j["median_size"] = median_size;
  return j;
}

std::string NccSummary::BriefReport() const {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(1);
  const double total = evaluated_pixels > 0 ? evaluated_pixels : 1;
  s << "accepted " << 100.0 * accepted_pixels / total << "% of " << evaluated_pixels << " px";
  bool first = true;
  for (int code = static_cast<int>(Rejection::kBorder); code < kNumRejectionCodes; ++code) {
    if (pixels_by_reason[code] == 0) continue;
    s << (first ? " (" : ", ") << ToString(static_cast<Rejection>(code)) << " "
      << 100.0 * pixels_by_reason[code] / total << "%";
    first = false;
  }
  if (!first) s << ")";
  s.precision(2);
  s << " in " << 1e3 * match_seconds << " ms";
  return s.str();
}

nlohmann::json NccSummary::ToJson() const {
  nlohmann::json rejected;
  for (int code = static_cast<int>(Rejection::kBorder); code < kNumRejectionCodes; ++code) {
    rejected[ToString(static_cast<Rejection>(code))] = pixels_by_reason[code];
  }
  return {{"size_px", {width, height}},
          {"pixels_evaluated", evaluated_pixels},
          {"pixels_accepted", accepted_pixels},
          {"pixels_rejected", rejected},
          {"rows_processed", {band_min_row, band_max_row}},
          {"working_shift_bits", working_shift_bits},
          {"bit_depth", bit_depth},
          {"ground_following_row_steps", ground_following_row_steps},
          {"match_ms", 1e3 * match_seconds}};
}

}  // namespace lunarnav::stereo
