#include "calib/window_selection.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <limits>
#include <random>
#include <sstream>

#include "calib/paper_rig.h"
#include "calib/rectified_rig.h"

namespace lunarnav::calib {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// The rig's projections, taken from its public pieces (poses, rectifying rotation, P_l, P_r),
// independently of SelectWindow's half-spaces.
struct Projector {
  explicit Projector(const StereoRig& rig, ReferenceImage reference) : rig(rig), reference(reference) {
    const RectifiedGeometry& g = *rig.rectified;
    vehicle_from_rect = rig.VehicleFromLeft().linear() * g.rect_from_left.transpose();
    centre = reference == ReferenceImage::kRight ? rig.VehicleFromRight().translation()
                                                 : rig.VehicleFromLeft().translation();
    f = g.P_left(0, 0);
    c_x = reference == ReferenceImage::kRight ? g.P_right(0, 2) : g.P_left(0, 2);
    c_y = g.P_left(1, 2);
  }
  // Rectified left-frame coordinates of a vehicle point.
  Eigen::Vector3d InRect(const Eigen::Vector3d& p) const {
    return rig.rectified->rect_from_left * (rig.VehicleFromLeft().inverse() * p);
  }
  // Row, disparity x_l - x_r, reference column and depth of a vehicle point.
  struct Projection {
    double row, disparity, column, depth;
  };
  Projection Project(const Eigen::Vector3d& p) const {
    const Eigen::Vector3d q = InRect(p);
    const Eigen::Vector3d l = rig.rectified->P_left * q.homogeneous();
    const Eigen::Vector3d r = rig.rectified->P_right * q.homogeneous();
    const double x_l = l.x() / l.z(), x_r = r.x() / r.z();
    return {l.y() / l.z(), x_l - x_r, reference == ReferenceImage::kRight ? x_r : x_l, q.z()};
  }
  // The viewing ray of reference pixel (x, y), in the vehicle frame, unit depth.
  Eigen::Vector3d Ray(double x, double y) const {
    return vehicle_from_rect * Eigen::Vector3d((x - c_x) / f, (y - c_y) / f, 1.0);
  }
  const StereoRig& rig;
  ReferenceImage reference;
  Eigen::Matrix3d vehicle_from_rect;
  Eigen::Vector3d centre;
  double f, c_x, c_y;
};

// Tight bounds of a set of rows and disparities.
struct Bounds {
  double row_min = kInf, row_max = -kInf, d_min = kInf, d_max = -kInf;
  long count = 0;
  void Add(double row, double d) {
    row_min = std::min(row_min, row);
    row_max = std::max(row_max, row);
    d_min = std::min(d_min, d);
    d_max = std::max(d_max, d);
    ++count;
  }
};

struct Case {
  const char* name;
  RegionOfInterest region;
};

const Case kCases[] = {
    {"paper Figure 3 interval", {4.2, 7.5, -0.5, 1.0}},
    {"near", {2.0, 3.0, -0.3, 0.3}},
    {"far, cut by the top edge", {10.0, 30.0, -0.5, 2.0}},
    {"flat ground only", {5.0, 6.0, 0.0, 0.0}},
    {"everything ahead", {1.6, 20.0, -1.0, 1.0}},
};

struct RigCase {
  const char* name;
  StereoRig rig;
};

std::vector<RigCase> Rigs() {
  return {{"paper-like, aligned", testing::IdealRectifiedRig()},
          {"half size, rectified frame rolled 4 deg and yawed 3 deg, c_r - c_l = -6 px",
           testing::IdealRectifiedRig(320, 240, 370, 0.9, testing::RollYaw(4, 3), -6.0)}};
}

TEST(SelectWindow, ContainsEveryPixelWhoseRayMeetsTheRegionAndLittleElse) {
  for (const RigCase& rc : Rigs()) {
    const RectifiedGeometry& g = *rc.rig.rectified;
    for (ReferenceImage reference : {ReferenceImage::kRight, ReferenceImage::kLeft}) {
      const Projector proj(rc.rig, reference);
      for (const Case& c : kCases) {
        SCOPED_TRACE(std::string(rc.name) + ", " + ToString(reference) + ", " + c.name);
        const ImageWindow w = SelectWindow(rc.rig, c.region, reference);
        const int margin = WindowSelectionOptions().disparity_margin_px;
        // Every pixel centre: the depths at which its ray is inside the slab form an interval;
        // disparity is monotone in depth, so its ends bound the pixel's disparities.
        Bounds pixels;
        int outside = 0;
        for (int y = 0; y < g.height_px; ++y) {
          for (int x = 0; x < g.width_px; ++x) {
            const Eigen::Vector3d ray = proj.Ray(x, y);
            double lo = 1e-9, hi = kInf;
            auto clip = [&](double a, double b) {  // a * depth + b >= 0
              if (a > 0) lo = std::max(lo, -b / a);
              else if (a < 0) hi = std::min(hi, -b / a);
              else if (b < 0) hi = -kInf;
            };
            clip(ray.y(), proj.centre.y() - c.region.y_min_m);
            clip(-ray.y(), c.region.y_max_m - proj.centre.y());
            clip(ray.z(), proj.centre.z() - c.region.z_min_m);
            clip(-ray.z(), c.region.z_max_m - proj.centre.z());
            if (!(lo <= hi)) continue;
            for (double depth : {lo, hi}) {
              const auto p = proj.Project(proj.centre + depth * ray);
              ASSERT_NEAR(p.row, y, 1e-6);  // the projector and the ray agree
              pixels.Add(y, p.disparity);
              const bool in = y >= w.min_row && y <= w.max_row && p.disparity >= w.min_disparity_px + margin &&
                              p.disparity <= w.max_disparity_px - margin;
              outside += !in;
            }
          }
        }
        ASSERT_GT(pixels.count, 0);
        EXPECT_TRUE(w.visible);
        EXPECT_EQ(outside, 0);
        EXPECT_FALSE(w.disparity_clipped);
        // Little else: the continuous region reaches at most half a pixel beyond the pixel
        // centres (one row), and the disparities beyond the pixels' by rounding (< 1 px), the
        // margin and the disparity change over half a pixel (< 0.5 px on these rigs).
        EXPECT_GE(w.min_row, pixels.row_min - 1);
        EXPECT_LE(w.max_row, pixels.row_max + 1);
        EXPECT_GE(w.min_disparity_px, pixels.d_min - margin - 1.5);
        EXPECT_LE(w.max_disparity_px, pixels.d_max + margin + 1.5);
      }
    }
  }
}

TEST(SelectWindow, ContainsRandomPointsOfTheRegionSeenByTheReferenceImage) {
  std::mt19937 rng(20240603);  // fixed seed
  for (const RigCase& rc : Rigs()) {
    const RectifiedGeometry& g = *rc.rig.rectified;
    for (ReferenceImage reference : {ReferenceImage::kRight, ReferenceImage::kLeft}) {
      const Projector proj(rc.rig, reference);
      for (const Case& c : kCases) {
        SCOPED_TRACE(std::string(rc.name) + ", " + ToString(reference) + ", " + c.name);
        const ImageWindow w = SelectWindow(rc.rig, c.region, reference, WindowSelectionOptions{0});
        std::uniform_real_distribution<double> Y(c.region.y_min_m, c.region.y_max_m);
        std::uniform_real_distribution<double> Z(c.region.z_min_m, c.region.z_max_m);
        std::uniform_real_distribution<double> column(-0.5, g.width_px - 0.5);
        std::bernoulli_distribution coin(0.5);
        // Half of the time a coordinate sits at one of its ends, so that the samples reach
        // the region's faces, edges and corners (where the extremes are).
        auto pick = [&](std::uniform_real_distribution<double>& u) {
          return coin(rng) ? (coin(rng) ? u.a() : u.b()) : u(rng);
        };
        Bounds samples;
        int outside = 0;
        for (int i = 0; i < 100000; ++i) {
          // A point of the slab (Y, Z) whose X puts it at a random column of the reference
          // image: the column is a ratio of affine functions of X, solved for X.
          const Eigen::Vector3d base(0, pick(Y), pick(Z));
          const double x = pick(column);
          const Eigen::Vector3d q0 = proj.vehicle_from_rect.transpose() * (base - proj.centre);
          const Eigen::Vector3d e = proj.vehicle_from_rect.transpose() * Eigen::Vector3d::UnitX();
          const double X = (proj.f * q0.x() - (x - proj.c_x) * q0.z()) / ((x - proj.c_x) * e.z() - proj.f * e.x());
          const Eigen::Vector3d point(X, base.y(), base.z());
          const auto p = proj.Project(point);
          if (!(p.depth > 0) || p.row < -0.5 || p.row > g.height_px - 0.5) continue;  // not in the image
          ASSERT_NEAR(p.column, x, 1e-6);
          samples.Add(p.row, p.disparity);
          const long row = std::lround(p.row);
          outside += !(row >= w.min_row && row <= w.max_row && p.disparity >= w.min_disparity_px &&
                       p.disparity <= w.max_disparity_px);
        }
        ASSERT_GT(samples.count, 1000);
        EXPECT_EQ(outside, 0);
        // Little else: with no margin, the band exceeds the samples' tight bounds by rounding
        // (< 1 row, < 1 px) and by the gap between the samples and the true extremes.
        EXPECT_GE(w.min_row, samples.row_min - 1.1);
        EXPECT_LE(w.max_row, samples.row_max + 1.1);
        EXPECT_GE(w.min_disparity_px, samples.d_min - 1.1);
        EXPECT_LE(w.max_disparity_px, samples.d_max + 1.1);
      }
    }
  }
}

TEST(SelectWindow, AgreesWithThePapersBoundaryPointsWhenTheyAreInView) {
  // Aligned rig: lines of constant (Y, Z) are image rows, so the paper's eight boundary points
  // (x = 0 and x = dim_x, Y = Y_min/max, Z = Z_min/max) give the exact band when all of them
  // are in the image, as for this near interval.
  const StereoRig rig = testing::IdealRectifiedRig();
  const Projector proj(rig, ReferenceImage::kRight);
  const RegionOfInterest region{3.0, 5.0, -0.3, 0.3};
  const ImageWindow w = SelectWindow(rig, region, ReferenceImage::kRight, WindowSelectionOptions{0});
  Bounds paper;
  for (double Y : {region.y_min_m, region.y_max_m}) {
    for (double Z : {region.z_min_m, region.z_max_m}) {
      for (double x : {-0.5, 639.5}) {
        // Solve for the X that puts (X, Y, Z) at column x (the camera's x is the vehicle's X).
        const Eigen::Vector3d q0 = proj.vehicle_from_rect.transpose() * (Eigen::Vector3d(0, Y, Z) - proj.centre);
        const auto p = proj.Project(Eigen::Vector3d(q0.z() * (x - proj.c_x) / proj.f - q0.x(), Y, Z));
        ASSERT_NEAR(p.column, x, 1e-6);
        ASSERT_TRUE(p.row > -0.5 && p.row < 479.5);
        paper.Add(p.row, p.disparity);
      }
    }
  }
  EXPECT_NEAR(w.row_extent[0], paper.row_min, 1e-6);
  EXPECT_NEAR(w.row_extent[1], paper.row_max, 1e-6);
  EXPECT_NEAR(w.disparity_extent_px[0], paper.d_min, 1e-6);
  EXPECT_NEAR(w.disparity_extent_px[1], paper.d_max, 1e-6);
  // For the paper's Figure 3 interval the top boundary points (Z_max = 1 m at 4.2 m) lie above
  // the image: the boundary points would give rows above the image and disparities of points
  // nobody sees; the band stops at the top row, with the disparities of what is in view.
  const ImageWindow fig3 = SelectWindow(rig, RegionOfInterest{4.2, 7.5, -0.5, 1.0}, ReferenceImage::kRight);
  const auto hidden = proj.Project(Eigen::Vector3d(0, 4.2, 1.0));
  EXPECT_LT(hidden.row, -0.5);
  EXPECT_EQ(fig3.min_row, 0);
  EXPECT_LT(fig3.disparity_extent_px[1], hidden.disparity);
}

TEST(SelectWindow, ShrinksWithTheIntervalAndReportsTheShareOfTheSearchKept) {
  // The paper's Figure 2 argument: for Y_min = 5 m the subimage and the disparity range grow
  // with Delta Y, and a small Delta Y keeps a small share of the work of a full search. The
  // full search is the paper's Figure 1 configuration: every row, disparities of 2 m to 14 m.
  // The table goes to the test log.
  const StereoRig rig = testing::IdealRectifiedRig();
  const RegionOfInterest full_region{2.0, 14.0, -0.5, 1.0};
  const ImageWindow full = SelectWindow(rig, full_region, ReferenceImage::kRight);
  std::ostringstream table;
  table << "| I_Y (m) | rows | rows kept | disparities (px) | disparities kept | work kept |\n"
        << "|---|---|---|---|---|---|\n";
  auto add_row = [&](const RegionOfInterest& region) {
    const ImageWindow w = SelectWindow(rig, region, ReferenceImage::kRight);
    const double rows = w.RowFraction();
    const double disparities = w.DisparityFraction(full.min_disparity_px, full.max_disparity_px);
    table << std::fixed << std::setprecision(1) << "| " << region.y_min_m << " - " << region.y_max_m << " | "
          << w.min_row << " - " << w.max_row << " | " << std::setprecision(0) << 100 * rows << " % | "
          << w.min_disparity_px << " - " << w.max_disparity_px << " | " << 100 * disparities << " % | "
          << 100 * rows * disparities << " % |\n";
    return w;
  };
  add_row(full_region);
  int previous_rows = 0, previous_disparities = 0;
  std::vector<double> work;
  for (double delta : {0.5, 1.0, 2.0, 4.0, 8.0}) {
    const ImageWindow w = add_row(RegionOfInterest{5.0, 5.0 + delta, -0.5, 1.0});
    ASSERT_TRUE(w.visible);
    EXPECT_GE(w.Rows(), previous_rows) << delta;
    EXPECT_GT(w.Disparities(), previous_disparities) << delta;
    EXPECT_NEAR(w.RowFraction(), w.Rows() / 480.0, 1e-12);
    previous_rows = w.Rows();
    previous_disparities = w.Disparities();
    work.push_back(w.RowFraction() * w.DisparityFraction(full.min_disparity_px, full.max_disparity_px));
  }
  add_row(RegionOfInterest{4.2, 7.5, -0.5, 1.0});
  add_row(RegionOfInterest{4.2, 7.5, -0.2, 0.2});
  // Half a metre at 5 m costs under 5 % of the full search (the rows above the one where
  // the ground at 5 m - 0.5 m appears, the disparities of 5 m - 5.5 m), and the cost grows
  // with the interval.
  EXPECT_LT(work.front(), 0.05);
  EXPECT_TRUE(std::is_sorted(work.begin(), work.end()));
  EXPECT_LT(work.front(), work.back());
  std::cout << table.str();
}

TEST(SelectWindow, ReportsRegionsOutOfSightAndClipsRegionsReachingTheCamera) {
  const StereoRig rig = testing::IdealRectifiedRig();
  // Behind the vehicle, and high above what the tilted cameras see.
  EXPECT_FALSE(SelectWindow(rig, RegionOfInterest{-6.0, -2.0, -0.5, 1.0}, ReferenceImage::kRight).visible);
  EXPECT_FALSE(SelectWindow(rig, RegionOfInterest{2.0, 4.0, 30.0, 40.0}, ReferenceImage::kRight).visible);
  EXPECT_EQ(SelectWindow(rig, RegionOfInterest{-6.0, -2.0, -0.5, 1.0}, ReferenceImage::kRight).Rows(), 0);
  // A region that holds the cameras: disparities grow without bound and are cut where no
  // pixel can match inside the other image.
  const ImageWindow w = SelectWindow(rig, RegionOfInterest{-1.0, 3.0, 0.0, 2.0}, ReferenceImage::kRight);
  ASSERT_TRUE(w.visible);
  EXPECT_TRUE(w.disparity_clipped);
  EXPECT_EQ(w.max_disparity_px, 639);
}

TEST(SelectWindow, NeedsARectifiedRigAndAnOrderedRegion) {
  EXPECT_THROW(SelectWindow(testing::PaperRig(), RegionOfInterest{}, ReferenceImage::kRight), std::invalid_argument);
  const StereoRig rig = testing::IdealRectifiedRig();
  EXPECT_THROW(SelectWindow(rig, RegionOfInterest{5.0, 4.0, 0.0, 1.0}, ReferenceImage::kRight), std::invalid_argument);
  EXPECT_THROW(SelectWindow(rig, RegionOfInterest{4.0, 5.0, 1.0, 0.0}, ReferenceImage::kRight), std::invalid_argument);
  EXPECT_THROW(SelectWindow(rig, RegionOfInterest{4.0, NAN, 0.0, 1.0}, ReferenceImage::kRight), std::invalid_argument);
  // Beyond 1000 m, each way: said as the option's (1e300 m was reported as an empty band).
  EXPECT_THROW(SelectWindow(rig, RegionOfInterest{1e300, 1e301, 0.0, 1.0}, ReferenceImage::kRight),
               std::invalid_argument);
  EXPECT_THROW(SelectWindow(rig, RegionOfInterest{4.0, 5.0, -2000.0, 1.0}, ReferenceImage::kRight),
               std::invalid_argument);
  EXPECT_THROW(SelectWindow(rig, RegionOfInterest{}, ReferenceImage::kRight, WindowSelectionOptions{-1}),
               std::invalid_argument);
}


// stereo-batch's default with a rig: the ground from the nearest point both images hold to the
// far limit, and per row the disparities of the region's points.
TEST(SelectGroundWindow, StartsAtTheNearestGroundBothImagesHoldAndBoundsEveryRowsPoints) {
  std::mt19937 rng(7);
  for (const RigCase& rc : Rigs()) {
    const RectifiedGeometry& g = *rc.rig.rectified;
    for (ReferenceImage reference : {ReferenceImage::kRight, ReferenceImage::kLeft}) {
      SCOPED_TRACE(std::string(rc.name) + ", " + ToString(reference));
      const Projector proj(rc.rig, reference);
      GroundWindowOptions options;
      const GroundWindow gw = SelectGroundWindow(rc.rig, reference, options);
      // Both images hold a ground point (X, Y, 0) when its reference pixel and its match are
      // inside: some X does at Y_min + 1 cm, none at Y_min - 1 cm.
      auto both_hold = [&](double y) {
        for (double x = -5; x <= 5; x += 0.002) {
          const auto p = proj.Project(Eigen::Vector3d(x, y, 0));
          const double other = reference == ReferenceImage::kRight ? p.column + p.disparity : p.column - p.disparity;
          if (p.depth > 0 && p.row >= -0.5 && p.row <= g.height_px - 0.5 && p.column >= -0.5 &&
              p.column <= g.width_px - 0.5 && other >= -0.5 && other <= g.width_px - 0.5) {
            return true;
          }
        }
        return false;
      };
      EXPECT_TRUE(both_hold(gw.region.y_min_m + 0.01));
      EXPECT_FALSE(both_hold(gw.region.y_min_m - 0.01));
      // The far limit: a 1 px disparity error moves a point by 25 cm along its ray there.
      const double fb = g.P_left(0, 0) * (-g.P_right(0, 3) / g.P_left(0, 0));
      EXPECT_NEAR(gw.far_limit_depth_m * gw.far_limit_depth_m / fb, 0.25, 1e-9);
      EXPECT_EQ(gw.region.z_min_m, options.z_min_m);
      EXPECT_EQ(gw.region.z_max_m, options.z_max_m);
      // The whole-region window is SelectWindow's.
      const ImageWindow w = SelectWindow(rc.rig, gw.region, reference);
      EXPECT_EQ(gw.window.min_disparity_px, w.min_disparity_px);
      EXPECT_EQ(gw.window.max_disparity_px, w.max_disparity_px);
      EXPECT_EQ(gw.window.min_row, w.min_row);
      EXPECT_EQ(gw.window.max_row, w.max_row);
      ASSERT_EQ(static_cast<int>(gw.row_disparity_px.size()), g.height_px);
      // Random points of the region seen by the reference image fall inside their row's band,
      // and the bands are tight: the widest exceeds the samples' spread by little.
      std::uniform_real_distribution<double> Y(gw.region.y_min_m, gw.region.y_max_m), Z(options.z_min_m, options.z_max_m),
          column(-0.5, g.width_px - 0.5);
      std::bernoulli_distribution coin(0.5);
      auto pick = [&](std::uniform_real_distribution<double>& u) {  // often at an end, where the extremes are
        return coin(rng) ? (coin(rng) ? u.a() : u.b()) : u(rng);
      };
      std::vector<double> lo(g.height_px, kInf), hi(g.height_px, -kInf);
      int seen = 0, outside = 0, guard_seen = 0, guard_outside = 0, guard_below = 0, sunk_seen = 0, sunk_outside = 0;
      EXPECT_LE(gw.guard_min_disparity_px, gw.window.min_disparity_px);
      ASSERT_EQ(gw.row_accept_min_px.size(), gw.row_disparity_px.size());
      for (int r = 0; r < g.height_px; ++r) {
        const auto [band_lo, band_hi] = gw.row_disparity_px[r];
        if (band_lo > band_hi) continue;
        EXPECT_LE(band_lo, gw.row_accept_min_px[r]);  // the guard lies below the accepted band
        EXPECT_LE(gw.row_accept_min_px[r], band_hi);
        EXPECT_GE(band_lo, gw.guard_min_disparity_px);
      }
      EXPECT_NEAR(gw.guard_y_max_m - proj.centre.y(), options.guard_distance_factor * (gw.region.y_max_m - proj.centre.y()),
                  1e-9);
      for (int i = 0; i < 400000; ++i) {
        // A point of the slab at a random column of the reference image (as above).
        const Eigen::Vector3d base(0, pick(Y), pick(Z));
        const double x = pick(column);
        const Eigen::Vector3d q0 = proj.vehicle_from_rect.transpose() * (base - proj.centre);
        const Eigen::Vector3d e = proj.vehicle_from_rect.transpose() * Eigen::Vector3d::UnitX();
        const double X = (proj.f * q0.x() - (x - proj.c_x) * q0.z()) / ((x - proj.c_x) * e.z() - proj.f * e.x());
        const auto p = proj.Project(Eigen::Vector3d(X, base.y(), base.z()));
        if (!(p.depth > 0) || p.row < -0.5 || p.row > g.height_px - 0.5 || p.column < -0.5 ||
            p.column > g.width_px - 0.5) {
          continue;
        }
        const int row = static_cast<int>(std::lround(p.row));
        ++seen;
        // Inside the accepted band: from the row's far limit to the top of its band.
        const int band_lo = gw.row_accept_min_px[row], band_hi = gw.row_disparity_px[row].second;
        outside += !(p.disparity >= band_lo && p.disparity <= band_hi);
        // The guard: a point of the slab beyond the far limit, out to guard_y_max_m, seen on a
        // row that has a band, lies in the searched band.
        const double y_guard = gw.region.y_max_m + (gw.guard_y_max_m - gw.region.y_max_m) * (i % 97) / 96.0;
        const Eigen::Vector3d g0 = proj.vehicle_from_rect.transpose() * (Eigen::Vector3d(0, y_guard, base.z()) - proj.centre);
        const double Xg = (proj.f * g0.x() - (x - proj.c_x) * g0.z()) / ((x - proj.c_x) * e.z() - proj.f * e.x());
        const auto pg = proj.Project(Eigen::Vector3d(Xg, y_guard, base.z()));
        if (pg.depth > 0 && pg.row >= -0.5 && pg.row <= g.height_px - 0.5) {
          const auto [guard_lo, guard_hi] = gw.row_disparity_px[static_cast<int>(std::lround(pg.row))];
          if (guard_lo <= guard_hi) {
            guard_outside += !(pg.disparity >= guard_lo);
            guard_below += pg.disparity < gw.row_accept_min_px[static_cast<int>(std::lround(pg.row))] - 1;
            ++guard_seen;
          }
        }
        // Below the heights: ground sunk under Z_min by up to tan(guard_tilt) per metre of Y (a
        // vehicle pitched up), out to guard_y_max_m, lies in the searched band too.
        const double y_sunk = gw.region.y_min_m + (gw.guard_y_max_m - gw.region.y_min_m) * (i % 89) / 88.0;
        const double z_sunk = options.z_min_m - std::tan(options.guard_tilt_deg * M_PI / 180.0) * y_sunk * (i % 7) / 6.0;
        const Eigen::Vector3d s0 = proj.vehicle_from_rect.transpose() * (Eigen::Vector3d(0, y_sunk, z_sunk) - proj.centre);
        const double Xs = (proj.f * s0.x() - (x - proj.c_x) * s0.z()) / ((x - proj.c_x) * e.z() - proj.f * e.x());
        const auto ps = proj.Project(Eigen::Vector3d(Xs, y_sunk, z_sunk));
        if (ps.depth > 0 && ps.row >= -0.5 && ps.row <= g.height_px - 0.5) {
          const auto [sunk_lo, sunk_hi] = gw.row_disparity_px[static_cast<int>(std::lround(ps.row))];
          if (sunk_lo <= sunk_hi && ps.disparity <= sunk_hi) {
            sunk_outside += !(ps.disparity >= sunk_lo);
            ++sunk_seen;
          }
        }
        lo[row] = std::min(lo[row], p.disparity);
        hi[row] = std::max(hi[row], p.disparity);
      }
      ASSERT_GT(seen, 20000);
      EXPECT_GT(sunk_seen, 1000);
      EXPECT_EQ(sunk_outside, 0);
      EXPECT_EQ(outside, 0);
      EXPECT_GT(guard_seen, 100);
      EXPECT_EQ(guard_outside, 0);
      EXPECT_GT(guard_below, 100);  // the guard searches below the accepted band
      double slack = 0;
      int rows = 0;
      for (int r = 0; r < g.height_px; ++r) {
        if (!(lo[r] <= hi[r])) continue;
        // The accepted band (above it, the tall guard searches what stands over the heights).
        const int band_lo = gw.row_accept_min_px[r];
        const int band_hi = gw.row_accept_max_px.empty() ? gw.row_disparity_px[r].second : gw.row_accept_max_px[r];
        slack += (band_hi - band_lo) - (hi[r] - lo[r]);
        ++rows;
      }
      EXPECT_LT(slack / rows, 6.0);  // margin 1 px each end, rounding, and samples short of the extremes
    }
  }
}

}  // namespace
// A requested interval's bands with a near guard (stereo-batch --requests): the points of the
// region lie in each row's accepted band, the points of the same heights nearer than the
// interval, down to Y_min / 3, in the band searched above it.
TEST(SelectRowBands, ANearGuardHoldsTheGroundNearerThanTheInterval) {
  std::mt19937 rng(11);
  for (const RigCase& rc : Rigs()) {
    const RectifiedGeometry& g = *rc.rig.rectified;
    for (ReferenceImage reference : {ReferenceImage::kRight, ReferenceImage::kLeft}) {
      SCOPED_TRACE(std::string(rc.name) + ", " + ToString(reference));
      const Projector proj(rc.rig, reference);
      const RegionOfInterest region{5.0, 7.0, -0.5, 1.0};
      const ImageWindow window = SelectWindow(rc.rig, region, reference);
      ASSERT_TRUE(window.visible);
      const RowBands b = SelectRowBands(rc.rig, reference, region, window, 3.0, 2.0, 3.0);
      const RowBands plain = SelectRowBands(rc.rig, reference, region, window, 3.0, 2.0, 1.0);
      const double y_near = proj.centre.y() + (region.y_min_m - proj.centre.y()) / 3.0;
      std::uniform_real_distribution<double> X(-4, 4), Z(region.z_min_m, region.z_max_m),
          Y(region.y_min_m, region.y_max_m), Y_near(y_near, region.y_min_m);
      int inside = 0, inside_wrong = 0, near = 0, near_outside = 0, near_above = 0;
      for (int i = 0; i < 200000; ++i) {
        const bool in_region = i % 2 == 0;
        const auto p = proj.Project(Eigen::Vector3d(X(rng), in_region ? Y(rng) : Y_near(rng), Z(rng)));
        if (!(p.depth > 0) || p.row < -0.5 || p.row > g.height_px - 0.5 || p.column < -0.5 ||
            p.column > g.width_px - 0.5) {
          continue;
        }
        const int row = static_cast<int>(std::lround(p.row));
        const auto [lo, hi] = b.row_disparity_px[row];
        if (lo > hi) continue;
        if (in_region) {
          ++inside;
          inside_wrong += !(p.disparity >= b.row_accept_min_px[row] && p.disparity <= b.row_accept_max_px[row]);
        } else if (p.disparity <= g.width_px - 1) {
          ++near;
          near_outside += !(p.disparity <= hi);
          near_above += p.disparity > b.row_accept_max_px[row] + 1;
        }
      }
      EXPECT_GT(inside, 10000);
      EXPECT_EQ(inside_wrong, 0);
      EXPECT_GT(near, 10000);
      EXPECT_EQ(near_outside, 0);
      EXPECT_GT(near_above, near / 4);  // the guard searches above the accepted band
      // Without the near guard the accepted bands are the same and nothing lies above them.
      EXPECT_EQ(plain.row_accept_max_px, b.row_accept_max_px);
      EXPECT_EQ(plain.row_accept_min_px, b.row_accept_min_px);
      for (int r = 0; r < g.height_px; ++r) {
        if (plain.row_disparity_px[r].first <= plain.row_disparity_px[r].second) {
          EXPECT_EQ(plain.row_disparity_px[r].second, plain.row_accept_max_px[r]) << r;
        }
      }
      EXPECT_GE(b.guard_max_disparity_px, plain.guard_max_disparity_px);
    }
  }
}

// The rig's default search with a tall guard: the region's points lie in each row's accepted
// band as without it; the points of a post taller than the heights (Z_max to Z_max + 1.5 m at
// the region's distances), above many rows' bands, lie in the band searched above them, to be
// rejected there; without the guard the bands and the accepted disparities are the same and
// nothing of the post above the heights is searched.
TEST(SelectGroundWindow, ATallGuardHoldsWhatStandsAboveTheHeights) {
  std::mt19937 rng(13);
  for (const RigCase& rc : Rigs()) {
    const RectifiedGeometry& g = *rc.rig.rectified;
    for (ReferenceImage reference : {ReferenceImage::kRight, ReferenceImage::kLeft}) {
      SCOPED_TRACE(std::string(rc.name) + ", " + ToString(reference));
      const Projector proj(rc.rig, reference);
      GroundWindowOptions options;
      EXPECT_EQ(options.tall_guard_m, 1.5);  // the default
      options.tall_guard_m = 0;
      const GroundWindow plain = SelectGroundWindow(rc.rig, reference, options);
      options.tall_guard_m = 1.5;
      const GroundWindow tall = SelectGroundWindow(rc.rig, reference, options);
      ASSERT_TRUE(tall.window.visible);
      EXPECT_TRUE(plain.row_accept_max_px.empty());
      ASSERT_EQ(tall.row_accept_max_px.size(), tall.row_disparity_px.size());
      EXPECT_EQ(plain.row_accept_min_px, tall.row_accept_min_px);
      EXPECT_EQ(plain.guard_max_disparity_px, plain.window.max_disparity_px);
      EXPECT_GT(tall.guard_max_disparity_px, plain.guard_max_disparity_px);
      const RegionOfInterest& region = tall.region;
      std::uniform_real_distribution<double> X(-4, 4), Y(region.y_min_m, region.y_max_m),
          Z(region.z_min_m, region.z_max_m), Z_tall(region.z_max_m, region.z_max_m + 1.5);
      int inside = 0, inside_wrong = 0, above = 0, above_outside = 0, above_accepted = 0, plain_holds = 0;
      for (int i = 0; i < 200000; ++i) {
        const bool in_region = i % 2 == 0;
        const auto p = proj.Project(Eigen::Vector3d(X(rng), Y(rng), in_region ? Z(rng) : Z_tall(rng)));
        if (!(p.depth > 0) || p.row < -0.5 || p.row > g.height_px - 0.5 || p.column < -0.5 ||
            p.column > g.width_px - 0.5) {
          continue;
        }
        const int row = static_cast<int>(std::lround(p.row));
        const auto [lo, hi] = tall.row_disparity_px[row];
        if (lo > hi) continue;
        // Without the guard a row's band ends at its accepted disparities.
        const auto [plain_lo, plain_hi] = plain.row_disparity_px[row];
        ASSERT_EQ(plain_lo, lo) << row;
        ASSERT_EQ(plain_hi, tall.row_accept_max_px[row]) << row;
        if (in_region) {
          ++inside;
          inside_wrong += !(p.disparity >= tall.row_accept_min_px[row] && p.disparity <= tall.row_accept_max_px[row]);
        } else {
          ++above;
          above_outside += !(p.disparity <= hi);
          above_accepted += p.disparity > tall.row_accept_max_px[row] + 1;  // beyond the band: the guard's
          plain_holds += p.disparity <= plain_hi;
        }
      }
      EXPECT_GT(inside, 10000);
      EXPECT_EQ(inside_wrong, 0);
      EXPECT_GT(above, 300);  // most of the post stands above the window's rows: not searched at all
      EXPECT_EQ(above_outside, 0);
      EXPECT_GT(above_accepted, above / 10);
      EXPECT_LT(plain_holds, above - above_accepted / 2);
    }
  }
}

// A vehicle pitched over a rock (or rolled on a slope) sees the ground ahead where a level
// vehicle would not: with its attitude the bands hold the region taken in the level frame at
// the mast base, every point of it; the level vehicle's bands miss much of it.
TEST(SelectGroundWindow, WithTheVehiclesAttitudeTheBandsHoldTheLevelRegion) {
  std::mt19937 rng(5);
  const StereoRig rig = testing::IdealRectifiedRig();
  const RectifiedGeometry& g = *rig.rectified;
  const ReferenceImage reference = ReferenceImage::kRight;
  const Projector proj(rig, reference);
  for (const auto& [pitch, roll] : {std::pair{19.4, 0.0}, std::pair{-15.0, 0.0}, std::pair{3.0, 12.0}}) {
    SCOPED_TRACE(::testing::Message() << "pitch " << pitch << ", roll " << roll);
    WindowSelectionOptions attitude;
    attitude.vehicle_pitch_deg = pitch;
    attitude.vehicle_roll_deg = roll;
    const Eigen::Matrix3d level_from_vehicle = attitude.LevelFromVehicle();
    // Rx(pitch) Ry(roll): the vehicle's forward axis rises by the pitch.
    EXPECT_NEAR(std::asin((level_from_vehicle * Eigen::Vector3d::UnitY()).z()), pitch * M_PI / 180, 1e-12);
    const GroundWindowOptions options;
    const GroundWindow tilted = SelectGroundWindow(rig, reference, options, attitude);
    const GroundWindow level = SelectGroundWindow(rig, reference, options);
    ASSERT_TRUE(tilted.window.visible);
    std::uniform_real_distribution<double> X(-6, 6), Y(tilted.region.y_min_m, tilted.region.y_max_m),
        Z(options.z_min_m, options.z_max_m);
    int seen = 0, missed = 0, missed_level = 0;
    for (int i = 0; i < 100000; ++i) {
      const Eigen::Vector3d in_level(X(rng), Y(rng), i % 2 == 0 ? 0.0 : Z(rng));
      const auto p = proj.Project(level_from_vehicle.transpose() * in_level);
      if (!(p.depth > 0) || p.row < -0.5 || p.row > g.height_px - 0.5 || p.column < -0.5 ||
          p.column > g.width_px - 0.5 || p.column + p.disparity > g.width_px - 0.5) {
        continue;
      }
      const int row = static_cast<int>(std::lround(p.row));
      ++seen;
      auto inside = [&](const GroundWindow& w) {
        const auto [lo, hi] = w.row_disparity_px[row];
        return lo <= hi && p.disparity >= w.row_accept_min_px[row] && p.disparity <= hi;
      };
      missed += !inside(tilted);
      missed_level += !inside(level);
    }
    EXPECT_GT(seen, 5000);
    EXPECT_EQ(missed, 0);
    EXPECT_GT(missed_level, seen / 20);  // without the attitude the search misses the ground
  }
  WindowSelectionOptions bad;
  bad.vehicle_pitch_deg = 90;
  EXPECT_THROW(SelectGroundWindow(rig, reference, GroundWindowOptions(), bad), std::invalid_argument);
}

}  // namespace lunarnav::calib
