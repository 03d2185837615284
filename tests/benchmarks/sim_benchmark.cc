// Speed of the stereo simulator: one 640 x 480 pair of the paper's rig over the terrain
// preset, 4 rays per pixel, raw cameras (distortion), with and without the ground truth.
//
//   build/bin/sim_benchmark
//
// The scene (terrain grid) is built once, outside the timing; `simulate stereo` reports its
// build time separately in summary.json.
#include <benchmark/benchmark.h>

#include <memory>

#include <tbb/global_control.h>

#include "sim/stereo_sim.h"

namespace {
using namespace lunarnav;

struct Setup {
  sim::StereoSimOptions options;
  calib::StereoRig rig;
  std::unique_ptr<sim::Scene> scene;
  std::vector<sim::VehiclePose> poses;
};

const Setup& GetSetup() {
  static const Setup setup = [] {
    Setup s;
    s.rig = sim::MakeSimulatedRig(s.options);
    s.scene = std::make_unique<sim::Scene>(sim::MakeSceneOptions(s.options));
    s.poses = sim::MakeTrajectory(s.options, &s.scene->terrain());
    return s;
  }();
  return setup;
}

// Arg 0: threads; arg 1: 1 = with ground truth.
void BM_RenderPaperPair(benchmark::State& state) {
  const Setup& s = GetSetup();
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, state.range(0));
  sim::StereoRenderOptions options = sim::MakeRenderOptions(s.options);
  options.compute_truth = state.range(1) != 0;
  const sim::StereoRenderer renderer(s.rig, options);
  for (auto _ : state) {
    const sim::StereoFrame frame = renderer.Render(*s.scene, s.poses.front());
    benchmark::DoNotOptimize(frame.left.data);
  }
}
BENCHMARK(BM_RenderPaperPair)
    ->Args({2, 1})->Args({2, 0})->Args({1, 1})->Args({1, 0})
    ->Unit(benchmark::kMillisecond)->UseRealTime()->Repetitions(3)->ReportAggregatesOnly(true);

}  // namespace

BENCHMARK_MAIN();
