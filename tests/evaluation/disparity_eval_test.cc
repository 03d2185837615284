#include "evaluation/disparity_eval.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <fstream>
#include <limits>
#include <random>

#include <opencv2/imgcodecs.hpp>

#include "io/image_io.h"
#include "io/json_io.h"
#include "util/errors.h"
#include "util/testing.h"

namespace lunarnav::evaluation {
namespace {
namespace fs = std::filesystem;

// OpenCV's matchers write disparity x 16 and mark no match with (min_disparity - 1) x 16.
TEST(DisparityFromOpenCv, DividesBySixteenAndMarksNoMatchWithNan) {
  const cv::Mat fixed = (cv::Mat_<std::int16_t>(1, 4) << -16, 0, 37, 1600);
  const cv::Mat d = DisparityFromOpenCv(fixed);
  ASSERT_EQ(d.type(), CV_32FC1);
  EXPECT_TRUE(std::isnan(d.at<float>(0, 0)));
  EXPECT_EQ(d.at<float>(0, 1), 0.0f);
  EXPECT_EQ(d.at<float>(0, 2), 2.3125f);
  EXPECT_EQ(d.at<float>(0, 3), 100.0f);
  // With a least disparity of 5 the marker is 64 and 80 the first disparity.
  const cv::Mat shifted = DisparityFromOpenCv((cv::Mat_<std::int16_t>(1, 3) << 64, 79, 80), 5);
  EXPECT_TRUE(std::isnan(shifted.at<float>(0, 0)));
  EXPECT_TRUE(std::isnan(shifted.at<float>(0, 1)));
  EXPECT_EQ(shifted.at<float>(0, 2), 5.0f);
  EXPECT_THROW(DisparityFromOpenCv(cv::Mat(1, 1, CV_32FC1, cv::Scalar(1))), InputError);
}

TEST(ScoreDisparity, AMapAgainstItselfHasNoErrorAndFullDensity) {
  cv::Mat truth(30, 40, CV_32FC1);
  cv::randu(truth, 1, 60);
  truth.at<float>(3, 4) = NAN;  // no truth here
  const DisparityScores s = ScoreDisparity(truth, truth, cv::Mat(), {}, {});
  EXPECT_EQ(s.truth_pixels, 30 * 40 - 1);
  EXPECT_EQ(s.DensityPct(), 100.0);
  for (std::size_t k = 0; k < 4; ++k) EXPECT_EQ(s.BadPct(k), 0.0);
  EXPECT_EQ(s.RmsErrorPx(), 0.0);
}

TEST(ScoreDisparity, MatchesHandCountedErrors) {
  // Truth 10 everywhere on a 2 x 5 image; estimates with errors 0.25, 0.75, 1.5, 3, 5 in the
  // first row and, in the second, one missing estimate, one masked pixel, three exact.
  cv::Mat truth(2, 5, CV_32FC1, cv::Scalar(10));
  cv::Mat estimate = (cv::Mat_<float>(2, 5) << 10.25f, 9.25f, 11.5f, 7, 15, NAN, 10, 10, 10, 99);
  cv::Mat mask(2, 5, CV_8UC1, cv::Scalar(1));
  mask.at<std::uint8_t>(1, 4) = 0;
  const DisparityScores s = ScoreDisparity(estimate, truth, mask, {}, {});
  EXPECT_EQ(s.truth_pixels, 9);
  EXPECT_EQ(s.estimated_pixels, 8);
  EXPECT_EQ(s.bad, (std::vector<long long>{4, 3, 2, 1}));  // > 0.5, > 1, > 2, > 4
  EXPECT_DOUBLE_EQ(s.BadPct(1), 100.0 * 3 / 8);
  EXPECT_DOUBLE_EQ(s.BadOrMissingPct(1), 100.0 * 4 / 9);
  EXPECT_DOUBLE_EQ(s.MeanAbsErrorPx(), (0.25 + 0.75 + 1.5 + 3 + 5) / 8);
  EXPECT_DOUBLE_EQ(s.RmsErrorPx(), std::sqrt((0.0625 + 0.5625 + 2.25 + 9 + 25) / 8));
  EXPECT_NEAR(s.DensityPct(), 100.0 * 8 / 9, 1e-12);
  // KITTI's D1: error > 3 px and > 5 % of 10: only the 5 px error (3 px is not above 3).
  EXPECT_EQ(s.d1_outliers, 1);
  EXPECT_DOUBLE_EQ(s.D1Pct(), 100.0 / 8);
  EXPECT_DOUBLE_EQ(s.D1OrMissingPct(), 100.0 * 2 / 9);
  // The bias: the median of -3, -0.75, 0, 0, 0, 0.25, 1.5 (the 5 px error lies beyond 3 px).
  EXPECT_NEAR(s.BiasPx(), 0.0, 1e-9);
}

TEST(ScoreDisparity, BiasIsTheOffsetOfTheGoodEstimatesWhateverTheGrossErrors) {
  // 400 estimates 0.37 px over the truth with noise of +-0.2 px, and 150 gross errors of +10 px
  // (a mean would take them in: 2.9 px); pooled with a map 0.37 px under, the offsets cancel.
  cv::Mat truth(20, 30, CV_32FC1), over(20, 30, CV_32FC1), under(20, 30, CV_32FC1);
  cv::randu(truth, 5, 60);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> noise(-0.2f, 0.2f);
  for (int k = 0; k < 600; ++k) {
    const float t = truth.at<float>(k), e = noise(rng);
    over.at<float>(k) = k < 400 ? t + 0.37f + e : k < 550 ? t + 10 : NAN;
    under.at<float>(k) = k < 400 ? t - 0.37f - e : NAN;
  }
  const DisparityScores a = ScoreDisparity(over, truth, cv::Mat(), {}, {});
  EXPECT_EQ(a.estimated_pixels, 550);
  EXPECT_NEAR(a.BiasPx(), 0.37, 0.03);
  EXPECT_GT(a.MeanAbsErrorPx(), 2.5);
  DisparityScores pooled = a;
  pooled.Add(ScoreDisparity(under, truth, cv::Mat(), {}, {}));
  EXPECT_NEAR(pooled.BiasPx(), 0.0, 0.2);  // between the two clusters
  EXPECT_TRUE(std::isnan(ScoreDisparity(truth + 5, truth, cv::Mat(), {}, {}).BiasPx()));  // none within 3 px
}

// D1's relative part: at a true disparity of 100 an error of 4 px is within 5 %.
TEST(ScoreDisparity, D1NeedsBothTheAbsoluteAndTheRelativeError) {
  EXPECT_FALSE(IsD1Outlier(4.0, 100.0));
  EXPECT_TRUE(IsD1Outlier(5.5, 100.0));
  EXPECT_FALSE(IsD1Outlier(3.0, 10.0));
  EXPECT_TRUE(IsD1Outlier(3.01, 10.0));
}

// Middlebury 2014's masks: 255 non-occluded, 128 occluded, 0 unknown.
TEST(ScoreDisparity, MaskMinimumSelectsMiddleburysNonOccludedPixels) {
  const cv::Mat truth(1, 3, CV_32FC1, cv::Scalar(20));
  const cv::Mat estimate = (cv::Mat_<float>(1, 3) << 20, 30, 40);
  const cv::Mat mask = (cv::Mat_<std::uint8_t>(1, 3) << 255, 128, 0);
  DisparityEvalOptions options;
  EXPECT_EQ(ScoreDisparity(estimate, truth, mask, {}, options).truth_pixels, 2);
  options.mask_min_value = 255;
  const DisparityScores nonocc = ScoreDisparity(estimate, truth, mask, {}, options);
  EXPECT_EQ(nonocc.truth_pixels, 1);
  EXPECT_EQ(nonocc.bad[0], 0);
}

TEST(ScoreDisparity, SamplesTheTruthOnTheSubsamplingGrid) {
  cv::Mat truth(20, 30, CV_32FC1);
  for (int y = 0; y < truth.rows; ++y) {
    for (int x = 0; x < truth.cols; ++x) truth.at<float>(y, x) = static_cast<float>(x + 100 * y);
  }
  const SampleGrid grid{2, 1, 5, 4};
  cv::Mat estimate(5, 6, CV_32FC1);
  for (int j = 0; j < estimate.rows; ++j) {
    for (int i = 0; i < estimate.cols; ++i) estimate.at<float>(j, i) = truth.at<float>(1 + 4 * j, 2 + 5 * i);
  }
  const DisparityScores s = ScoreDisparity(estimate, truth, cv::Mat(), grid, {});
  EXPECT_EQ(s.truth_pixels, 30);
  EXPECT_EQ(s.bad[0], 0);
  // A full-size estimate is read at the grid points only; the other pixels do not count as
  // missing.
  cv::Mat full(truth.size(), CV_32FC1, cv::Scalar(NAN));
  for (int y = 1; y < truth.rows; y += 4) {
    for (int x = 2; x < truth.cols; x += 5) full.at<float>(y, x) = truth.at<float>(y, x) + 0.75f;
  }
  const DisparityScores f = ScoreDisparity(full, truth, cv::Mat(), grid, {});
  EXPECT_EQ(f.truth_pixels, 30);
  EXPECT_EQ(f.estimated_pixels, 30);
  EXPECT_EQ(f.bad, (std::vector<long long>{30, 0, 0, 0}));
  SampleGrid band = grid;  // rows 5 and 9 only
  band.min_row = 4;
  band.max_row = 10;
  EXPECT_EQ(ScoreDisparity(full, truth, cv::Mat(), band, {}).truth_pixels, 12);
  EXPECT_THROW(ScoreDisparity(cv::Mat(5, 7, CV_32FC1), truth, cv::Mat(), grid, {}), InputError);
}

TEST(ReadTruthDisparity, ReadsKittiPngsWithZeroAsNoTruth) {
  util::ScopedTempDir tmp;
  cv::Mat png(2, 2, CV_16UC1, cv::Scalar(256 * 12 + 128));
  png.at<std::uint16_t>(0, 1) = 0;
  ASSERT_TRUE(cv::imwrite((tmp.path() / "t.png").string(), png));
  const cv::Mat truth = ReadTruthDisparity(tmp.path() / "t.png", 256.0);
  EXPECT_FLOAT_EQ(truth.at<float>(0, 0), 12.5f);
  EXPECT_TRUE(std::isnan(truth.at<float>(0, 1)));
  ASSERT_TRUE(cv::imwrite((tmp.path() / "eight.png").string(), cv::Mat(2, 2, CV_8UC1, cv::Scalar(3))));
  EXPECT_THROW(ReadTruthDisparity(tmp.path() / "eight.png", 256.0), InputError);
}

TEST(EvaluateDisparityDirectories, PairsStemsAndNamesEveryMismatch) {
  util::ScopedTempDir tmp;
  const fs::path results = tmp.path() / "run", truth = tmp.path() / "truth";
  fs::create_directories(results / "disparity");
  fs::create_directories(truth);
  cv::Mat map(8, 10, CV_32FC1, cv::Scalar(20));
  io::WriteImageAtomic(results / "disparity" / "a.pfm", map);
  io::WriteImageAtomic(results / "disparity" / "only_estimate.pfm", map);
  cv::Mat shifted = map + 1.5;
  io::WriteImageAtomic(results / "disparity" / "b.pfm", shifted);
  io::WriteImageAtomic(truth / "a.pfm", map);
  io::WriteImageAtomic(truth / "b.pfm", map);
  io::WriteImageAtomic(truth / "only_truth.pfm", map);
  const std::vector<DisparityItem> items = EvaluateDisparityDirectories(results, truth, {}, {});
  ASSERT_EQ(items.size(), 4u);
  EXPECT_TRUE(items[0].problem.empty());
  EXPECT_EQ(items[0].scores.bad[0], 0);
  EXPECT_EQ(items[1].scores.bad, (std::vector<long long>{80, 80, 0, 0}));
  EXPECT_NE(items[2].problem.find("no truth"), std::string::npos);
  EXPECT_NE(items[3].problem.find("no estimate"), std::string::npos);
  const Table table = DisparityTable(items, {});
  ASSERT_EQ(table.rows.size(), 5u);  // 4 stems and "all"
  EXPECT_TRUE(table.rows[2][1].IsNotAvailable());
  EXPECT_DOUBLE_EQ(table.rows[4][3].number(), 50.0);  // bad-0.5 over both scored maps
  EXPECT_THROW(EvaluateDisparityDirectories(results, tmp.path() / "missing", {}, {}), InputError);
  fs::remove(truth / "a.pfm");
  fs::remove(truth / "b.pfm");
  EXPECT_THROW(EvaluateDisparityDirectories(results, truth, {}, {}), InputError);
}

// With window selection the processed band is the pair's window (options.window.rows in the
// sidecar), not --rows: rows the matcher never searched are not scored.
TEST(EvaluateDisparityDirectories, ScoresOnlyTheWindowsRows) {
  util::ScopedTempDir tmp;
  const fs::path results = tmp.path() / "run", truth = tmp.path() / "truth";
  fs::create_directories(results / "disparity");
  fs::create_directories(truth);
  const cv::Mat map(8, 10, CV_32FC1, cv::Scalar(20));
  io::WriteImageAtomic(truth / "a.pfm", map);
  cv::Mat estimate(8, 10, CV_32FC1, cv::Scalar(std::numeric_limits<float>::infinity()));
  estimate.rowRange(2, 4).setTo(20);  // the window: rows 2 and 3
  io::WriteImageAtomic(results / "disparity" / "a.pfm", estimate);
  const nlohmann::json sidecar = {{"disparity", {{"grid", {{"origin_px", {0, 0}}, {"step_px", {1, 1}}}}}},
                                  {"options", {{"rows", nullptr}, {"window", {{"rows", {2, 3}}}}}}};
  io::WriteJsonAtomic(results / "disparity" / "a.json", sidecar);
  const std::vector<DisparityItem> items = EvaluateDisparityDirectories(results, truth, {}, {});
  ASSERT_EQ(items.size(), 1u);
  EXPECT_EQ(items[0].scores.truth_pixels, 20);
  EXPECT_DOUBLE_EQ(items[0].scores.DensityPct(), 100.0);
}

}  // namespace
}  // namespace lunarnav::evaluation
