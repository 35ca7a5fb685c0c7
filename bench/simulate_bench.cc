// Simulator speed: one paper-preset part pair (2 x 2592 x 1944) on one thread,
// split into rendering (ray casting, blur, noise, quantisation) and PNG encoding.
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
  uint64_t seed = 1;
  for (auto _ : state) {
    for (const RigSide camera : {RigSide::kLeft, RigSide::kRight}) {
      cv::Mat1b image = RenderPartImage(scene.station, camera, scene.part.geometry,
                                        scene.part.shots[0].truth.support_from_part, seed++, false);
      benchmark::DoNotOptimize(image.data);
    }
  }
}
BENCHMARK(BM_RenderPaperPartPair)->Unit(benchmark::kMillisecond)->UseRealTime();

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
