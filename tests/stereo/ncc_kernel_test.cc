#include "stereo/ncc_kernel.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <iostream>
#include <string>
#include <memory>
#include <vector>

#include "sim/layered_scene.h"

namespace lunarnav::stereo::internal {
namespace {

// Every kernel the host runs (baseline, AVX2, AVX-512) gives the baseline's records bit for
// bit; the test says which ran.
TEST(RunnableKernels, AllAgreeBitForBitWithTheBaselineKernel) {
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
  BaselineKernel()(in, 0, in.num_rows, workspace.data(), sink, &b);
  const auto kernels = RunnableKernels();
  ASSERT_FALSE(kernels.empty());
  std::string ran;
  int searched = 0;
  for (const auto& [name, kernel] : kernels) {
    ran += std::string(ran.empty() ? "" : ", ") + name;
    std::fill(a.begin(), a.end(), PeakRecord{});
    kernel(in, 0, in.num_rows, workspace.data(), sink, &a);
    searched = 0;
    for (std::size_t k = 0; k < a.size(); ++k) {
      ASSERT_EQ(a[k].status, b[k].status) << k << " " << name;
      if (a[k].status != PeakRecord::kSearched) continue;
      ++searched;
      ASSERT_EQ(a[k].best, b[k].best) << k << " " << name;
      ASSERT_EQ(a[k].c_best, b[k].c_best) << k << " " << name;
      ASSERT_EQ(a[k].c_second, b[k].c_second) << k << " " << name;
    }
  }
  std::cout << "kernels compared with the baseline: " << ran << "\n";
  ::testing::Test::RecordProperty("kernels", ran);
  const char* selected = nullptr;
  SelectKernel(&selected);
  EXPECT_NE(ran.find(selected), std::string::npos) << "the selected kernel " << selected << " was not compared";
  EXPECT_GT(searched, 1000);
}

}  // namespace
}  // namespace lunarnav::stereo::internal
