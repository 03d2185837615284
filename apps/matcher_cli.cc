#include "apps/matcher_cli.h"

#include <sstream>
#include <tuple>

#include "util/check.h"
#include "util/format.h"
#include "util/parse.h"

namespace lunarnav::apps {

void AddMatcherOptions(CLI::App* app, MatcherCommandLine* cl, stereo::FrameCheckOptions* frame_check) {
  const stereo::NccOptions paper = stereo::PresetOptions("paper");
  const stereo::NccOptions quality = stereo::PresetOptions("quality");
  stereo::NccOptions& given = cl->given;
  auto preset_default = [&](auto paper_value, auto quality_value) {
    std::ostringstream s;
    s << "paper " << paper_value << ", quality " << quality_value;
    return s.str();
  };
  app->add_option("--preset", cl->preset,
                  "named defaults: quality (semi-global census matching with the paper's confidence and "
                  "filters, left-right and speckle checks) or paper (exactly the paper's matcher, sec. 3.2-3.4)")
      ->check(CLI::IsMember(stereo::PresetNames()))
      ->capture_default_str();
  app->add_option("--aggregation", cl->aggregation, "window (the paper's) or semi-global")
      ->check(CLI::IsMember({"window", "semi-global"}))
      ->default_str("from the preset");
  app->add_option("--window", cl->window, "half-sizes WXxWY of the correlation window (quality: of the confidence C)")
      ->default_str(preset_default("25x17", "3x3"));
  app->add_option("--sigma-min", given.min_sigma,
                  "filter 1: min std dev of the reference window, 8-bit grey levels (scaled by the bit depth)")
      ->default_str(preset_default(paper.min_sigma, quality.min_sigma));
  app->add_option("--c-min", given.min_correlation, "filter 2: min best correlation C")
      ->default_str(preset_default(paper.min_correlation, quality.min_correlation));
  app->add_option("--ambiguity", given.ambiguity,
                  "filter 3: M, reject when (C - C')/C < M (0.1 = 10 %); window aggregation only")
      ->default_str(preset_default(paper.ambiguity, quality.ambiguity));
  app->add_option("--median", given.median_size, "filter 4: median size k (odd; 0 = off)")
      ->default_str(preset_default(paper.median_size, quality.median_size));
  app->add_option("--census", cl->census, "semi-global: census window half-sizes XxY ((2X+1)(2Y+1)-1 <= 64)")
      ->capture_default_str();
  app->add_option("--p1", given.semi_global.penalty_small,
                  "semi-global: penalty of a 1-px disparity change between neighbours (census bits)")
      ->default_str(std::to_string(quality.semi_global.penalty_small));
  app->add_option("--p2", given.semi_global.penalty_large,
                  "semi-global: penalty of a larger disparity change (census bits)")
      ->default_str(util::Format("%d; with --rig %d (rows not subsampled)", quality.semi_global.penalty_large,
                                  kMapPenaltyLarge));
  app->add_option("--p2-edge", given.semi_global.edge_levels,
                  "semi-global: P2 falls to P2 E / (E + g) across a grey-level step g (8-bit levels); 0 = constant")
      ->default_str(std::to_string(quality.semi_global.edge_levels));
  app->add_option("--gradient-weight", given.semi_global.gradient_weight,
                  "semi-global: census bits added per grey level (8-bit) of horizontal-gradient difference "
                  "between the matched pixels (0 = census only)")
      ->default_str(util::Format("%g", quality.semi_global.gradient_weight));
  app->add_option("--gradient-cap", given.semi_global.gradient_cap_levels,
                  "semi-global: the gradient difference counts up to this many grey levels (8-bit)")
      ->default_str(std::to_string(quality.semi_global.gradient_cap_levels));
  app->add_option("--paths", given.semi_global.num_paths, "semi-global: aggregation directions, 4 or 8")
      ->default_str(std::to_string(quality.semi_global.num_paths));
  app->add_option("--uniqueness", given.semi_global.uniqueness,
                  "semi-global: reject when the best cost outside the minimum's lobe is within this "
                  "fraction of the best (0 = off)")
      ->default_str(std::to_string(quality.semi_global.uniqueness));
  app->add_option("--lr-check", given.semi_global.left_right_max_diff_px,
                  "semi-global: max left-right disagreement, px (-1 = off)")
      ->default_str(std::to_string(quality.semi_global.left_right_max_diff_px));
  app->add_option("--speckle-size", given.semi_global.speckle_max_size_px,
                  "semi-global: reject disconnected regions of at most this many pixels (0 = off)")
      ->default_str(std::to_string(quality.semi_global.speckle_max_size_px));
  app->add_option("--speckle-range", given.semi_global.speckle_range_px,
                  "semi-global: disparity step, px, that disconnects a region")
      ->default_str(std::to_string(quality.semi_global.speckle_range_px));
  app->add_option("--aperture", cl->aperture,
                  "semi-global: reject a pixel whose census window's mean horizontal gradient is below GRADIENT "
                  "grey levels per pixel (8-bit) and below RATIO times its vertical one (texture along the rows, "
                  "which does not fix the match), as RATIO:GRADIENT, or off")
      ->default_str(util::Format("off; with --rig %g:%g", kMapApertureRatio, kMapApertureGradient));
  app->add_option("--occlusion-margin", given.semi_global.occlusion_margin_px,
                  "semi-global: reject a match followed, within N px on the side the other camera cannot see, "
                  "by a drop of disparity larger than --speckle-range (the nearer surface spread over the "
                  "half-occluded background; 0 = off)")
      ->default_str(util::Format("0; with --rig %d", kMapOcclusionMarginPx));
  app->add_option("--border-tolerance", given.border_tolerance_px,
                  "border rule: reject a pixel whose search runs past the other image when its match lies this many "
                  "px left of the surface's to its left (-1 = off)")
      ->default_str(preset_default(paper.border_tolerance_px, quality.border_tolerance_px));
  app->add_option("--bit-depth", given.bit_depth, "significant bits of 16-bit images (default: a PNG's sBIT, else told from the data's values and noise)");
  app->add_option("--step", cl->step, "partial subsampling steps DXxDY")->capture_default_str();
  app->add_option("--reference", cl->reference, "image the disparity map is referenced to")
      ->check(CLI::IsMember({"right", "left"}))
      ->capture_default_str();
  app->add_option("--vertical-alignment", cl->vertical_alignment,
                  "measure the pairs' residual vertical misalignment (rows of the two images off by a fraction of a "
                  "pixel, which biases the disparity of oblique texture) on a few pairs of the run and resample "
                  "every pair to take it out: auto; off; or a FILE, the summary.json of a run that measured it "
                  "(resample by that, measuring nothing: the shards of a cluster run)")
      ->default_str("off; with --rig auto (semi-global)");
  app->add_option("--blank-sigma", frame_check->blank_max_sigma,
                  "a frame with intensity std dev below this (8-bit grey levels) is blank")
      ->capture_default_str();
  app->add_option("--saturation-fraction", frame_check->saturated_max_fraction,
                  "a frame with more than this fraction of pixels at full scale is saturated")
      ->capture_default_str();
}

stereo::NccOptions MatcherFromCommandLine(const CLI::App& app, const MatcherCommandLine& cl) {
  stereo::NccOptions m = stereo::PresetOptions(cl.preset);
  const stereo::NccOptions& given = cl.given;
  auto given_option = [&](const char* name) { return app.get_option(name)->count() > 0; };
  if (given_option("--aggregation")) {
    m.aggregation = cl.aggregation == "window" ? stereo::Aggregation::kWindow : stereo::Aggregation::kSemiGlobal;
  }
  if (given_option("--sigma-min")) m.min_sigma = given.min_sigma;
  if (given_option("--c-min")) m.min_correlation = given.min_correlation;
  if (given_option("--ambiguity")) m.ambiguity = given.ambiguity;
  if (given_option("--median")) m.median_size = given.median_size;
  if (given_option("--census")) {
    std::tie(m.semi_global.census_half_x_px, m.semi_global.census_half_y_px) =
        util::ParseIntPair(cl.census, 'x', "--census");
  }
  if (given_option("--p1")) m.semi_global.penalty_small = given.semi_global.penalty_small;
  if (given_option("--p2")) m.semi_global.penalty_large = given.semi_global.penalty_large;
  if (given_option("--paths")) m.semi_global.num_paths = given.semi_global.num_paths;
  if (given_option("--p2-edge")) m.semi_global.edge_levels = given.semi_global.edge_levels;
  if (given_option("--gradient-weight")) m.semi_global.gradient_weight = given.semi_global.gradient_weight;
  if (given_option("--gradient-cap")) m.semi_global.gradient_cap_levels = given.semi_global.gradient_cap_levels;
  if (given_option("--uniqueness")) m.semi_global.uniqueness = given.semi_global.uniqueness;
  if (given_option("--lr-check")) m.semi_global.left_right_max_diff_px = given.semi_global.left_right_max_diff_px;
  if (given_option("--speckle-size")) m.semi_global.speckle_max_size_px = given.semi_global.speckle_max_size_px;
  if (given_option("--speckle-range")) m.semi_global.speckle_range_px = given.semi_global.speckle_range_px;
  if (given_option("--aperture")) {
    if (cl.aperture == "off") {
      m.semi_global.aperture_ratio = 0;
    } else {
      std::tie(m.semi_global.aperture_ratio, m.semi_global.aperture_gradient) =
          util::ParseDoublePair(cl.aperture, ':', "--aperture");
      LN_CHECK_ARG(m.semi_global.aperture_ratio > 0)
          << "aperture: RATIO must be > 0 (or give off), got " << cl.aperture;
    }
  }
  if (given_option("--occlusion-margin")) m.semi_global.occlusion_margin_px = given.semi_global.occlusion_margin_px;
  if (given_option("--bit-depth")) m.bit_depth = given.bit_depth;
  if (given_option("--border-tolerance")) m.border_tolerance_px = given.border_tolerance_px;
  if (given_option("--window")) {
    std::tie(m.half_window_x_px, m.half_window_y_px) = util::ParseIntPair(cl.window, 'x', "--window");
  }
  std::tie(m.step_x_px, m.step_y_px) = util::ParseIntPair(cl.step, 'x', "--step");
  m.reference = stereo::ReferenceImageFromString(cl.reference);
  return m;
}

void ApplyVerticalAlignment(const CLI::App& app, const MatcherCommandLine& cl, bool map_pipeline,
                            stereo::BatchOptions* batch) {
  using Mode = stereo::BatchOptions::VerticalAlignment;
  if (app.get_option("--vertical-alignment")->count() == 0) {
    batch->vertical_alignment =
        map_pipeline && batch->matcher.aggregation == stereo::Aggregation::kSemiGlobal ? Mode::kAuto : Mode::kOff;
    return;
  }
  if (cl.vertical_alignment == "auto" || cl.vertical_alignment == "off") {
    batch->vertical_alignment = stereo::VerticalAlignmentFromString(cl.vertical_alignment);
    return;
  }
  batch->vertical_alignment = Mode::kGiven;
  batch->vertical_source = cl.vertical_alignment;
  batch->vertical_given = stereo::ReadMeasuredVerticalAlignment(cl.vertical_alignment);
}

void ApplyMapPipelineDefaults(const CLI::App& app, stereo::NccOptions* matcher) {
  if (matcher->aggregation != stereo::Aggregation::kSemiGlobal) return;
  if (app.get_option("--aperture")->count() == 0) {
    matcher->semi_global.aperture_ratio = kMapApertureRatio;
    matcher->semi_global.aperture_gradient = kMapApertureGradient;
  }
  if (app.get_option("--occlusion-margin")->count() == 0) {
    matcher->semi_global.occlusion_margin_px = kMapOcclusionMarginPx;
  }
  if (app.get_option("--p2")->count() == 0 && matcher->step_y_px == 1) {
    matcher->semi_global.penalty_large = kMapPenaltyLarge;
  }
}

}  // namespace lunarnav::apps
