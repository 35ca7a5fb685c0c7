// Simulator speed: one paper-preset part pair (2 x 2592 x 1944) on one thread,
// split into rendering (ray casting, blur, noise, quantisation) and PNG encoding.
// The render is timed with both side-face models (argument 0: local, the default; 1:
// centre, one direction), so that the cost of the local faces' sheet coordinates is a
// ratio measured in one run.
//   build/simulate_bench --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>
#include <opencv2/imgcodecs.hpp>
#include <tbb/global_control.h>

#include "flatscan/simulation/dataset.h"

namespace flatscan {
namespace {

struct PaperPart {
  Station station = BuildStation(ScenePreset("paper"));
  SimulatedPart part;
  PaperPart() {
    Random rng(7);
    part = SampleSimulatedPart(station, 0, rng);
  }
};

void BM_RenderPaperPartPair(benchmark::State& state) {
  tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
  PaperPart scene;
  scene.part.geometry.side_faces = state.range(0) == 0 ? SideFaceModel::kLocalNormal : SideFaceModel::kCentreNormal;
  state.SetLabel(SideFaceModelName(scene.part.geometry.side_faces));
  uint64_t seed = 1;
  for (auto _ : state) {
    for (const RigSide camera : {RigSide::kLeft, RigSide::kRight}) {
      cv::Mat1b image = RenderPartImage(scene.station, camera, scene.part.geometry,
                                        scene.part.shots[0].truth.support_from_part, seed++, false);
      benchmark::DoNotOptimize(image.data);
    }
  }
}
BENCHMARK(BM_RenderPaperPartPair)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_EncodePaperPartPairPng(benchmark::State& state) {
  PaperPart scene;
  const cv::Mat1b images[2] = {
      RenderPartImage(scene.station, RigSide::kLeft, scene.part.geometry, scene.part.shots[0].truth.support_from_part, 1, false),
      RenderPartImage(scene.station, RigSide::kRight, scene.part.geometry, scene.part.shots[0].truth.support_from_part, 2, false)};
  std::vector<uchar> buffer;
  for (auto _ : state)
    for (const cv::Mat1b& image : images) {
      cv::imencode(".png", image, buffer, {cv::IMWRITE_PNG_COMPRESSION, 1});
      benchmark::DoNotOptimize(buffer.data());
    }
}
BENCHMARK(BM_EncodePaperPartPairPng)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace flatscan

BENCHMARK_MAIN();
