// Speed of the NCC matcher, side by side with OpenCV's StereoBM on the same images, in one run
// (and of the quality preset beside StereoSGBM: BM_QualityBesideSGBM).
//
//   build/bin/stereo_benchmark
//
// BM_SideBySide is the comparison: NCC and StereoBM alternate within every iteration, and
// the ratio is the median of the per-iteration ratios. The other benchmarks give absolute
// figures, repeated 7 times (medians).
//
// Scenes are rendered by lunarnav::sim (a textured slanted ground plane with boxes).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <string>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "sim/layered_scene.h"
#include "stereo/ncc_matcher.h"

namespace {
using namespace lunarnav;

const sim::RenderedPair& Scene() {
  static const sim::RenderedPair pair = [] {
    sim::LayeredSceneOptions scene;
    scene.width = 640;
    scene.height = 480;
    sim::PlaneLayer ground;  // disparity 20 at the top row to 116 at the bottom
    ground.d0_px = 20.0;
    ground.slope_y = 0.2;
    sim::PlaneLayer box;
    box.d0_px = 70.3;
    box.support_right = cv::Rect2d(250, 150, 120, 90);
    box.seed = 3;
    scene.layers = {ground, box};
    scene.noise_sigma = 1.0;
    return sim::RenderLayeredPair(scene);
  }();
  return pair;
}

// Full resolution, 128 disparities, the paper's 51 x 35 window, all filters, both cores.
void BM_NccFullResolution(benchmark::State& state) {
  stereo::NccOptions options;
  options.min_disparity_px = 0;
  options.max_disparity_px = 127;
  options.num_threads = static_cast<int>(state.range(0));
  stereo::NccResult result;  // reused, as stereo-batch reuses it across pairs
  for (auto _ : state) {
    stereo::MatchStereoPair(options, Scene().left, Scene().right, &result);
    benchmark::DoNotOptimize(result.disparity_px.data);
  }
  state.SetLabel(stereo::ActiveKernelName());
}
BENCHMARK(BM_NccFullResolution)->Arg(2)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime()
    ->Repetitions(7)->ReportAggregatesOnly(true);

// OpenCV's StereoBM, block 41, 128 disparities, on the same pair and threads.
void BM_StereoBM(benchmark::State& state) {
  cv::setNumThreads(static_cast<int>(state.range(0)));
  auto bm = cv::StereoBM::create(128, 41);
  cv::Mat disparity;
  for (auto _ : state) {
    bm->compute(Scene().left, Scene().right, disparity);
    benchmark::DoNotOptimize(disparity.data);
  }
}
BENCHMARK(BM_StereoBM)->Arg(2)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime()
    ->Repetitions(7)->ReportAggregatesOnly(true);

// The paper's configuration (Figure 3): rows 130-233, disparities 44-118, dx = 5, dy = 4,
// one core. The paper: 0.7 s per pair on a Sparc10; the target here is >= 1000 pairs/s.
void BM_NccPaperConfiguration(benchmark::State& state) {
  stereo::NccOptions options;
  options.min_row = 130;
  options.max_row = 233;
  options.min_disparity_px = 44;
  options.max_disparity_px = 118;
  options.step_x_px = 5;
  options.step_y_px = 4;
  options.num_threads = 1;
  stereo::NccResult result;
  for (auto _ : state) {
    stereo::MatchStereoPair(options, Scene().left, Scene().right, &result);
    benchmark::DoNotOptimize(result.disparity_px.data);
  }
  state.counters["pairs_per_s"] = benchmark::Counter(static_cast<double>(state.iterations()),
                                                     benchmark::Counter::kIsRate);
}
BENCHMARK(BM_NccPaperConfiguration)->Unit(benchmark::kMicrosecond)->UseRealTime()
    ->Repetitions(7)->ReportAggregatesOnly(true);

// The comparison itself: each iteration runs NCC, then StereoBM, on the same pair with the
// same threads, so both see the same state of a shared machine; the counters are the
// medians of the per-iteration times and of the per-iteration ratio NCC / StereoBM.
void BM_SideBySide(benchmark::State& state) {
  const int threads = static_cast<int>(state.range(0));
  stereo::NccOptions options;
  options.max_disparity_px = 127;
  options.num_threads = threads;
  stereo::NccResult result;
  cv::setNumThreads(threads);
  auto bm = cv::StereoBM::create(128, 41);
  cv::Mat disparity;
  std::vector<double> ncc_ms, bm_ms, ratio;
  using Clock = std::chrono::steady_clock;
  for (auto _ : state) {
    const auto t0 = Clock::now();
    stereo::MatchStereoPair(options, Scene().left, Scene().right, &result);
    const auto t1 = Clock::now();
    bm->compute(Scene().left, Scene().right, disparity);
    const auto t2 = Clock::now();
    ncc_ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
    bm_ms.push_back(std::chrono::duration<double, std::milli>(t2 - t1).count());
    ratio.push_back(ncc_ms.back() / bm_ms.back());
    state.SetIterationTime(std::chrono::duration<double>(t2 - t0).count());
  }
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  state.counters["ncc_ms"] = median(ncc_ms);
  state.counters["stereobm_ms"] = median(bm_ms);
  state.counters["ratio"] = median(ratio);
  state.SetLabel(stereo::ActiveKernelName());
}
BENCHMARK(BM_SideBySide)->Arg(2)->Arg(1)->UseManualTime()->Iterations(60)
    ->Unit(benchmark::kMillisecond);

// A pair of KITTI's size (1242 x 375): ground from disparity 5 at the top row to 99 at the
// bottom, and a box.
const sim::RenderedPair& KittiSizedScene() {
  static const sim::RenderedPair pair = [] {
    sim::LayeredSceneOptions scene;
    scene.width = 1242;
    scene.height = 375;
    sim::PlaneLayer ground;
    ground.d0_px = 5.0;
    ground.slope_y = 0.25;
    sim::PlaneLayer box;
    box.d0_px = 60.3;
    box.support_right = cv::Rect2d(500, 120, 200, 120);
    box.seed = 3;
    scene.layers = {ground, box};
    scene.noise_sigma = 1.0;
    return sim::RenderLayeredPair(scene);
  }();
  return pair;
}

// The quality preset in process (left reference, 128 disparities, the stated threads) beside
// OpenCV's StereoSGBM (MODE_HH, block 5, the penalties of scripts/bench-stereo-real, one
// thread) on a pair of KITTI's size, alternating within every iteration; counters are medians
// of the per-iteration times and of their ratio (issue 44's target is a whole process on real
// pairs: scripts/bench-stereo-real; this is the matcher alone, for development).
void BM_QualityBesideSGBM(benchmark::State& state) {
  const int threads = static_cast<int>(state.range(0));
  stereo::NccOptions options = stereo::PresetOptions("quality");
  options.reference = stereo::ReferenceImage::kLeft;
  options.min_disparity_px = 0;
  options.max_disparity_px = 127;
  options.num_threads = threads;
  stereo::NccResult result;
  auto sgbm = cv::StereoSGBM::create(0, 128, 5, 8 * 25, 32 * 25, 0, 0, 10, 100, 2, cv::StereoSGBM::MODE_HH);
  cv::Mat disparity;
  std::vector<double> quality_ms, sgbm_ms, ratio;
  using Clock = std::chrono::steady_clock;
  for (auto _ : state) {
    const auto t0 = Clock::now();
    stereo::MatchStereoPair(options, KittiSizedScene().left, KittiSizedScene().right, &result);
    const auto t1 = Clock::now();
    cv::setNumThreads(1);
    sgbm->compute(KittiSizedScene().left, KittiSizedScene().right, disparity);
    const auto t2 = Clock::now();
    quality_ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
    sgbm_ms.push_back(std::chrono::duration<double, std::milli>(t2 - t1).count());
    ratio.push_back(quality_ms.back() / sgbm_ms.back());
    state.SetIterationTime(std::chrono::duration<double>(t2 - t0).count());
  }
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  state.counters["quality_ms"] = median(quality_ms);
  state.counters["sgbm_ms"] = median(sgbm_ms);
  state.counters["ratio"] = median(ratio);
  for (const auto& [stage, seconds] : result.summary.stage_seconds) state.counters[stage] = 1e3 * seconds;
}
BENCHMARK(BM_QualityBesideSGBM)->Arg(2)->Arg(1)->UseManualTime()->Iterations(20)
    ->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
