// The quality preset (semi-global census matching) against synthetic scenes of known
// disparity: each of its stages on the case it exists for.
#include "stereo/sgm_matcher.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <random>
#include <vector>

#include "sim/layered_scene.h"
#include "stereo/correlation_curve.h"
#include "stereo/disparity_filters.h"
#include "stereo/ncc_matcher.h"
#include "stereo/census_hamming.h"
#include "stereo/semi_global.h"

namespace lunarnav::stereo {
namespace {

using sim::LayeredSceneOptions;
using sim::PlaneLayer;
using sim::RenderLayeredPair;
using sim::TextureKind;

PlaneLayer Plane(double d0, double slope_x = 0, double slope_y = 0, cv::Rect2d support = {}, std::uint32_t seed = 1) {
  PlaneLayer p;
  p.d0_px = d0;
  p.slope_x = slope_x;
  p.slope_y = slope_y;
  p.support_right = support;
  p.seed = seed;
  return p;
}

LayeredSceneOptions Scene(std::vector<PlaneLayer> layers, int width = 320, int height = 240) {
  LayeredSceneOptions s;
  s.width = width;
  s.height = height;
  s.layers = std::move(layers);
  return s;
}

NccOptions Quality(int d_max = 63) {
  NccOptions o = PresetOptions("quality");
  o.max_disparity_px = d_max;
  return o;
}

// |estimate - truth| at accepted pixels of `region` (right-image pixels), and the share of the
// region's pixels accepted.
struct Agreement {
  std::vector<double> errors;
  int pixels = 0;
  double AcceptedShare() const { return pixels ? static_cast<double>(errors.size()) / pixels : 0; }
  double ShareWithin(double tolerance) const {
    return errors.empty() ? 0
                          : static_cast<double>(std::count_if(errors.begin(), errors.end(),
                                                              [&](double e) { return e <= tolerance; })) /
                                errors.size();
  }
};
Agreement Compare(const NccResult& r, const cv::Mat& truth, cv::Rect region) {
  Agreement a;
  for (int y = region.y; y < region.y + region.height; ++y) {
    for (int x = region.x; x < region.x + region.width; ++x) {
      const float t = truth.at<float>(y, x);
      if (!std::isfinite(t)) continue;
      ++a.pixels;
      const float d = r.disparity_px.at<float>(y, x);
      if (std::isfinite(d)) a.errors.push_back(std::abs(d - t));
    }
  }
  return a;
}

TEST(SemiGlobal, RecoversAConstantShiftWithEitherReference) {
  const auto pair = RenderLayeredPair(Scene({Plane(17.3)}));
  for (const ReferenceImage reference : {ReferenceImage::kRight, ReferenceImage::kLeft}) {
    NccOptions o = Quality();
    o.reference = reference;
    const NccResult r = MatchStereoPair(o, pair.left, pair.right);
    const cv::Mat& truth = reference == ReferenceImage::kRight ? pair.disparity_right_px : pair.disparity_left_px;
    // Away from the side where the match leaves the other image.
    const cv::Rect inner = reference == ReferenceImage::kRight ? cv::Rect(8, 8, 280, 224) : cv::Rect(32, 8, 280, 224);
    const Agreement a = Compare(r, truth, inner);
    EXPECT_GT(a.AcceptedShare(), 0.97) << ToString(reference);
    EXPECT_GT(a.ShareWithin(0.5), 0.97) << ToString(reference);
    EXPECT_EQ(r.summary.evaluated_pixels, 320 * 240);
  }
}

// The ground seen by a tilted rig: disparity grows by 0.3 px a row. The paper's large window
// assumes a fronto-parallel surface; the aggregation follows the slope.
TEST(SemiGlobal, FollowsSlantedGroundWhereTheFrontoParallelWindowFails) {
  const auto pair = RenderLayeredPair(Scene({Plane(4.0, 0.0, 0.3)}));
  const cv::Rect inner(8, 40, 280, 160);
  NccOptions quality = Quality(95);
  const Agreement q = Compare(MatchStereoPair(quality, pair.left, pair.right), pair.disparity_right_px, inner);
  NccOptions paper = PresetOptions("paper");
  paper.max_disparity_px = 95;
  const Agreement p = Compare(MatchStereoPair(paper, pair.left, pair.right), pair.disparity_right_px, inner);
  EXPECT_GT(q.AcceptedShare(), 0.9);
  EXPECT_GT(q.ShareWithin(0.5), 0.95);
  EXPECT_LT(p.ShareWithin(0.5) * p.AcceptedShare(), 0.8 * q.ShareWithin(0.5) * q.AcceptedShare());
}

// Ground slanted in the image, rows subsampled: the disparity grows by 0.3 px a row, 2.4 px
// between grid rows 8 apart, a jump the ground itself would pay P2 for on the vertical and
// diagonal paths. Given the ground's disparity per row, those paths follow its change at no
// penalty (and an upright face's constant disparity still costs nothing).
TEST(SemiGlobal, TheGroundsDisparityLetsSubsampledRowsFollowSlantedGround) {
  const auto pair = RenderLayeredPair(Scene({Plane(4.0, 0.0, 0.3)}));
  NccOptions o = Quality(95);
  o.step_y_px = 8;
  o.semi_global.penalty_large = 480;
  const int h = pair.left.rows;
  o.row_disparity_px.assign(h, {0, 95});
  const cv::Rect inner(8, 40, 280, 160);
  const NccResult plain = MatchStereoPair(o, pair.left, pair.right);
  const Agreement without = Compare(plain, pair.disparity_right_px, inner);
  for (int y = 0; y < h; ++y) o.row_ground_disparity_px.push_back(pair.disparity_right_px.at<float>(y, 160));
  const NccResult following = MatchStereoPair(o, pair.left, pair.right);
  const Agreement with = Compare(following, pair.disparity_right_px, inner);
  // Every step between the 30 grid rows changes by 2.4 px; the summary says how many it followed.
  EXPECT_EQ(plain.summary.ground_following_row_steps, 0);
  EXPECT_EQ(following.summary.ground_following_row_steps, 29);
  // One row in 8 is on the grid: an accepted share of 0.125 is every grid pixel.
  EXPECT_GT(with.AcceptedShare(), 0.9 * 0.125);
  EXPECT_GT(with.ShareWithin(0.5), 0.97);
  EXPECT_LT(without.ShareWithin(0.5), 0.9);  // without it, the jumps: 82 % within 0.5 px
  EXPECT_GT(with.AcceptedShare(), without.AcceptedShare());
}

// A near square in front of a far plane: the far plane's pixels next to the square's left
// side (right reference) have no match in the left image. The left-right check removes them.
TEST(SemiGlobal, LeftRightCheckRemovesTheOccludedBand) {
  const cv::Rect2d square(140, 60, 100, 120);
  const auto pair = RenderLayeredPair(Scene({Plane(30.0, 0, 0, square, 2), Plane(6.0)}));
  NccOptions o = Quality();
  const NccResult r = MatchStereoPair(o, pair.left, pair.right);
  // Right reference: the far pixel x matches left x + 6, which the square hides where
  // x + 6 is in [170, 270) (the square at x_l = x_r + 30): the 24 columns right of the square.
  int occluded = 0, occluded_accepted_wrong = 0, lr_rejected = 0;
  for (int y = 70; y < 170; ++y) {
    for (int x = 0; x < 320; ++x) {
      const float t = pair.disparity_right_px.at<float>(y, x);
      if (std::abs(t - 6.0f) > 0.01f) continue;  // far plane only
      const int xl = x + 6;
      const bool hidden = xl >= 140 + 30 && xl < 240 + 30;  // under the square in the left image
      if (!hidden) continue;
      ++occluded;
      const float d = r.disparity_px.at<float>(y, x);
      occluded_accepted_wrong += std::isfinite(d) && std::abs(d - t) > 1.0f;
      lr_rejected += r.rejection.at<std::uint8_t>(y, x) == static_cast<int>(Rejection::kLeftRightMismatch);
    }
  }
  ASSERT_GT(occluded, 1500);
  EXPECT_LT(occluded_accepted_wrong, 0.1 * occluded);
  EXPECT_GT(lr_rejected, 0.3 * occluded);
  // Without the check, most of the band is accepted with the wrong disparity.
  o.semi_global.left_right_max_diff_px = -1;
  o.semi_global.speckle_max_size_px = 0;
  const NccResult unchecked = MatchStereoPair(o, pair.left, pair.right);
  int wrong_unchecked = 0;
  for (int y = 70; y < 170; ++y) {
    for (int x = 0; x < 320; ++x) {
      const float t = pair.disparity_right_px.at<float>(y, x);
      if (std::abs(t - 6.0f) > 0.01f || !(x + 6 >= 170 && x + 6 < 270)) continue;
      const float d = unchecked.disparity_px.at<float>(y, x);
      wrong_unchecked += std::isfinite(d) && std::abs(d - t) > 1.0f;
    }
  }
  EXPECT_GT(wrong_unchecked, 2 * occluded_accepted_wrong + 50);
}

// The ground seen by a rig, nearer down the image: disparity grows row by row until, in the
// last columns of the near rows, the match lies beyond the left image's right edge (right
// reference: x + d > width - 1). Those pixels searched only the disparities left inside, and
// on smooth texture (cells of 6-12 px, sensor noise) some match there with confidence.
struct BorderCount {
  int beyond = 0, beyond_accepted = 0;  // true match outside the left image
  int cut = 0, cut_accepted = 0, cut_wrong = 0;  // range cut by the edge, true match inside
  int inside = 0, inside_accepted = 0;  // whole range inside the image
  int rule = 0;                         // marked beyond_border
};
BorderCount CountAtTheBorder(const NccResult& r, const cv::Mat& truth, int reach_px) {
  BorderCount c;
  const int width = truth.cols;
  for (int y = 20; y < truth.rows - 20; ++y) {
    for (int x = 40; x < width; ++x) {
      const float t = truth.at<float>(y, x);
      const float d = r.disparity_px.at<float>(y, x);
      const bool accepted = std::isfinite(d);
      c.rule += r.rejection.at<std::uint8_t>(y, x) == static_cast<int>(Rejection::kBeyondBorder);
      if (x + t > width - 1) {
        ++c.beyond;
        c.beyond_accepted += accepted;
      } else if (x + reach_px > width - 1) {
        ++c.cut;
        c.cut_accepted += accepted;
        c.cut_wrong += accepted && std::abs(d - t) > 1.0f;
      } else {
        ++c.inside;
        c.inside_accepted += accepted;
      }
    }
  }
  return c;
}

TEST(BorderRule, NoPixelSeenBeyondTheEdgeIsMatchedInside) {
  struct Case {
    std::string preset;
    double texture_px, slope;
    bool census_only;  // the quality preset without its gradient term
    bool fails_without_rule;
  };
  // The paper's 51 x 35 window needs gentle slopes; the quality preset follows steeper ground.
  // On the finer texture the gradient term alone keeps the pixels beyond the edge from
  // matching inside; census alone does not, which shows the rule's work there.
  for (const Case& k : {Case{"quality", 6.0, 0.6, true, true}, Case{"quality", 6.0, 0.6, false, false},
                        Case{"quality", 12.0, 0.3, false, true}, Case{"paper", 12.0, 0.1, false, true}}) {
    SCOPED_TRACE(k.preset + " texture " + std::to_string(k.texture_px) + " slope " + std::to_string(k.slope) +
                 (k.census_only ? " census only" : ""));
    PlaneLayer ground = Plane(230.0 - 200.0 * k.slope, 0.0, k.slope);  // d = 230 at row 200
    ground.texture_scale_px = k.texture_px;
    LayeredSceneOptions scene = Scene({ground}, 640, 240);
    scene.noise_sigma = 2.0;
    const auto pair = RenderLayeredPair(scene);
    NccOptions o = PresetOptions(k.preset);
    o.min_disparity_px = 0;
    o.max_disparity_px = 280;
    if (k.census_only) o.semi_global.gradient_weight = 0;
    const int reach = o.max_disparity_px + (k.preset == "paper" ? o.half_window_x_px : 0);
    const BorderCount with_rule = CountAtTheBorder(MatchStereoPair(o, pair.left, pair.right), pair.disparity_right_px, reach);
    o.border_tolerance_px = -1;
    const BorderCount without = CountAtTheBorder(MatchStereoPair(o, pair.left, pair.right), pair.disparity_right_px, reach);
    ASSERT_GT(with_rule.beyond, 30000);
    EXPECT_EQ(with_rule.beyond_accepted, 0) << "of " << with_rule.beyond;
    EXPECT_GT(with_rule.rule, 0);
    // Without the rule pixels beyond the edge are matched inside (a wrong, smaller disparity:
    // points below the ground in the map).
    if (k.fails_without_rule) {
      EXPECT_GT(without.beyond_accepted, 100) << "of " << without.beyond;
    }
    EXPECT_EQ(without.rule, 0);
    // Where the true match is inside, the cut range loses little and gains no error...
    EXPECT_GT(with_rule.cut_accepted, 0.9 * without.cut_accepted);
    EXPECT_LE(with_rule.cut_wrong, without.cut_wrong);
    // ... and where the whole range was inside, nothing changes.
    EXPECT_EQ(with_rule.inside_accepted, without.inside_accepted);
    EXPECT_GT(with_rule.inside_accepted, 0.7 * with_rule.inside);
  }
}

// The rule's arithmetic on a hand-made grid: the bound advances 0.15 px a pixel from the
// match that raised it; only cut cells are judged, and among them only where that match,
// carried on a pixel a pixel, leaves the image (nearer the middle it is an occlusion).
TEST(BorderRule, BoundAdvancesFromTheFarthestMatch) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  cv::Mat d, reason;
  auto reset = [&] {
    d = cv::Mat(1, 20, CV_32FC1, cv::Scalar(nan));
    reason = cv::Mat(1, 20, CV_8UC1, cv::Scalar(static_cast<int>(Rejection::kLowTexture)));
  };
  auto set = [&](int x, float v) {
    d.at<float>(0, x) = v;
    reason.at<std::uint8_t>(0, x) = static_cast<std::uint8_t>(Rejection::kAccepted);
  };
  auto accepted = [&](int x) { return reason.at<std::uint8_t>(0, x) == static_cast<int>(Rejection::kAccepted); };
  // Width 20, reach 10: cells x >= 10 are cut. Cell 8 matches column 16; cells 9-11 are
  // rejected by other filters. Cell 12 matches column 16, within the tolerance of the bound
  // 16 + 0.15 * 4 (kept, the bound stays); cell 13 column 14.5, left of 16 + 0.15 * 5 - 1 where
  // 16 + 5 leaves the image (rejected); cell 14 column 19 (kept, raises the bound); cell 15
  // column 15.5, left of 19.15 - 1 with 19 + 1 beyond column 19 (rejected).
  reset();
  set(3, 1.0f);  // column 4, far behind
  set(8, 8.0f);
  set(12, 4.0f);
  set(13, 1.5f);
  set(14, 5.0f);
  set(15, 0.5f);
  EXPECT_EQ(RejectMatchesBeyondTheBorder(0, 1, 20, {10}, 0, 1.0, &d, &reason), 2);
  for (int x : {13, 15}) {
    EXPECT_EQ(reason.at<std::uint8_t>(0, x), static_cast<int>(Rejection::kBeyondBorder)) << x;
    EXPECT_TRUE(std::isnan(d.at<float>(0, x))) << x;
  }
  for (int x : {3, 8, 12, 14}) EXPECT_TRUE(accepted(x)) << x;
  // An uncut cell is never judged, whatever its match: cell 9 matching column 10.
  set(9, 1.0f);
  EXPECT_EQ(RejectMatchesBeyondTheBorder(0, 1, 20, {10}, 0, 1.0, &d, &reason), 0);
  EXPECT_TRUE(accepted(9));
  // An occlusion far from the edge: cell 10 matches column 12, cell 11 column 11, left of the
  // bound 12.15 - 1 but with 12 + 1 inside the image: kept. With a window of 7 (columns 13-19
  // hold no window), 12 + 1 lies beyond the last column 12 that does: rejected.
  reset();
  set(10, 2.0f);
  set(11, 0.0f);
  EXPECT_EQ(RejectMatchesBeyondTheBorder(0, 1, 20, {10}, 0, 1.0, &d, &reason), 0);
  EXPECT_TRUE(accepted(11));
  EXPECT_EQ(RejectMatchesBeyondTheBorder(0, 1, 20, {10}, 7, 1.0, &d, &reason), 1);
  EXPECT_FALSE(accepted(11));
}

// Speckles: a disparity map with an island smaller than the speckle size loses it, a larger
// region stays. The matcher's own stage runs OpenCV's filter on the grid; here the whole
// matcher sees a scene whose small patch is noise on a flat plane.
// The far guard: rows whose surface (disparity 17.3) lies beyond their accepted band [25, 40]
// match falsely inside it when only the band is searched; searched down to 5 with 25 as the
// least accepted, they find the surface in the guard and reject it as beyond_far. Rows whose
// accepted band holds the surface keep it.
TEST(SemiGlobal, TheFarGuardRejectsSurfacesBeyondTheBandInsteadOfMatchingThemFalsely) {
  const auto pair = RenderLayeredPair(Scene({Plane(17.3)}));
  const cv::Rect upper(8, 8, 280, 100), lower(8, 132, 280, 100);
  NccOptions o = Quality(40);
  o.min_disparity_px = 5;
  // Without the guard: the upper rows search [25, 40] only.
  o.row_disparity_px.assign(240, {5, 40});
  for (int y = 0; y < 120; ++y) o.row_disparity_px[y] = {25, 40};
  const NccResult unguarded = MatchStereoPair(o, pair.left, pair.right);
  const Agreement false_matches = Compare(unguarded, pair.disparity_right_px, upper);
  // With it: every row searches [5, 40]; the upper rows accept from 25, the lower from 10.
  o.row_disparity_px.assign(240, {5, 40});
  o.row_accept_min_px.assign(240, 10);
  for (int y = 0; y < 120; ++y) o.row_accept_min_px[y] = 25;
  const NccResult guarded = MatchStereoPair(o, pair.left, pair.right);
  const Agreement up = Compare(guarded, pair.disparity_right_px, upper);
  const Agreement down = Compare(guarded, pair.disparity_right_px, lower);
  EXPECT_GT(false_matches.AcceptedShare(), 0.05);  // what the guard is for: matches, all wrong
  EXPECT_EQ(false_matches.ShareWithin(1.0), 0.0);
  EXPECT_EQ(up.errors.size(), 0u);
  EXPECT_GT(guarded.summary.pixels_by_reason[static_cast<int>(Rejection::kBeyondFar)], 0.9 * 280 * 100);
  EXPECT_GT(down.AcceptedShare(), 0.97);
  EXPECT_GT(down.ShareWithin(0.5), 0.97);
}

// The near guard, the mirror of the far one: rows whose surface (disparity 32.7) lies nearer
// than their accepted band [10, 25] match falsely inside it when only the band is searched;
// searched up to 40 with 25 as the greatest accepted, they find it in the guard and reject it
// as beyond_near. Rows whose accepted band holds the surface keep it.
TEST(SemiGlobal, TheNearGuardRejectsSurfacesNearerThanTheBandInsteadOfMatchingThemFalsely) {
  const auto pair = RenderLayeredPair(Scene({Plane(32.7)}));
  const cv::Rect upper(8, 8, 280, 100), lower(8, 132, 280, 100);
  NccOptions o = Quality(40);
  o.min_disparity_px = 10;
  o.row_disparity_px.assign(240, {10, 40});
  for (int y = 0; y < 120; ++y) o.row_disparity_px[y] = {10, 25};
  const NccResult unguarded = MatchStereoPair(o, pair.left, pair.right);
  const Agreement false_matches = Compare(unguarded, pair.disparity_right_px, upper);
  o.row_disparity_px.assign(240, {10, 40});
  o.row_accept_max_px.assign(240, 36);
  for (int y = 0; y < 120; ++y) o.row_accept_max_px[y] = 25;
  const NccResult guarded = MatchStereoPair(o, pair.left, pair.right);
  const Agreement up = Compare(guarded, pair.disparity_right_px, upper);
  const Agreement down = Compare(guarded, pair.disparity_right_px, lower);
  EXPECT_GT(false_matches.AcceptedShare(), 0.05);
  EXPECT_EQ(false_matches.ShareWithin(1.0), 0.0);
  EXPECT_EQ(up.errors.size(), 0u);
  EXPECT_GT(guarded.summary.pixels_by_reason[static_cast<int>(Rejection::kBeyondNear)], 0.9 * 280 * 100);
  EXPECT_EQ(guarded.summary.pixels_by_reason[static_cast<int>(Rejection::kBeyondFar)], 0);
  EXPECT_GT(down.AcceptedShare(), 0.97);
  EXPECT_GT(down.ShareWithin(0.5), 0.97);
}

TEST(SemiGlobal, SpeckleFilterRemovesSmallIslandsAndKeepsLargeRegions) {
  const auto pair = RenderLayeredPair(Scene({Plane(25.0, 0, 0, cv::Rect2d(60, 60, 6, 6), 3),
                                             Plane(25.0, 0, 0, cv::Rect2d(180, 60, 60, 60), 4), Plane(5.0)}));
  NccOptions o = Quality();
  o.semi_global.speckle_max_size_px = 100;
  const NccResult r = MatchStereoPair(o, pair.left, pair.right);
  int island_accepted_near = 0;
  for (int y = 60; y < 66; ++y) {
    for (int x = 60; x < 66; ++x) {
      const float d = r.disparity_px.at<float>(y, x);
      island_accepted_near += std::isfinite(d) && std::abs(d - 25.0f) < 2.0f;
    }
  }
  EXPECT_EQ(island_accepted_near, 0);
  const Agreement large = Compare(r, pair.disparity_right_px, cv::Rect(185, 65, 50, 50));
  EXPECT_GT(large.AcceptedShare(), 0.9);
  EXPECT_GT(large.ShareWithin(0.5), 0.95);
  EXPECT_GT(r.summary.pixels_by_reason[static_cast<int>(Rejection::kSpeckle)] +
                r.summary.pixels_by_reason[static_cast<int>(Rejection::kLeftRightMismatch)],
            0);
}

// A 12-bit camera's pair stored in 16-bit words gives the same map as the same pair in 8 bits:
// the census cost only orders grey levels, and every grey-level threshold follows the depth.
TEST(SemiGlobal, TwelveBitDataMatchesLikeItsEightBitScaling) {
  const auto pair = RenderLayeredPair(Scene({Plane(12.0, 0.02, 0.0)}));
  cv::Mat left12, right12;
  pair.left.convertTo(left12, CV_16U, 16.0);  // 0..4080 of 4095
  pair.right.convertTo(right12, CV_16U, 16.0);
  NccOptions o = Quality();
  o.min_sigma = 4.0;  // a threshold that matters, in 8-bit grey levels
  const NccResult r8 = MatchStereoPair(o, pair.left, pair.right);
  o.bit_depth = 12;
  const NccResult r12 = MatchStereoPair(o, left12, right12);
  EXPECT_EQ(r12.summary.bit_depth, 12);
  // The edge-aware P2 sees grey-level steps on the 8-bit scale, 255/4095 of the 12-bit ones,
  // and the gradient term derivatives in 16ths of those levels: rounding moves a step by a
  // level now and then, so the maps agree up to a few pixels.
  EXPECT_NEAR(r12.summary.accepted_pixels, r8.summary.accepted_pixels, 0.005 * r8.summary.accepted_pixels);
  int both = 0, same = 0;
  for (int y = 0; y < 240; ++y) {
    for (int x = 0; x < 320; ++x) {
      const float a = r8.disparity_px.at<float>(y, x), b = r12.disparity_px.at<float>(y, x);
      if (!std::isfinite(a) || !std::isfinite(b)) continue;
      ++both;
      same += std::abs(a - b) < 0.05f;
    }
  }
  EXPECT_GT(same, 0.995 * both);
  // Read as 16 significant bits, the same threshold rejects most of the image as flat.
  o.bit_depth = 16;
  const NccResult wrong = MatchStereoPair(o, left12, right12);
  EXPECT_LT(wrong.summary.accepted_pixels, r12.summary.accepted_pixels / 2);
}

// The aperture filter: texture that runs along the rows (horizontal stripes) is rejected as
// `aperture`; texture across them (diagonal stripes, random texture) and texture weak both
// ways are not. Off by default; the same labels on 12-bit data scaled from the 8-bit.
TEST(SemiGlobal, TheApertureFilterRejectsTextureAlongTheRowsOnly) {
  constexpr int kWidth = 320, kHeight = 240, kShift = 10;
  // The left image on a canvas kShift wider; the right one is it shifted (x_l = x_r + d).
  cv::Mat canvas(kHeight, kWidth + kShift, CV_32F);
  cv::RNG rng(7);
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth + kShift; ++x) {
      double v = 128;
      if (y < 80) {
        v += 60 * std::sin(2 * M_PI * y / 6.0);  // stripes along the rows
      } else if (y < 160) {
        v += 60 * std::sin(2 * M_PI * (x + y) / 8.0);  // diagonal stripes
      } else {
        v += x < kWidth / 2 ? 0.0 : 40 * std::sin(2 * M_PI * x / 7.0) * std::cos(2 * M_PI * y / 5.0);  // faint | texture
      }
      canvas.at<float>(y, x) = static_cast<float>(v + rng.gaussian(0.8));
    }
  }
  cv::Mat left8, right8;
  canvas.colRange(0, kWidth).convertTo(left8, CV_8U);
  canvas.colRange(kShift, kWidth + kShift).convertTo(right8, CV_8U);
  auto aperture_share = [&](const NccResult& r, int y0, int y1, int x0, int x1) {
    int n = 0, rejected = 0;
    for (int y = y0; y < y1; ++y) {
      for (int x = x0; x < x1; ++x) {
        ++n;
        rejected += r.rejection.at<std::uint8_t>(y, x) == static_cast<int>(Rejection::kAperture);
      }
    }
    return static_cast<double>(rejected) / n;
  };
  NccOptions o = Quality(31);
  const NccResult off = MatchStereoPair(o, left8, right8);
  EXPECT_EQ(off.summary.pixels_by_reason[static_cast<int>(Rejection::kAperture)], 0);
  o.semi_global.aperture_ratio = 0.4;
  o.semi_global.aperture_gradient = 1.5;
  const NccResult on = MatchStereoPair(o, left8, right8);
  EXPECT_GT(aperture_share(on, 8, 72, 8, kWidth - 8), 0.95);       // along the rows
  EXPECT_LT(aperture_share(on, 88, 152, 8, kWidth - 8), 0.01);     // diagonal
  EXPECT_LT(aperture_share(on, 168, 232, 8, kWidth / 2 - 8), 0.01);  // weak both ways: the noise
  EXPECT_LT(aperture_share(on, 168, 232, kWidth / 2 + 8, kWidth - 8), 0.01);  // strong both ways
  EXPECT_EQ(on.summary.pixels_by_reason[static_cast<int>(Rejection::kAperture)],
            static_cast<long>(cv::countNonZero(on.rejection == static_cast<int>(Rejection::kAperture))));
  // Away from the stripes (and the median's and speckle filter's reach into them), the
  // matches are those of the filter off.
  for (int y = 96; y < 232; ++y) {
    if (y >= 148 && y < 172) continue;  // where the regions meet
    for (int x = 8; x < kWidth - 8; ++x) {
      if (on.rejection.at<std::uint8_t>(y, x) != 0) continue;
      ASSERT_EQ(on.disparity_px.at<float>(y, x), off.disparity_px.at<float>(y, x)) << x << "," << y;
    }
  }
  // Matched in a band of rows (window selection), the measure is made for the band only and
  // gives the band's labels of the whole image.
  NccOptions band = o;
  band.min_row = 60;
  band.max_row = 100;
  const NccResult in_band = MatchStereoPair(band, left8, right8);
  EXPECT_EQ(cv::countNonZero((in_band.rejection.rowRange(60, 101) == static_cast<int>(Rejection::kAperture)) !=
                             (on.rejection.rowRange(60, 101) == static_cast<int>(Rejection::kAperture))),
            0);
  EXPECT_GT(cv::countNonZero(in_band.rejection.rowRange(60, 101) == static_cast<int>(Rejection::kAperture)), 1000);
  // The threshold is in 8-bit grey levels per pixel, scaled by the bit depth.
  cv::Mat left12, right12;
  left8.convertTo(left12, CV_16U, 16.0);
  right8.convertTo(right12, CV_16U, 16.0);
  o.bit_depth = 12;
  const NccResult on12 = MatchStereoPair(o, left12, right12);
  EXPECT_EQ(cv::countNonZero((on12.rejection == static_cast<int>(Rejection::kAperture)) !=
                             (on.rejection == static_cast<int>(Rejection::kAperture))),
            0);
}

// The occlusion margin: beside a nearer square, the matches within the margin before a drop
// of disparity on the half-occluded side (right of the square, right reference) are
// rejected as `occluded_edge`, and nowhere else: not on a smooth slanted plane, not on the
// square's other side. Off by default.
TEST(SemiGlobal, TheOcclusionMarginRejectsOnlyBeforeADropOnTheHiddenSide) {
  const cv::Rect2d square(140, 60, 100, 120);  // right-image columns 140..239
  const auto pair = RenderLayeredPair(Scene({Plane(30.0, 0, 0, square, 2), Plane(6.0)}));
  NccOptions o = Quality();
  const NccResult off = MatchStereoPair(o, pair.left, pair.right);
  const auto code = static_cast<int>(Rejection::kOccludedEdge);
  EXPECT_EQ(off.summary.pixels_by_reason[code], 0);
  o.semi_global.occlusion_margin_px = 4;
  const NccResult on = MatchStereoPair(o, pair.left, pair.right);
  int labelled = 0, misplaced = 0;
  for (int y = 0; y < 240; ++y) {
    for (int x = 0; x < 320; ++x) {
      if (on.rejection.at<std::uint8_t>(y, x) != code) continue;
      ++labelled;
      // Within the margin of the square's right edge, or of the occluded band's (24 columns
      // right of it: the background there has no match, and what the matcher gave it drops
      // to the background's disparity at its end), in the square's rows.
      // Along the square's top and bottom edges a row's census windows straddle the edge, and
      // a row's matches mix the two disparities: a drop along the row there too.
      const bool near_edge = (x >= 240 - 4 - 1 && x < 240 + 24 + 4 && y >= 60 - 4 && y < 180 + 4) ||
                             (x >= 140 - 4 && x < 240 + 24 + 4 && (std::abs(y - 60) <= 4 || std::abs(y - 180) <= 4));
      misplaced += !near_edge;
      if (!near_edge) ADD_FAILURE() << "occluded_edge at " << x << "," << y;
    }
  }
  EXPECT_GT(labelled, 10);
  EXPECT_EQ(misplaced, 0);
  EXPECT_EQ(on.summary.pixels_by_reason[code], labelled);
  // Accepted matches more than 1 px off in the columns around the square's right edge: no
  // more than without the margin, and the square's left edge and the rest as before.
  auto wrong = [&](const NccResult& r, int x0, int x1) {
    int n = 0;
    for (int y = 70; y < 170; ++y) {
      for (int x = x0; x < x1; ++x) {
        const float d = r.disparity_px.at<float>(y, x);
        n += std::isfinite(d) && std::abs(d - pair.disparity_right_px.at<float>(y, x)) > 1.0f;
      }
    }
    return n;
  };
  EXPECT_LE(wrong(on, 230, 270), wrong(off, 230, 270));
  EXPECT_EQ(cv::countNonZero(on.rejection.colRange(0, 200) == code), 0);
  // A smooth surface slanted along the rows has no drop: what the margin rejects there are
  // the few matches that stood out of it (wrong by more than the drop, or rejected by a later
  // filter without the margin).
  const auto slanted = RenderLayeredPair(Scene({Plane(12.0, 0.05, 0.02)}));
  const NccResult slanted_on = MatchStereoPair(o, slanted.left, slanted.right);
  o.semi_global.occlusion_margin_px = 0;
  const NccResult slanted_off = MatchStereoPair(o, slanted.left, slanted.right);
  EXPECT_LT(slanted_on.summary.pixels_by_reason[code], 10);
  for (int y = 0; y < 240; ++y) {
    for (int x = 0; x < 320; ++x) {
      if (slanted_on.rejection.at<std::uint8_t>(y, x) != code) continue;
      const float d = slanted_off.disparity_px.at<float>(y, x);
      EXPECT_TRUE(!std::isfinite(d) || std::abs(d - slanted.disparity_right_px.at<float>(y, x)) > 2.0f) << x << "," << y;
    }
  }
}

// The confidence C the quality preset writes is the paper's correlation (Correlation, the
// literal reference) at the chosen whole disparity, bit for bit: inside the images it is
// summed in integers, which hold the same values; at the edges Correlation itself is used.
// 8- and 16-bit data, either reference.
TEST(SemiGlobal, TheConfidenceIsThePapersCorrelationAtTheChosenDisparity) {
  const auto pair = RenderLayeredPair(Scene({Plane(9.0, 0.03, 0.1)}, 160, 120));
  cv::Mat left12, right12;
  pair.left.convertTo(left12, CV_16U, 16.0);
  pair.right.convertTo(right12, CV_16U, 16.0);
  for (const bool deep : {false, true}) {
    for (const ReferenceImage reference : {ReferenceImage::kRight, ReferenceImage::kLeft}) {
      NccOptions o = Quality(31);
      o.reference = reference;
      if (deep) o.bit_depth = 12;
      const cv::Mat& left = deep ? left12 : pair.left;
      const cv::Mat& right = deep ? right12 : pair.right;
      const NccResult r = MatchStereoPair(o, left, right);
      NccOptions window = o;
      window.step_x_px = window.step_y_px = 1;
      int checked = 0;
      for (int y = 0; y < r.disparity_px.rows; ++y) {
        for (int x = 0; x < r.disparity_px.cols; ++x) {
          const float d = r.disparity_px.at<float>(y, x);
          if (!std::isfinite(d)) continue;
          // The whole disparity C was taken at: the sub-pixel vertex lies within half a pixel.
          const float c = r.correlation.at<float>(y, x);
          const float below = static_cast<float>(Correlation(left, right, window, x, y, static_cast<int>(std::floor(d))));
          const float above = static_cast<float>(Correlation(left, right, window, x, y, static_cast<int>(std::ceil(d))));
          ASSERT_TRUE(c == below || c == above) << x << "," << y << " d " << d << " C " << c << " vs " << below << ", "
                                                << above << (deep ? " (12-bit)" : "") << " " << ToString(reference);
          ++checked;
        }
      }
      EXPECT_GT(checked, 10000);
    }
  }
}

// Ambiguity on a cost curve: a single minimum is kept even when its flanks ripple (the paper's
// second-peak test, which excludes only the best's two neighbours, would see a rival there); a
// repeated pattern's second minimum is a rival.
TEST(IsAmbiguousMinimum, KeepsOneRippledMinimumAndRejectsARepeatedOne) {
  // A V around k = 10 with ripples on its flanks: 40 30 20 21 ... (a rise, a dip, a rise).
  std::vector<std::uint16_t> single(32);
  for (int k = 0; k < 32; ++k) single[k] = static_cast<std::uint16_t>(100 + 20 * std::abs(k - 10));
  single[12] = 135;  // rising flank: 100, 120, 135 (not a dip), 160, ...
  EXPECT_FALSE(internal::IsAmbiguousMinimum(single.data(), 0, 31, 10, 0.1));
  // A dip on the flank that is not far above the best is a rival.
  single[20] = 105;
  EXPECT_TRUE(internal::IsAmbiguousMinimum(single.data(), 0, 31, 10, 0.1));
  // Period 12: minima at 8, 20 and 32-1 of nearly equal cost.
  std::vector<std::uint16_t> repeated(32);
  for (int k = 0; k < 32; ++k) repeated[k] = static_cast<std::uint16_t>(100 + 8 * std::min((k - 8 + 120) % 12, 12 - (k - 8 + 120) % 12) + (k == 20 ? 0 : 2));
  EXPECT_TRUE(internal::IsAmbiguousMinimum(repeated.data(), 0, 31, 20, 0.1));
  // The rival is outside the searched range [14, 26]: nothing to compare with.
  EXPECT_FALSE(internal::IsAmbiguousMinimum(repeated.data(), 14, 26, 20, 0.1));
}

// Few textured pixels are ambiguous.
TEST(SemiGlobal, TexturedSceneIsRarelyAmbiguous) {
  const auto textured = RenderLayeredPair(Scene({Plane(20.0)}));
  NccOptions o = Quality();
  const NccResult t = MatchStereoPair(o, textured.left, textured.right);
  EXPECT_LT(t.summary.pixels_by_reason[static_cast<int>(Rejection::kAmbiguous)], 0.02 * t.summary.evaluated_pixels);
}

// Partial subsampling: the grid's pixels get full-resolution disparities.
TEST(SemiGlobal, PartialSubsamplingKeepsFullDisparityResolution) {
  const auto pair = RenderLayeredPair(Scene({Plane(9.6, 0.01, 0.0)}));
  // 5 x 4 (the paper's steps) is wider than half the 7 x 7 confidence window.
  for (const auto& [sx, sy] : {std::pair{3, 2}, std::pair{5, 4}}) {
  SCOPED_TRACE(sx);
  NccOptions o = Quality();
  o.step_x_px = sx;
  o.step_y_px = sy;
  const NccResult r = MatchStereoPair(o, pair.left, pair.right);
  int on_grid = 0, good = 0;
  for (int y = 10; y < 230; ++y) {
    for (int x = 8; x < 290; ++x) {
      const float d = r.disparity_px.at<float>(y, x);
      if (y % sy != 0 || x % sx != 0) {
        EXPECT_EQ(r.rejection.at<std::uint8_t>(y, x), static_cast<int>(Rejection::kNotEvaluated));
        continue;
      }
      ++on_grid;
      good += std::isfinite(d) && std::abs(d - pair.disparity_right_px.at<float>(y, x)) < 0.25f;
    }
  }
  EXPECT_GT(good, 0.95 * on_grid);
  }
}

// The census transform against its definition.
TEST(CensusTransform, MatchesTheDefinitionWithReplicatedBorders) {
  cv::Mat image(9, 11, CV_8UC1);
  cv::randu(image, 0, 256);
  std::vector<std::uint64_t> codes;
  internal::CensusTransform(image, 2, 1, cv::Range(0, 9), &codes);
  for (int y = 0; y < 9; ++y) {
    for (int x = 0; x < 11; ++x) {
      std::uint64_t expected = 0;
      for (int wy = -1; wy <= 1; ++wy) {
        for (int wx = -2; wx <= 2; ++wx) {
          if (wx == 0 && wy == 0) continue;
          const int yy = std::clamp(y + wy, 0, 8), xx = std::clamp(x + wx, 0, 10);
          expected = (expected << 1) | (image.at<std::uint8_t>(yy, xx) < image.at<std::uint8_t>(y, x) ? 1u : 0u);
        }
      }
      EXPECT_EQ(codes[y * 11 + x], expected) << x << "," << y;
    }
  }
}

// Every census Hamming kernel the CPU runs (baseline, AVX2, AVX-512) against popcount itself,
// on rows whose targets leave the image on either side (spans of every length, shorter than
// a vector too), with a subsampled grid and per-row bands; entries outside the image untouched.
TEST(CensusHamming, EveryKernelCountsTheBitsOfEveryInsideTarget) {
  const int w = 61, h = 3;
  std::vector<std::uint64_t> ref(static_cast<std::size_t>(w) * h), tgt(ref.size());
  std::mt19937_64 rng(7);
  for (auto& v : ref) v = rng();
  for (auto& v : tgt) v = rng() & rng();  // fewer bits set: distances of every size
  const std::vector<int> shift = {0, 9, 3}, width = {37, 20, 33};
  for (const auto& [name, kernel] : internal::RunnableHammingKernels()) {
    for (const bool banded : {false, true}) {
      for (const int step : {1, 2}) {
        SCOPED_TRACE(std::string(name) + (banded ? " banded" : "") + " step " + std::to_string(step));
        internal::SgmInput in;
        in.ref_census = ref.data();
        in.tgt_census = tgt.data();
        in.width = w;
        in.x0 = step - 1;
        in.step_x = step;
        in.num_cols = (w - in.x0 + step - 1) / step;
        in.num_rows = h;
        in.d_min = -17;
        in.num_disp = 41;
        if (banded) {
          in.row_shift = shift.data();
          in.row_num_disp = width.data();
        }
        for (int j = 0; j < h; ++j) {
          const int n = in.RowDisp(j), d0 = in.d_min + in.Shift(j);
          std::vector<std::uint8_t> cost(static_cast<std::size_t>(in.num_cols) * n, 0xEE);
          kernel(in, j, 0, in.num_cols, cost.data());
          for (int i = 0; i < in.num_cols; ++i) {
            const int x = in.x0 + i * step;
            for (int k = 0; k < n; ++k) {
              const int xt = x + d0 + k;
              const int expected = xt >= 0 && xt < w ? __builtin_popcountll(ref[j * w + x] ^ tgt[j * w + xt]) : 0xEE;
              ASSERT_EQ(cost[static_cast<std::size_t>(i) * n + k], expected) << "row " << j << " x " << x << " k " << k;
            }
          }
        }
      }
    }
  }
}

// Semi-global aggregation against a brute-force implementation of the recurrence, with a
// constant P2 and with the edge-aware one (P2 from the grey-level step along each path).
TEST(SemiGlobalAggregate, MatchesABruteForceRecurrence) {
  for (const int edge_levels : {0, 16}) {
  for (const bool banded : {false, true}) {
  for (const bool gradient_term : {false, true}) {
  for (const bool ground : {false, true}) {
  SCOPED_TRACE(edge_levels);
  SCOPED_TRACE(banded);
  SCOPED_TRACE(gradient_term);
  SCOPED_TRACE(ground);
  const int w = 23, h = 9, n = 7;
  // Per-row bands: row y searches d_min + shift[y] + k, k < width[y] (bands that move by up to
  // 3 and change width, some rows sharing no disparity with the previous row).
  const std::vector<int> shift = {0, 1, 1, 3, 0, 2, 5, 5, 1}, width = {7, 6, 3, 4, 7, 2, 1, 2, 6};
  cv::Mat ref(h, w, CV_8UC1), tgt(h, w, CV_8UC1);
  cv::randu(ref, 0, 256);
  cv::randu(tgt, 0, 256);
  std::vector<std::uint64_t> rc, tc;
  internal::CensusTransform(ref, 2, 2, cv::Range(0, h), &rc);
  internal::CensusTransform(tgt, 2, 2, cv::Range(0, h), &tc);
  internal::SgmInput in;
  in.ref_census = rc.data();
  in.tgt_census = tc.data();
  in.width = w;
  in.num_cols = w;
  in.num_rows = h;
  in.d_min = -2;
  in.num_disp = n;
  in.penalty_small = 5;
  in.penalty_large = 40;
  if (banded) {
    in.row_shift = shift.data();
    in.row_num_disp = width.data();
  }
  // The ground's disparity per row: changes of 0, 1 (P1 carries them), 2, 3 and back.
  const std::vector<int> ground_px = {0, 2, 5, 6, 6, 4, 1, 2, 0};
  if (ground) in.row_ground = ground_px.data();
  auto band_n = [&](int y) { return banded ? width[y] : n; };
  auto band_lo = [&](int y) { return in.d_min + (banded ? shift[y] : 0); };
  cv::Mat grey;
  ref.convertTo(grey, CV_16S);
  in.ref_grey = grey.ptr<std::int16_t>();
  in.edge_levels = edge_levels;
  auto p2_between = [&](int x, int y, int px, int py) {
    if (edge_levels == 0) return in.penalty_large;
    const int g = std::min(255, std::abs(grey.at<std::int16_t>(y, x) - grey.at<std::int16_t>(py, px)));
    return std::max(in.penalty_large * edge_levels / (edge_levels + g), in.penalty_small + 1);
  };
  // The gradient term with arbitrary derivatives (the matcher's are Sobel's, in 16ths of a
  // level): 3 / 16 of a bit per level up to 40 levels, so that some differences are capped
  // and the result is truncated.
  cv::Mat ref_gradient(h, w, CV_16SC1), tgt_gradient(h, w, CV_16SC1);
  cv::randu(ref_gradient, -4080, 4081);
  cv::randu(tgt_gradient, -4080, 4081);
  if (gradient_term) {
    in.ref_gradient = ref_gradient.ptr<std::int16_t>();
    in.tgt_gradient = tgt_gradient.ptr<std::int16_t>();
    in.gradient_weight16 = 3;
    in.gradient_cap = 40 * 16;
  }
  internal::AggregatedCost agg;
  internal::SemiGlobalAggregate(in, &agg);
  // Everything by disparity d (the band's k-th is band_lo + k).
  auto cost = [&](int x, int y, int d) {
    // Outside: the nearest inside cost; no target of the band inside: kInvalidCensusCost.
    const int first = x + band_lo(y), last = first + band_n(y) - 1;
    if (last < 0 || first > w - 1) return internal::kInvalidCensusCost;
    const int xt = std::clamp(x + d, std::max(first, 0), std::min(last, w - 1));
    const int gradient_difference =
        std::abs(ref_gradient.at<std::int16_t>(y, x) - tgt_gradient.at<std::int16_t>(y, xt));
    return __builtin_popcountll(rc[y * w + x] ^ tc[y * w + xt]) +
           (gradient_term ? std::min(gradient_difference, 40 * 16) * 3 / 256 : 0);
  };
  auto in_band = [&](int y, int d) { return d >= band_lo(y) && d < band_lo(y) + band_n(y); };
  const int dirs[8][2] = {{1, 0}, {1, 1}, {0, 1}, {-1, 1}, {-1, 0}, {-1, -1}, {0, -1}, {1, -1}};
  std::vector<long> expected(static_cast<std::size_t>(w) * h * n, 0);
  for (const auto& dir : dirs) {
    // L along the direction (dx, dy): predecessor (x - dx, y - dy).
    // L(x, y, d) for d in row y's band; a disparity the predecessor's row did not search is
    // not a state of it.
    const int span = 16;
    std::vector<long> L(static_cast<std::size_t>(w) * h * span, -1);
    std::function<long(int, int, int)> path = [&](int x, int y, int d) -> long {
      long& v = L[(static_cast<std::size_t>(y) * w + x) * span + (d - in.d_min)];
      if (v >= 0) return v;
      const int px = x - dir[0], py = y - dir[1];
      if (px < 0 || px >= w || py < 0 || py >= h) return v = cost(x, y, d);
      long prev_min = LONG_MAX;
      for (int q = band_lo(py); q < band_lo(py) + band_n(py); ++q) prev_min = std::min(prev_min, path(px, py, q));
      long best = prev_min + p2_between(x, y, px, py);
      if (in_band(py, d)) best = std::min(best, path(px, py, d));
      if (in_band(py, d - 1)) best = std::min(best, path(px, py, d - 1) + in.penalty_small);
      if (in_band(py, d + 1)) best = std::min(best, path(px, py, d + 1) + in.penalty_small);
      // From the previous row, the ground's change of disparity when it is 2 px or more: d - s
      // at no penalty, its neighbours at P1.
      const int s = ground && py != y ? ground_px[y] - ground_px[py] : 0;
      if (std::abs(s) >= 2 && std::abs(s) <= n) {
        if (in_band(py, d - s)) best = std::min(best, path(px, py, d - s));
        if (in_band(py, d - s - 1)) best = std::min(best, path(px, py, d - s - 1) + in.penalty_small);
        if (in_band(py, d - s + 1)) best = std::min(best, path(px, py, d - s + 1) + in.penalty_small);
      }
      return v = cost(x, y, d) + best - prev_min;
    };
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        for (int k = 0; k < band_n(y); ++k) {
          expected[(static_cast<std::size_t>(y) * w + x) * n + k] += path(x, y, band_lo(y) + k);
        }
      }
    }
  }
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const std::uint16_t* got = agg.sum(x, y);
      for (int k = 0; k < band_n(y); ++k) {
        ASSERT_EQ(static_cast<long>(got[k]), expected[(static_cast<std::size_t>(y) * w + x) * n + k])
            << x << "," << y << " k " << k;
      }
    }
  }
  }
  }
  }
}
}

}  // namespace
}  // namespace lunarnav::stereo
