// The matcher's command-line options (preset, aggregation, window, filters, semi-global
// penalties, border rule, bit depth, subsampling, reference, frame checks), shared by the tools
// that match pairs: stereo-batch and map-loop. docs/stereo-batch.md describes each.
#pragma once

#include <string>

#include <CLI/CLI.hpp>

#include "stereo/batch.h"
#include "stereo/frame_check.h"
#include "stereo/ncc_options.h"

namespace lunarnav::apps {

/// What the options are bound to until MatcherFromCommandLine reads them.
struct MatcherCommandLine {
  std::string preset = "quality";
  std::string aggregation = "semi-global", census = "4x3", window, step = "1x1", reference = "right";
  std::string aperture = "off";
  std::string vertical_alignment = "off";
  stereo::NccOptions given = stereo::PresetOptions("paper");  ///< Explicit values, applied over the preset.
};

/// Adds the matcher's options to `app`, bound to `cl`, and the frame checks' to `frame_check`.
void AddMatcherOptions(CLI::App* app, MatcherCommandLine* cl, stereo::FrameCheckOptions* frame_check);

/// The matcher after parsing: the preset's options with every option given on the command line
/// over them (an explicit option overrides the preset). @throws std::invalid_argument for a
/// malformed pair (WXxWY, DXxDY).
stereo::NccOptions MatcherFromCommandLine(const CLI::App& app, const MatcherCommandLine& cl);

/// The aperture filter the map pipeline uses (stereo-batch with --rig, map-loop): ratio and
/// gradient (docs/stereo-matcher.md).
inline constexpr double kMapApertureRatio = 0.4;
inline constexpr double kMapApertureGradient = 1.5;
/// The occlusion margin the map pipeline uses: the census window's half-width (px).
inline constexpr int kMapOcclusionMarginPx = 4;
/// The penalty of a disparity jump the map pipeline uses over every row: twice the quality
/// preset's (smooth, weakly textured ground at range; docs/stereo-matcher.md). With rows
/// subsampled (--step DXxDY, DY > 1) the preset's stays: there neighbouring grid rows of
/// ground slanted in the image lie more than a pixel of disparity apart, and the jump penalty
/// is paid by the ground itself.
inline constexpr int kMapPenaltyLarge = 480;

/// The map pipeline's matcher defaults over `matcher`: with semi-global aggregation, the
/// aperture filter on (kMapApertureRatio, kMapApertureGradient) unless --aperture is given,
/// the occlusion margin kMapOcclusionMarginPx unless --occlusion-margin is given, and P2
/// kMapPenaltyLarge unless --p2 is given or the rows are subsampled.
void ApplyMapPipelineDefaults(const CLI::App& app, stereo::NccOptions* matcher);

/// `batch`'s vertical alignment: --vertical-alignment when given (auto, off, or a FILE read
/// here: a run's summary.json with its measurement; @throws InputError naming it when that
/// holds none); else auto for the map pipeline's semi-global matcher (stereo-batch with --rig,
/// map-loop), off otherwise (the paper's matcher stays exact). After batch->matcher is set.
void ApplyVerticalAlignment(const CLI::App& app, const MatcherCommandLine& cl, bool map_pipeline,
                            stereo::BatchOptions* batch);

}  // namespace lunarnav::apps
