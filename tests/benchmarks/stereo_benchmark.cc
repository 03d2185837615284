// Speed of the NCC matcher, side by side with OpenCV's StereoBM on the same images, in one run.
//
//   build/bin/stereo_benchmark            (all; prints the NCC / StereoBM time ratio at the end)
//
// Every benchmark is repeated 7 times with the repetitions of all benchmarks randomly
// interleaved (so a slow spell of a shared machine hits both sides alike); the ratio uses
// the medians.
//
// Scenes are rendered by lunarnav::sim (a textured slanted ground plane with boxes).
#include <benchmark/benchmark.h>

#include <cstdio>
#include <map>
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

// Records every run's real time so the ratios can be printed after the table.
class RatioReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& run : runs) {
      if (run.aggregate_name == "median") times_[run.run_name.str()] = run.GetAdjustedRealTime();
    }
    ConsoleReporter::ReportRuns(runs);
  }
  void PrintRatios() const {
    for (const char* threads : {"2", "1"}) {
      const std::string ncc = std::string("BM_NccFullResolution/") + threads + "/repeats:7/real_time";
      const std::string bm = std::string("BM_StereoBM/") + threads + "/repeats:7/real_time";
      if (times_.count(ncc) == 0 || times_.count(bm) == 0) continue;
      std::printf("NCC / StereoBM time ratio (medians), %s thread(s): %.2f\n", threads,
                  times_.at(ncc) / times_.at(bm));
    }
  }

 private:
  std::map<std::string, double> times_;
};

}  // namespace

int main(int argc, char** argv) {
  std::vector<char*> args(argv, argv + argc);
  std::string interleave = "--benchmark_enable_random_interleaving=true";
  args.insert(args.begin() + 1, interleave.data());
  argc = static_cast<int>(args.size());
  argv = args.data();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  RatioReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  reporter.PrintRatios();
  benchmark::Shutdown();
  return 0;
}
