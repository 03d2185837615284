#include "stereo/ncc_kernel.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <memory>
#include <vector>

#include "sim/layered_scene.h"

namespace lunarnav::stereo::internal {
namespace {

// The dispatched (AVX2 on most x86-64 CPUs) and portable kernels give identical records.
TEST(SelectKernel, AgreesBitForBitWithTheBaselineKernel) {
  sim::LayeredSceneOptions scene;
  scene.width = 200;
  scene.height = 100;
  sim::PlaneLayer plane;
  plane.d0_px = 11.2;
  plane.slope_x = 0.02;
  scene.layers = {plane};
  const auto pair = sim::RenderLayeredPair(scene);
  cv::Mat ref, tgt;
  pair.right.convertTo(ref, CV_16S, 1.0, -128.0);
  pair.left.convertTo(tgt, CV_16S, 1.0, -128.0);
  KernelInput in;
  in.ref = ref.ptr<std::int16_t>();
  in.tgt = tgt.ptr<std::int16_t>();
  in.width = 200;
  in.height = 100;
  in.step_x = 3;
  in.step_y = 2;
  in.mx = 3;
  in.my = 4;
  in.num_cols = (200 - 1) / 3 + 1;
  in.first_row = 8;
  in.num_rows = 40;
  in.d_min = -3;
  in.num_disp = 37;
  in.min_correlation = 0.5;
  in.ambiguity = 0.1;
  const std::size_t bytes = KernelWorkspaceBytes(in);
  std::vector<std::uint64_t> workspace(bytes / 8 + 8);
  std::vector<PeakRecord> a(in.num_rows * in.num_cols), b(a.size());
  // Collects the rows the kernel hands over.
  auto sink = [](void* context, int row, const PeakRecord* records) {
    auto* all = static_cast<std::vector<PeakRecord>*>(context);
    const int cols = (200 - 1) / 3 + 1;
    std::copy(records, records + cols, all->begin() + static_cast<std::ptrdiff_t>(row) * cols);
  };
  const char* name = nullptr;
  SelectKernel(&name)(in, 0, in.num_rows, workspace.data(), sink, &a);
  BaselineKernel()(in, 0, in.num_rows, workspace.data(), sink, &b);
  int searched = 0;
  for (std::size_t k = 0; k < a.size(); ++k) {
    ASSERT_EQ(a[k].status, b[k].status) << k << " " << name;
    if (a[k].status != PeakRecord::kSearched) continue;
    ++searched;
    ASSERT_EQ(a[k].best, b[k].best) << k;
    ASSERT_EQ(a[k].c_best, b[k].c_best) << k;
    ASSERT_EQ(a[k].c_second, b[k].c_second) << k;
  }
  EXPECT_GT(searched, 1000);
}

}  // namespace
}  // namespace lunarnav::stereo::internal
