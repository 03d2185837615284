#include "evaluation/boxes_eval.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "util/errors.h"
#include "util/testing.h"

namespace lunarnav::evaluation {
namespace {

// An XYZ map looking at a box face at Y = 4 m spanning X [-0.5, 0.5], Z [0, 1]: face points
// measured 3 cm too far or 1 cm too near alternately, a wall behind at Y = 9 m, ground in
// front (Z < 0), and some pixels without a point.
cv::Mat Scene(long* face_points, double* expected_rms, double* expected_mean) {
  cv::Mat xyz(60, 80, CV_32FC3, cv::Scalar::all(NAN));
  double sum = 0, sum_sq = 0;
  *face_points = 0;
  for (int r = 0; r < xyz.rows; ++r) {
    for (int c = 0; c < xyz.cols; ++c) {
      const float x = -1.0f + 2.0f * c / (xyz.cols - 1);
      const float z = 1.2f - 1.6f * r / (xyz.rows - 1);
      if ((r + c) % 7 == 0) continue;  // no disparity
      cv::Vec3f p(x, 9.0f, z);
      if (z < 0) p = cv::Vec3f(x, 3.0f, z);  // ground in front
      const bool on_face = x >= -0.5f && x <= 0.5f && z >= 0 && z <= 1.0f;
      if (on_face) {
        const double e = (r + c) % 2 ? 0.03 : -0.01;
        p[1] = static_cast<float>(4.0 + e);
        const double m = 0.05;
        if (x >= -0.5 + m && x <= 0.5 - m && z >= m && z <= 1.0 - m) {
          ++*face_points;
          const double stored = static_cast<double>(p[1]) - 4.0;
          sum += stored;
          sum_sq += stored * stored;
        }
      }
      xyz.at<cv::Vec3f>(r, c) = p;
    }
  }
  *expected_rms = std::sqrt(sum_sq / *face_points);
  *expected_mean = sum / *face_points;
  return xyz;
}

TEST(EvaluateBoxFaces, UsesOnlyThePointsOnTheFace) {
  long n = 0;
  double rms = 0, mean = 0;
  const cv::Mat xyz = Scene(&n, &rms, &mean);
  ASSERT_GT(n, 300);
  const BoxFace face{0, 4.0, -0.5, 0.5, 0.0, 1.0};
  const auto errors = EvaluateBoxFaces(xyz, {face}, {});
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(errors[0].points, n);
  EXPECT_NEAR(errors[0].Rms(), rms, 1e-9);
  EXPECT_NEAR(errors[0].Mean(), mean, 1e-9);
  EXPECT_GT(errors[0].Rms(), 0.015);  // between 1 and 3 cm
  EXPECT_LT(errors[0].Rms(), 0.03);
}

TEST(EvaluateBoxFaces, AFaceNobodySeesHasNoPoints) {
  long n = 0;
  double rms = 0, mean = 0;
  const cv::Mat xyz = Scene(&n, &rms, &mean);
  const BoxFace hidden{1, 6.0, 2.0, 3.0, 0.0, 1.0};
  const auto errors = EvaluateBoxFaces(xyz, {hidden}, {});
  EXPECT_EQ(errors[0].points, 0);
  EXPECT_TRUE(std::isnan(errors[0].Rms()));
}

// A frame as the simulator labels it: box 0's front face at Y = 4 m over X [-0.5, 0.5],
// Z [0, 1] fills the pixels of rows 10-49 and columns 20-59 (label 2 = 2 + index 0; the true
// points there on the face), terrain (label 1) elsewhere. The measured map: the face's points
// 2 cm too far, except every 10th column of the face, a wrong match 2 m too far (50 % of Y).
struct LabelledFrame {
  BoxTruth truth;
  cv::Mat measured;
  long face_pixels = 0, wrong = 0;
};

LabelledFrame MakeLabelledFrame() {
  LabelledFrame f;
  f.truth.labels = cv::Mat(60, 80, CV_16UC1, cv::Scalar(1));
  f.truth.xyz = cv::Mat(60, 80, CV_32FC3, cv::Scalar(0, 9, 0));
  f.measured = cv::Mat(60, 80, CV_32FC3, cv::Scalar(0, 9, 0));
  for (int r = 10; r < 50; ++r) {
    for (int c = 20; c < 60; ++c) {
      // Pixel centres spread over X in (-0.5, 0.5) and Z in (0, 1):
      // X = -0.4875 ... 0.4875, Z = 0.9875 ... 0.0125, so the margin of 5 cm drops some.
      const float x = -0.5f + (c - 20 + 0.5f) / 40.0f;
      const float z = 1.0f - (r - 10 + 0.5f) / 40.0f;
      f.truth.labels.at<std::uint16_t>(r, c) = 2;
      f.truth.xyz.at<cv::Vec3f>(r, c) = cv::Vec3f(x, 4.0f, z);
      const bool wrong = c % 10 == 0;
      f.measured.at<cv::Vec3f>(r, c) = cv::Vec3f(x, wrong ? 6.0f : 4.02f, z);
      const bool inside = x >= -0.45f && x <= 0.45f && z >= 0.05f && z <= 0.95f;
      if (inside) {
        ++f.face_pixels;
        f.wrong += wrong;
      }
    }
  }
  return f;
}

TEST(EvaluateBoxFaces, TruthLabelsKeepEveryPointOfTheFaceAndAGateCountsWhatItDrops) {
  const LabelledFrame f = MakeLabelledFrame();
  // 36 x 36 pixel centres inside the 5 cm margin (|X| <= 0.45: columns 22-57; Z alike), and
  // 3 of each row's 36 columns (30, 40, 50) are wrong matches: 36 x 3.
  ASSERT_EQ(f.face_pixels, 36 * 36);
  ASSERT_EQ(f.wrong, 36 * 3);
  const BoxFace face{0, 4.0, -0.5, 0.5, 0.0, 1.0};
  // Float storage: 4.02f and 6.0f are what the errors are made of.
  const double small = static_cast<double>(4.02f) - 4.0, gross = 2.0;
  const long right = f.face_pixels - f.wrong;

  // By the truth, no gate: every point of the face counts, the wrong matches too.
  BoxesEvalOptions options;
  auto e = EvaluateBoxFaces(f.measured, {face}, options, &f.truth);
  EXPECT_EQ(e[0].points, f.face_pixels);
  EXPECT_EQ(e[0].gated_out, 0);
  EXPECT_NEAR(e[0].Rms(), std::sqrt((right * small * small + f.wrong * gross * gross) / f.face_pixels), 1e-6);

  // A 10 % gate drops the wrong matches and says so.
  options.y_gate_fraction = 0.10;
  e = EvaluateBoxFaces(f.measured, {face}, options, &f.truth);
  EXPECT_EQ(e[0].points, right);
  EXPECT_EQ(e[0].gated_out, f.wrong);
  EXPECT_NEAR(e[0].Rms(), small, 1e-6);
  EXPECT_NEAR(e[0].GatedOutShare(), 3.0 / 36.0, 1e-12);

  // Without the truth the default gate is in force, and what it drops is counted, not silent.
  e = EvaluateBoxFaces(f.measured, {face}, BoxesEvalOptions{});
  EXPECT_EQ(e[0].points, right);
  EXPECT_EQ(e[0].gated_out, f.wrong);

  // Another box's label: none of these pixels are its points.
  const BoxFace other{1, 4.0, -0.5, 0.5, 0.0, 1.0};
  EXPECT_EQ(EvaluateBoxFaces(f.measured, {other}, BoxesEvalOptions{}, &f.truth)[0].points, 0);
}

TEST(EvaluateBoxFaces, ASubsampledMapIsPlacedOnTheTruthGridBySampleGrid) {
  const LabelledFrame f = MakeLabelledFrame();
  const SampleGrid grid{1, 2, 3, 4};  // samples at x = 1 + 3i, y = 2 + 4j
  const int cols = (80 - 1 + 2) / 3, rows = (60 - 2 + 3) / 4;
  cv::Mat compact(rows, cols, CV_32FC3);
  cv::Mat full(60, 80, CV_32FC3, cv::Scalar::all(NAN));
  for (int j = 0; j < rows; ++j) {
    for (int i = 0; i < cols; ++i) {
      compact.at<cv::Vec3f>(j, i) = f.measured.at<cv::Vec3f>(2 + 4 * j, 1 + 3 * i);
      full.at<cv::Vec3f>(2 + 4 * j, 1 + 3 * i) = compact.at<cv::Vec3f>(j, i);
    }
  }
  const BoxFace face{0, 4.0, -0.5, 0.5, 0.0, 1.0};
  const auto from_compact = EvaluateBoxFaces(compact, {face}, BoxesEvalOptions{}, &f.truth, grid);
  const auto from_full = EvaluateBoxFaces(full, {face}, BoxesEvalOptions{}, &f.truth);
  ASSERT_GT(from_full[0].points, 50);
  EXPECT_EQ(from_compact[0].points, from_full[0].points);
  EXPECT_DOUBLE_EQ(from_compact[0].sum_sq_error, from_full[0].sum_sq_error);
  // A map of neither size is bad input.
  EXPECT_THROW(EvaluateBoxFaces(cv::Mat(5, 5, CV_32FC3), {face}, BoxesEvalOptions{}, &f.truth, grid), InputError);
}

TEST(BoxesTable, OneRowPerDistanceAndColumnsPerRun) {
  BoxRunResult a{"dx1_dy1", 1, 1, {}}, b{"dx5_dy4", 5, 4, {}};
  a.by_distance_cm[200] = {10, 0.0, 10 * 0.01 * 0.01};
  a.by_distance_cm[800] = {4, 0.4, 4 * 0.1 * 0.1, 1};  // one point dropped by the gate
  b.by_distance_cm[800] = {1, 0.2, 0.04};
  BoxesEvalOptions options;
  options.y_gate_fraction = 0.3;
  const Table t = BoxesTable({a, b}, {{200, 0.01}, {800, 0.1}}, options, true);
  ASSERT_EQ(t.rows.size(), 2u);
  ASSERT_EQ(t.columns.size(), 2u + 2 * 4);  // Y, predicted; per run E_Y, bias, points, dropped
  EXPECT_DOUBLE_EQ(t.rows[0][0].number(), 2.0);
  EXPECT_NEAR(t.rows[0][2].number(), 0.01, 1e-12);  // E_Y dx1_dy1 at 2 m
  EXPECT_TRUE(t.rows[0][6].IsNotAvailable());       // dx5_dy4 has no box at 2 m
  EXPECT_NEAR(t.rows[1][6].number(), 0.2, 1e-12);
  EXPECT_NEAR(t.rows[1][3].number(), 0.1, 1e-12);   // bias
  EXPECT_NEAR(t.rows[1][5].number(), 20.0, 1e-12);  // 1 of 5 points dropped at 8 m: 20 %
  EXPECT_NEAR(t.rows[0][5].number(), 0.0, 1e-12);
  // The notes state the gate and the total dropped.
  ASSERT_EQ(t.notes.size(), 2u);
  EXPECT_NE(t.notes[1].find("30 %"), std::string::npos) << t.notes[1];
  EXPECT_NE(t.notes[1].find("1 of 16"), std::string::npos) << t.notes[1];
  EXPECT_NE(t.notes[0].find("truth"), std::string::npos) << t.notes[0];
  // With the truth and no gate, the notes say no point is dropped.
  EXPECT_NE(BoxesTable({a}, {}, BoxesEvalOptions{}, true).notes[1].find("No Y gate"), std::string::npos);
}

TEST(ReadBoxList, ReadsBoxesAndPerFrameLists) {
  util::ScopedTempDir tmp;
  const auto path = tmp.path() / "boxes.json";
  std::ofstream(path) << R"({"format": "lunarnav.boxes/1",
    "boxes": [{"index": 0, "front_y_m": 2.0, "x_min_m": -0.6, "x_max_m": -0.1, "z_min_m": 0.0, "z_max_m": 0.5}],
    "frames": [{"stem": "000001", "boxes": [{"index": 0, "front_y_m": 1.5, "x_min_m": -0.6, "x_max_m": -0.1,
                                             "z_min_m": 0.0, "z_max_m": 0.5}]}]})";
  const BoxList list = ReadBoxList(path);
  EXPECT_DOUBLE_EQ(list.For("000000")[0].front_y_m, 2.0);
  EXPECT_DOUBLE_EQ(list.For("000001")[0].front_y_m, 1.5);
  std::ofstream(path) << R"({"format": "lunarnav.boxes/1",
    "boxes": [{"front_y_m": 2.0, "x_min_m": 0.5, "x_max_m": -0.1, "z_min_m": 0.0, "z_max_m": 0.5}]})";
  EXPECT_THROW(ReadBoxList(path), InputError);
}

// The options' limits: an edge margin beyond 10 m leaves no face to score (1e300 m wrote an
// empty table, exit 0).
TEST(BoxesEvalOptions, RefusesAMarginLargerThanAnyFace) {
  BoxesEvalOptions o;
  EXPECT_NO_THROW(o.Validate());
  o.edge_margin_m = 1e300;
  EXPECT_THROW(o.Validate(), std::invalid_argument);
  o.edge_margin_m = -0.1;
  EXPECT_THROW(o.Validate(), std::invalid_argument);
}

}  // namespace
}  // namespace lunarnav::evaluation
