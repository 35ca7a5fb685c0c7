// Inspection speed on one paper-preset part pair (2 x 2592 x 1944), one thread, from
// decoded images, per stage; PNG decoding apart; and OpenCV's StereoSGBM (3-way) on
// the rectified pair (rectification remap apart). After the run, the ratio of the two
// (measured in this one run, on the same pair) is printed.
//   build/inspect_bench --benchmark_counters_tabular=true
#include <chrono>
#include <cstdio>
#include <filesystem>

#include <benchmark/benchmark.h>
#include <spng.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <tbb/global_control.h>

#include "flatscan/inspection/inspect_part.h"
#include "flatscan/io/image_io.h"
#include "flatscan/simulation/dataset.h"
#include "flatscan/util/ordered_parallel.h"

namespace flatscan {
namespace {

// Mean wall time per iteration of the two benchmarks compared at the end (ms).
double inspect_ms = 0, sgbm_ms = 0;

template <typename F>
double MeanMs(benchmark::State& state, F body) {
  double total = 0;
  for (auto _ : state) {
    const auto start = std::chrono::steady_clock::now();
    body();
    total += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  }
  return total / std::max<int64_t>(1, state.iterations());
}

struct PaperPair {
  Station station = BuildStation(ScenePreset("paper"));
  SimulatedPart part;
  cv::Mat1b left, right;
  PaperPair() {
    Random rng(7);
    part = SampleSimulatedPart(station, 0, rng);
    left = RenderPartImage(station, RigSide::kLeft, part.geometry, part.shots[0].truth.support_from_part, 1, false);
    right = RenderPartImage(station, RigSide::kRight, part.geometry, part.shots[0].truth.support_from_part, 2, false);
  }
};

const PaperPair& Pair() {
  static const PaperPair pair;
  return pair;
}

void BM_InspectPaperPair(benchmark::State& state) {
  tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
  cv::setNumThreads(1);
  const PaperPair& p = Pair();
  InspectionParams params;
  params.thickness_mm = p.part.geometry.SideHeight();
  // Argument: 0 the local side faces (the default), 1 one direction per part (the
  // earlier model), to read the cost of the coupled face fit as a ratio in one run.
  params.side_faces = state.range(0) == 0 ? SideFaceModel::kLocalNormal : SideFaceModel::kCentreNormal;
  state.SetLabel(SideFaceModelName(params.side_faces));
  std::map<std::string, double> stages;
  const double mean_ms = MeanMs(state, [&] {
    const InspectionResult r = InspectPart(p.station.rig, p.station.plane, p.left, p.right, params);
    for (const auto& [stage, ms] : r.timing_ms) stages[stage] += ms;
  });
  if (state.range(0) == 0) inspect_ms = mean_ms;  // the product's figure, against SGBM below
  for (const auto& [stage, ms] : stages) state.counters[stage + "_ms"] = ms / state.iterations();
}
BENCHMARK(BM_InspectPaperPair)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();

// libspng's decoder, for the comparison (8-bit grey PNGs).
cv::Mat1b DecodeWithSpng(const std::vector<uchar>& png) {
  spng_ctx* ctx = spng_ctx_new(0);
  spng_ihdr ihdr{};
  size_t size = 0;
  spng_set_png_buffer(ctx, png.data(), png.size());
  spng_get_ihdr(ctx, &ihdr);
  cv::Mat1b image(int(ihdr.height), int(ihdr.width));
  spng_decoded_image_size(ctx, SPNG_FMT_G8, &size);
  const int rc = size == image.total() ? spng_decode_image(ctx, image.data, size, SPNG_FMT_G8, 0) : SPNG_EOVERFLOW;
  spng_ctx_free(ctx);
  if (rc != 0) std::abort();
  return image;
}

// One pair of PNGs as the simulator writes them, decoded on one thread: argument 0 with
// OpenCV's decoder (libpng), 1 with libspng, 2 with flatscan's (DecodeGreyPng:
// libdeflate, what ReadGreyImage uses for 8-bit grey PNGs). Ratios printed at the end.
double decode_ms[3] = {0, 0, 0};
void BM_DecodePngPair(benchmark::State& state) {
  cv::setNumThreads(1);
  std::vector<uchar> l, r;
  cv::imencode(".png", Pair().left, l);
  cv::imencode(".png", Pair().right, r);
  const int64_t decoder = state.range(0);
  state.SetLabel(decoder == 0 ? "OpenCV (libpng)" : decoder == 1 ? "libspng" : "flatscan (libdeflate)");
  decode_ms[decoder] = MeanMs(state, [&] {
    for (const std::vector<uchar>* png : {&l, &r}) {
      const cv::Mat image = decoder == 0   ? cv::imdecode(*png, cv::IMREAD_GRAYSCALE)
                            : decoder == 1 ? DecodeWithSpng(*png)
                                           : DecodeGreyPng(*png, "bench");
      benchmark::DoNotOptimize(image.data);
    }
  });
}
BENCHMARK(BM_DecodePngPair)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

// Batch throughput on 2 threads from PNG files, the way `inspect --pairs` runs
// (ParallelInOrder over the pairs, each read with ReadGreyImage and inspected on one
// thread): argument 1 decodes and inspects, 0 only decodes (the floor). Pairs per second
// in items_per_second; the ratio is printed at the end (same files, same run).
double batch_pairs_per_s[2] = {0, 0};
void BM_BatchFromPngFiles(benchmark::State& state) {
  tbb::global_control two_threads(tbb::global_control::max_allowed_parallelism, 2);
  cv::setNumThreads(1);
  const PaperPair& p = Pair();
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "flatscan_batch_bench";
  std::filesystem::create_directories(dir);
  const std::string left = (dir / "left.png").string(), right = (dir / "right.png").string();
  cv::imwrite(left, p.left);
  cv::imwrite(right, p.right);
  InspectionParams params;
  params.thickness_mm = p.part.geometry.SideHeight();
  const bool inspect = state.range(0) == 1;
  constexpr size_t kPairs = 16;
  double seconds = 0;
  for (auto _ : state) {
    const auto start = std::chrono::steady_clock::now();
    ParallelInOrder<double>(
        kPairs, 4,
        [&](size_t) {
          const cv::Mat1b l = ReadGreyImage(left), r = ReadGreyImage(right);
          return inspect ? InspectPart(p.station.rig, p.station.plane, l, r, params).values.flatness_mm : 0.0;
        },
        [](size_t, double& flatness) { benchmark::DoNotOptimize(flatness); });
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  state.SetItemsProcessed(static_cast<int64_t>(kPairs) * state.iterations());
  state.SetLabel(inspect ? "decode + inspect" : "decode only (floor)");
  batch_pairs_per_s[state.range(0)] = static_cast<double>(kPairs * state.iterations()) / seconds;
  std::filesystem::remove_all(dir);
}
BENCHMARK(BM_BatchFromPngFiles)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_StereoSgbm3WayRectifiedPair(benchmark::State& state) {
  cv::setNumThreads(1);
  const PaperPair& p = Pair();
  const StereoRig& rig = p.station.rig;
  const cv::Size size(rig.left.width, rig.left.height);
  cv::Mat m1x, m1y, m2x, m2y, l, r, disparity;
  cv::initUndistortRectifyMap(rig.left.CameraMatrix(), rig.left.DistortionVector(), rig.rectification.R1,
                              rig.rectification.P1, size, CV_32FC1, m1x, m1y);
  cv::initUndistortRectifyMap(rig.right.CameraMatrix(), rig.right.DistortionVector(), rig.rectification.R2,
                              rig.rectification.P2, size, CV_32FC1, m2x, m2y);
  cv::remap(p.left, l, m1x, m1y, cv::INTER_LINEAR);
  cv::remap(p.right, r, m2x, m2y, cv::INTER_LINEAR);
  // Disparities of the part at the working distance span about 0..160 px here.
  auto sgbm = cv::StereoSGBM::create(0, 256, 5, 8 * 25, 32 * 25, 1, 0, 10, 100, 1, cv::StereoSGBM::MODE_SGBM_3WAY);
  sgbm_ms = MeanMs(state, [&] {
    sgbm->compute(l, r, disparity);
    benchmark::DoNotOptimize(disparity.data);
  });
}
BENCHMARK(BM_StereoSgbm3WayRectifiedPair)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(2);

}  // namespace
}  // namespace flatscan

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  if (flatscan::inspect_ms > 0 && flatscan::sgbm_ms > 0)
    std::printf("StereoSGBM 3-way on the rectified pair: %.1f ms; flatscan inspection: %.2f ms; ratio %.0fx (same pair, "
                "same run, one thread)\n",
                flatscan::sgbm_ms, flatscan::inspect_ms, flatscan::sgbm_ms / flatscan::inspect_ms);
  if (flatscan::decode_ms[0] > 0 && flatscan::decode_ms[1] > 0 && flatscan::decode_ms[2] > 0)
    std::printf("PNG pair decoding on one thread: OpenCV %.1f ms, libspng %.1f ms (%.2f of OpenCV's time), flatscan "
                "%.1f ms (%.2f)\n",
                flatscan::decode_ms[0], flatscan::decode_ms[1], flatscan::decode_ms[1] / flatscan::decode_ms[0],
                flatscan::decode_ms[2], flatscan::decode_ms[2] / flatscan::decode_ms[0]);
  if (flatscan::batch_pairs_per_s[0] > 0 && flatscan::batch_pairs_per_s[1] > 0)
    std::printf("batch from PNG files on 2 threads: %.1f pairs/s (decoding alone: %.1f pairs/s); %.2f of the floor's "
                "rate\n",
                flatscan::batch_pairs_per_s[1], flatscan::batch_pairs_per_s[0],
                flatscan::batch_pairs_per_s[1] / flatscan::batch_pairs_per_s[0]);
  return 0;
}
