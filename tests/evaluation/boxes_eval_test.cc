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

TEST(BoxesTable, OneRowPerDistanceAndColumnsPerRun) {
  BoxRunResult a{"dx1_dy1", 1, 1, {}}, b{"dx5_dy4", 5, 4, {}};
  a.by_distance_cm[200] = {10, 0.0, 10 * 0.01 * 0.01};
  a.by_distance_cm[800] = {4, 0.4, 4 * 0.1 * 0.1};
  b.by_distance_cm[800] = {1, 0.2, 0.04};
  const Table t = BoxesTable({a, b}, {{200, 0.01}, {800, 0.1}});
  ASSERT_EQ(t.rows.size(), 2u);
  ASSERT_EQ(t.columns.size(), 2u + 2 * 3);
  EXPECT_DOUBLE_EQ(t.rows[0][0].number(), 2.0);
  EXPECT_NEAR(t.rows[0][2].number(), 0.01, 1e-12);  // E_Y dx1_dy1 at 2 m
  EXPECT_TRUE(t.rows[0][5].IsNotAvailable());        // dx5_dy4 has no box at 2 m
  EXPECT_NEAR(t.rows[1][5].number(), 0.2, 1e-12);
  EXPECT_NEAR(t.rows[1][3].number(), 0.1, 1e-12);   // bias
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

}  // namespace
}  // namespace lunarnav::evaluation
