#include "stereo/vertical_alignment.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "io/image_io.h"
#include "io/json_io.h"
#include "sim/layered_scene.h"
#include "stereo/batch.h"
#include "stereo/ncc_matcher.h"
#include "util/errors.h"
#include "util/testing.h"

namespace lunarnav::stereo {
namespace {
namespace fs = std::filesystem;

// The misalignment every test applies: the left image's rows 0.35 px below the right's at the
// centre, 0.8 px more from the image's left edge to its right, and bent (0.3 px at the sides).
VerticalMisalignment Applied(int width, int height) {
  VerticalMisalignment m;
  m.width_px = width;
  m.height_px = height;
  m.coefficients = {0.35, 0.4, 0.0, 0.3, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
  return m;
}

// Resamples `image` so that what stood at row y stands at row y + offset(x, y): the other
// image of a pair whose rows are off by `m` (other's row minus reference's).
cv::Mat Misalign(const cv::Mat& image, const VerticalMisalignment& m) {
  cv::Mat xs(image.size(), CV_32FC1), ys(image.size(), CV_32FC1);
  for (int y = 0; y < image.rows; ++y) {
    for (int x = 0; x < image.cols; ++x) {
      xs.at<float>(y, x) = static_cast<float>(x);
      ys.at<float>(y, x) = static_cast<float>(y - m.OffsetPx(x, y));
    }
  }
  cv::Mat out;
  cv::remap(image, out, xs, ys, cv::INTER_CUBIC, cv::BORDER_REPLICATE);
  return out;
}

// A textured ground-like plane (disparity growing down the image) with exact truth.
sim::RenderedPair Ground(int width, int height, std::uint32_t seed) {
  sim::LayeredSceneOptions scene;
  scene.width = width;
  scene.height = height;
  sim::PlaneLayer plane;
  plane.d0_px = 8;
  plane.slope_y = 0.1;
  plane.seed = seed;
  scene.layers = {plane};
  scene.noise_sigma = 1.0;
  scene.noise_seed = seed;
  return sim::RenderLayeredPair(scene);
}

NccOptions Quality() {
  NccOptions m = PresetOptions("quality");
  m.min_disparity_px = 0;
  m.max_disparity_px = 48;
  m.num_threads = 1;
  return m;
}

TEST(FitVerticalMisalignment, RecoversTheSurfaceThroughNoiseAndOutliers) {
  const VerticalMisalignment truth = Applied(640, 480);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> ux(0, 639), uy(240, 479), wild(-2, 2);
  std::normal_distribution<double> noise(0, 0.2);
  std::vector<VerticalSample> samples;
  for (int i = 0; i < 4000; ++i) {
    const double x = ux(rng), y = uy(rng);  // the lower half only, as a road fills it
    const double dy = i % 10 == 0 ? wild(rng) : truth.OffsetPx(x, y) + noise(rng);
    samples.push_back({static_cast<float>(x), static_cast<float>(y), static_cast<float>(dy)});
  }
  VerticalFitReport report;
  const auto fit = FitVerticalMisalignment(samples, {640, 480}, &report);
  ASSERT_TRUE(fit.has_value());
  EXPECT_EQ(report.samples, 4000);
  EXPECT_LT(report.samples_kept, 3900);  // the wild tenth mostly out
  EXPECT_NEAR(report.residual_px, 0.2, 0.03);
  for (double x : {0.0, 320.0, 639.0}) {
    for (double y : {240.0, 360.0, 479.0}) EXPECT_NEAR(fit->OffsetPx(x, y), truth.OffsetPx(x, y), 0.05) << x << "," << y;
  }
  // Not extrapolated above the rows the samples covered: the top row takes the value at their top.
  EXPECT_NEAR(fit->OffsetPx(320, 0), fit->OffsetPx(320, 240), 0.02);
  EXPECT_GT(fit->MaxAbsOffsetPx(), 1.0);
  // Too few samples measure nothing.
  samples.resize(kMinVerticalSamples - 1);
  EXPECT_FALSE(FitVerticalMisalignment(samples, {640, 480}).has_value());
}

TEST(MeasureVerticalOffsets, TrackerFindsTheRowsOffsetAtMatchedPixels) {
  const sim::RenderedPair pair = Ground(320, 240, 5);
  const VerticalMisalignment truth = Applied(320, 240);
  for (const ReferenceImage reference : {ReferenceImage::kRight, ReferenceImage::kLeft}) {
    const bool right_reference = reference == ReferenceImage::kRight;
    cv::Mat left = pair.left, right = pair.right;
    (right_reference ? left : right) = Misalign(right_reference ? pair.left : pair.right, truth);
    NccOptions matcher = Quality();
    matcher.reference = reference;
    NccResult result;
    MatchStereoPair(matcher, left, right, &result);
    const std::vector<VerticalSample> samples =
        MeasureVerticalOffsets(left, right, 8, result.disparity_px, 1, 1, reference);
    ASSERT_GT(samples.size(), 1000u) << ToString(reference);
    std::vector<double> errors;
    for (const VerticalSample& s : samples) errors.push_back(std::abs(s.offset_px - truth.OffsetPx(s.x_px, s.y_px)));
    std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
    EXPECT_LT(errors[errors.size() / 2], 0.05) << ToString(reference);
    // Fitted and taken out (twice, as a run does: the matches of the misaligned pair lean a
    // little towards the offset), the rows meet: measured again, nothing is left.
    auto fit = FitVerticalMisalignment(samples, left.size());
    ASSERT_TRUE(fit.has_value());
    for (int round = 0; round < 2; ++round) {
      cv::Mat l = left, r = right;
      VerticalResampler(*fit, reference).Apply(&l, &r);
      MatchStereoPair(matcher, l, r, &result);
      const auto residual =
          FitVerticalMisalignment(MeasureVerticalOffsets(l, r, 8, result.disparity_px, 1, 1, reference), l.size());
      ASSERT_TRUE(residual.has_value());
      EXPECT_LT(residual->MaxAbsOffsetPx(), round == 0 ? 0.2 : 0.06) << ToString(reference) << " round " << round;
      fit = fit->Plus(*residual);
    }
  }
}

TEST(MeasureVerticalOffsets, ReadsASubsampledMapAtItsGridsPoints) {
  // Partial subsampling: the map has the image's size with the grid's points only.
  const sim::RenderedPair pair = Ground(320, 240, 6);
  const VerticalMisalignment truth = Applied(320, 240);
  const cv::Mat left = Misalign(pair.left, truth);
  NccOptions matcher = Quality();
  matcher.step_x_px = 3;
  matcher.step_y_px = 2;
  NccResult result;
  MatchStereoPair(matcher, left, pair.right, &result);
  ASSERT_EQ(result.disparity_px.size(), left.size());
  const std::vector<VerticalSample> samples =
      MeasureVerticalOffsets(left, pair.right, 8, result.disparity_px, 3, 2, ReferenceImage::kRight);
  ASSERT_GT(samples.size(), 500u);
  std::vector<double> errors;
  for (const VerticalSample& s : samples) errors.push_back(std::abs(s.offset_px - truth.OffsetPx(s.x_px, s.y_px)));
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  EXPECT_LT(errors[errors.size() / 2], 0.06);
}

// Three pairs of the ground plane, their right images (the reference) as rendered and the left
// ones off by `misalignment` (none when empty); returns the truth of each stem.
std::vector<std::pair<std::string, cv::Mat>> WriteGroundRun(const fs::path& dir,
                                                            const VerticalMisalignment* misalignment) {
  fs::create_directories(dir / "left");
  fs::create_directories(dir / "right");
  std::vector<std::pair<std::string, cv::Mat>> truths;
  for (int i = 0; i < 3; ++i) {
    const sim::RenderedPair pair = Ground(320, 240, 11 + i);
    const std::string stem = "g" + std::to_string(i);
    io::WriteImageAtomic(dir / "left" / (stem + ".png"),
                         misalignment != nullptr ? Misalign(pair.left, *misalignment) : pair.left);
    io::WriteImageAtomic(dir / "right" / (stem + ".png"), pair.right);
    truths.emplace_back(stem, pair.disparity_right_px);
  }
  return truths;
}

// The mean |error| of a run's disparity maps against the truth, over the pixels matched.
double MeanAbsError(const fs::path& out, const std::vector<std::pair<std::string, cv::Mat>>& truths) {
  double sum = 0;
  long n = 0;
  for (const auto& [stem, truth] : truths) {
    const cv::Mat d = io::ReadPfm(OutputPathsFor(out, stem).disparity);
    for (int y = 0; y < d.rows; ++y) {
      for (int x = 0; x < d.cols; ++x) {
        const float v = d.at<float>(y, x), t = truth.at<float>(y, x);
        if (!std::isfinite(v) || !std::isfinite(t) || std::abs(v - t) > 3) continue;
        sum += std::abs(v - t);
        ++n;
      }
    }
  }
  return n > 0 ? sum / n : NAN;
}

BatchOptions QualityBatch(BatchOptions::VerticalAlignment mode) {
  BatchOptions options;
  options.matcher = Quality();
  options.num_threads = 1;
  options.show_progress = false;
  options.vertical_alignment = mode;
  return options;
}

TEST(RunStereoBatch, AutoVerticalAlignmentTakesOutTheRowsMisalignment) {
  util::ScopedTempDir tmp;
  const VerticalMisalignment truth = Applied(320, 240);
  const auto truths = WriteGroundRun(tmp.path() / "off", &truth);
  WriteGroundRun(tmp.path() / "aligned", nullptr);
  RunStereoBatch(QualityBatch(BatchOptions::VerticalAlignment::kOff), tmp.path() / "off", tmp.path() / "o-off");
  const BatchSummary summary =
      RunStereoBatch(QualityBatch(BatchOptions::VerticalAlignment::kAuto), tmp.path() / "off", tmp.path() / "o-auto");
  RunStereoBatch(QualityBatch(BatchOptions::VerticalAlignment::kOff), tmp.path() / "aligned", tmp.path() / "o-al");
  EXPECT_EQ(summary.pairs_ok, 3);
  const double off = MeanAbsError(tmp.path() / "o-off", truths), fixed = MeanAbsError(tmp.path() / "o-auto", truths),
               aligned = MeanAbsError(tmp.path() / "o-al", truths);
  EXPECT_GT(off, 1.5 * aligned);  // the misalignment costs the matcher
  EXPECT_LT(fixed, 1.2 * aligned) << off << " " << fixed << " " << aligned;
  const nlohmann::json j = io::ReadJson(summary.summary_path)["vertical_alignment"];
  EXPECT_TRUE(j["applied"].get<bool>());
  EXPECT_NEAR(j["max_abs_offset_px"].get<double>(), truth.MaxAbsOffsetPx(), 0.1) << j.dump();
}

// Disparity maps of two runs, bit for bit (NaN alike).
void ExpectSameDisparities(const fs::path& a_dir, const fs::path& b_dir, const std::vector<std::string>& stems) {
  for (const std::string& stem : stems) {
    cv::Mat a = io::ReadPfm(OutputPathsFor(a_dir, stem).disparity);
    cv::Mat b = io::ReadPfm(OutputPathsFor(b_dir, stem).disparity);
    cv::patchNaNs(a, -1);
    cv::patchNaNs(b, -1);
    EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0) << stem;
  }
}

TEST(RunStereoBatch, AGivenVerticalAlignmentResamplesAsTheRunThatMeasuredIt) {
  util::ScopedTempDir tmp;
  const VerticalMisalignment truth = Applied(320, 240);
  WriteGroundRun(tmp.path() / "in", &truth);
  const BatchSummary measured =
      RunStereoBatch(QualityBatch(BatchOptions::VerticalAlignment::kAuto), tmp.path() / "in", tmp.path() / "o-auto");
  BatchOptions given = QualityBatch(BatchOptions::VerticalAlignment::kGiven);
  given.vertical_source = measured.summary_path.string();
  given.vertical_given = ReadMeasuredVerticalAlignment(measured.summary_path);
  ASSERT_TRUE(given.vertical_given.has_value());
  const BatchSummary summary = RunStereoBatch(given, tmp.path() / "in", tmp.path() / "o-file");
  EXPECT_EQ(summary.pairs_ok, 3);
  ExpectSameDisparities(tmp.path() / "o-auto", tmp.path() / "o-file", {"g0", "g1", "g2"});
  const nlohmann::json j = io::ReadJson(summary.summary_path);
  EXPECT_EQ(j["vertical_alignment"]["mode"], "file");
  EXPECT_EQ(j["vertical_alignment"]["misalignment"], io::ReadJson(measured.summary_path)["vertical_alignment"]["misalignment"]);
  for (const nlohmann::json& st : j["timings_s"]["stages_sum"]) EXPECT_NE(st["stage"], "vertical alignment (measure)");

  // What is not a measurement is bad input, named.
  nlohmann::json bad = io::ReadJson(measured.summary_path);
  bad["vertical_alignment"]["misalignment"]["coefficients_px"][3] = "x";
  io::WriteJsonAtomic(tmp.path() / "bad.json", bad);
  EXPECT_THROW(ReadMeasuredVerticalAlignment(tmp.path() / "bad.json"), InputError);
  bad.erase("vertical_alignment");
  io::WriteJsonAtomic(tmp.path() / "none.json", bad);
  EXPECT_THROW(ReadMeasuredVerticalAlignment(tmp.path() / "none.json"), InputError);
  // A surface of other images: each pair fails, named.
  given.vertical_given->width_px = 640;
  const BatchSummary other = RunStereoBatch(given, tmp.path() / "in", tmp.path() / "o-other");
  EXPECT_EQ(other.pairs_failed, 3);
  EXPECT_NE(other.pairs[0].error.find("vertical alignment"), std::string::npos) << other.pairs[0].error;
}

TEST(RunStereoBatch, AutoVerticalAlignmentLeavesAlignedPairsAsTheyAre) {
  util::ScopedTempDir tmp;
  const auto truths = WriteGroundRun(tmp.path() / "in", nullptr);
  RunStereoBatch(QualityBatch(BatchOptions::VerticalAlignment::kOff), tmp.path() / "in", tmp.path() / "o-off");
  const BatchSummary summary =
      RunStereoBatch(QualityBatch(BatchOptions::VerticalAlignment::kAuto), tmp.path() / "in", tmp.path() / "o-auto");
  const nlohmann::json j = io::ReadJson(summary.summary_path)["vertical_alignment"];
  EXPECT_FALSE(j["applied"].get<bool>()) << j.dump();
  EXPECT_LT(j["rounds"][0]["surface_p95_abs_px"].get<double>(), kMinVerticalCorrectionPx);
  EXPECT_EQ(j["rounds"].size(), 1u);
  std::vector<std::string> stems;
  for (const auto& entry : truths) stems.push_back(entry.first);
  ExpectSameDisparities(tmp.path() / "o-off", tmp.path() / "o-auto", stems);
}

}  // namespace
}  // namespace lunarnav::stereo
