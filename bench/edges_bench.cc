// Boundary detection speed on one thread (issue 3 "Speed"):
//   BM_DetectTexturedFrame/M   a deterministic 2592 x 1944 textured frame (hundreds of
//                              blurred discs, rectangles and lines at various contrasts,
//                              noise), whole image (restrict_to_part = false); target
//                              <= 5 ms per megapixel for blur-model (M = 2)
//   BM_DetectBacklitFrame/M    a paper-preset backlit frame with one part, default
//                              options; target <= 4 ms per frame
//   BM_CannyBacklitFrame       cv::Canny alone on that frame (issue: about 5 ms)
//   BM_CannyTexturedFrame      cv::Canny alone on the textured frame
//   BM_FusedCannyTexturedFrame the detector's own Canny (canny.h) alone on it; counter
//                              differences_vs_cv: pixels that differ from cv::Canny's
//   BM_ProfileCrossingStage/A  per-point cost of the profile refinement on the textured
//                              frame's Canny pixels (A: 0 one at a time, 1 centroid
//                              only, 2 batched as the detector runs it)
//   BM_SmoothChainStage        per-point cost of the chain smoothing
// M: 0 canny (pixel level), 1 zernike, 2 blur-model. Counters: ms_per_MP, ms_per_frame,
// points, edge_pixels (Canny pixels considered). The machine may be shared: repeat
// (--benchmark_repetitions=5) and read the minimum or the median.
//   build/edges_bench --benchmark_counters_tabular=true
#include <chrono>

#include <benchmark/benchmark.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <tbb/global_control.h>

#include "flatscan/boundary/boundary.h"
#include "flatscan/boundary/canny.h"
#include "flatscan/boundary/edge_refinement.h"
#include "flatscan/simulation/dataset.h"
#include "flatscan/simulation/image_formation.h"
#include "flatscan/util/random.h"

namespace flatscan {
namespace {

constexpr int kWidth = 2592, kHeight = 1944;

// Random shapes on a slowly varying background, blurred (sigma 1 px), noised (2 grey)
// and quantised; the same bytes on every run.
const cv::Mat1b& TexturedFrame() {
  static const cv::Mat1b frame = [] {
    Random rng(2024);
    cv::Mat1b image(kHeight, kWidth);  // drawn in 8 bits (antialiasing), blurred in float
    for (int v = 0; v < kHeight; ++v)
      for (int u = 0; u < kWidth; ++u)
        image(v, u) = cv::saturate_cast<uchar>(110.0 + 40.0 * std::sin(u * 0.002) * std::cos(v * 0.003));
    const int kShapes = 900;
    for (int i = 0; i < kShapes; ++i) {
      const cv::Point2f c(static_cast<float>(rng.Uniform(0, kWidth)), static_cast<float>(rng.Uniform(0, kHeight)));
      const double grey = rng.Uniform(15, 240);
      const double size = rng.Uniform(4, 90);
      constexpr int kShift = 4;
      auto fixed = [](cv::Point2f p) { return cv::Point(cvRound(p.x * 16), cvRound(p.y * 16)); };
      switch (i % 3) {
        case 0:
          cv::circle(image, fixed(c), cvRound(size * 16), grey, cv::FILLED, cv::LINE_AA, kShift);
          break;
        case 1: {
          const cv::RotatedRect r(c, cv::Size2f(static_cast<float>(size), static_cast<float>(rng.Uniform(4, 90))),
                                  static_cast<float>(rng.Uniform(0, 180)));
          cv::Point2f corners[4];
          r.points(corners);
          cv::Point poly[4];
          for (int k = 0; k < 4; ++k) poly[k] = fixed(corners[k]);
          cv::fillConvexPoly(image, poly, 4, grey, cv::LINE_AA, kShift);
          break;
        }
        default: {
          const double a = rng.Uniform(0, M_PI), length = rng.Uniform(40, 400);
          const cv::Point2f d(static_cast<float>(std::cos(a) * length), static_cast<float>(std::sin(a) * length));
          cv::line(image, fixed(c - 0.5f * d), fixed(c + 0.5f * d), grey, 1 + static_cast<int>(rng.Uniform(0, 8)),
                   cv::LINE_AA, kShift);
        }
      }
    }
    cv::Mat1f irradiance;
    image.convertTo(irradiance, CV_32F);
    cv::GaussianBlur(irradiance, irradiance, cv::Size(9, 9), 1.0, 1.0, cv::BORDER_REPLICATE);
    return QuantizeWithNoise(irradiance, 2.0, 11);
  }();
  return frame;
}

// The left image of a paper-preset part (2592 x 1944, distortion, vignetting, blur
// 1 px, noise 2 grey), as `flatscan simulate` renders it.
const cv::Mat1b& BacklitFrame() {
  static const cv::Mat1b frame = [] {
    const Station station = BuildStation(ScenePreset("paper"));
    Random rng(7);
    const SimulatedPart part = SampleSimulatedPart(station, 0, rng);
    return RenderPartImage(station, RigSide::kLeft, part.geometry, part.shots[0].truth.support_from_part, 1, false);
  }();
  return frame;
}

EdgeMethod MethodArg(const benchmark::State& state) {
  switch (state.range(0)) {
    case 0: return EdgeMethod::kCannyPixel;
    case 1: return EdgeMethod::kZernike;
    default: return EdgeMethod::kBlurModel;
  }
}

const char* MethodLabel(EdgeMethod method) {
  switch (method) {
    case EdgeMethod::kCannyPixel: return "canny";
    case EdgeMethod::kZernike: return "zernike";
    case EdgeMethod::kBlurModel: return "blur-model";
  }
  return "?";
}

// Runs `work` per iteration and sets ms per iteration (real time) and ms per MP.
template <typename Work>
void Timed(benchmark::State& state, const cv::Mat& image, Work work) {
  tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
  cv::setNumThreads(1);
  double total_ms = 0.0;
  for (auto _ : state) {
    const auto start = std::chrono::steady_clock::now();
    work();
    total_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  }
  const double iterations = static_cast<double>(state.iterations());
  state.counters["ms_per_frame"] = total_ms / iterations;
  state.counters["ms_per_MP"] = total_ms / iterations / (image.total() * 1e-6);
}

void DetectOn(benchmark::State& state, const cv::Mat1b& image, bool restrict_to_part) {
  BoundaryOptions options;
  options.method = MethodArg(state);
  options.restrict_to_part = restrict_to_part;
  BoundaryResult result;
  Timed(state, image, [&] {
    result = DetectBoundary(image, options);
    benchmark::DoNotOptimize(result.points.data());
  });
  state.counters["points"] = static_cast<double>(result.points.size());
  state.counters["contours"] = static_cast<double>(result.contours.size());
  state.counters["edge_pixels"] = result.edge_pixels;
  state.SetLabel(MethodLabel(options.method));
}

void BM_DetectTexturedFrame(benchmark::State& state) { DetectOn(state, TexturedFrame(), false); }
BENCHMARK(BM_DetectTexturedFrame)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_DetectBacklitFrame(benchmark::State& state) { DetectOn(state, BacklitFrame(), true); }
BENCHMARK(BM_DetectBacklitFrame)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

void CannyOn(benchmark::State& state, const cv::Mat1b& image) {
  const BoundaryOptions defaults;
  cv::Mat1b edges;
  Timed(state, image, [&] {
    cv::Canny(image, edges, defaults.canny_low, defaults.canny_high, 3, true);
    benchmark::DoNotOptimize(edges.data);
  });
  state.counters["edge_pixels"] = cv::countNonZero(edges);
}

void BM_CannyBacklitFrame(benchmark::State& state) { CannyOn(state, BacklitFrame()); }
BENCHMARK(BM_CannyBacklitFrame)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_CannyTexturedFrame(benchmark::State& state) { CannyOn(state, TexturedFrame()); }
BENCHMARK(BM_CannyTexturedFrame)->Unit(benchmark::kMillisecond)->UseRealTime();

// The detector's own fused Canny (canny.h) alone on the textured frame.
void BM_FusedCannyTexturedFrame(benchmark::State& state) {
  const cv::Mat1b& image = TexturedFrame();
  const BoundaryOptions defaults;
  cv::Mat1b map(image.rows + 2, image.cols + 2);
  std::vector<uint8_t*> stack;
  Timed(state, image, [&] {
    CannyInto(image, cv::Rect(1, 1, image.cols - 2, image.rows - 2),
              CannyThresholds::FromL2(defaults.canny_low, defaults.canny_high), map.ptr<uint8_t>(2) + 2,
              static_cast<std::ptrdiff_t>(map.step1()), stack);
    benchmark::DoNotOptimize(map.data);
  });
  const cv::Rect inside(2, 2, image.cols - 4, image.rows - 4);
  cv::Mat1b expected;
  cv::Canny(image, expected, defaults.canny_low, defaults.canny_high, 3, true);
  cv::Mat1b ours = map(inside + cv::Point(1, 1)) == kCannyEdge;
  state.counters["edge_pixels"] = cv::countNonZero(ours);
  state.counters["differences_vs_cv"] = cv::countNonZero(ours != expected(inside));
}
BENCHMARK(BM_FusedCannyTexturedFrame)->Unit(benchmark::kMillisecond)->UseRealTime();

// Stage costs on the textured frame's Canny pixels (ns per point): the profile
// crossing with the likelihood step (blur sigma 1), and the chain smoothing.
struct CannyPixels {
  std::vector<cv::Point> pixels;
  std::vector<ProfileAxis> axes;
  std::vector<double> sigmas;
};
const CannyPixels& TexturedCannyPixels() {
  static const CannyPixels data = [] {
    CannyPixels d;
    const cv::Mat1b& image = TexturedFrame();
    cv::Mat1b edges;
    cv::Canny(image, edges, 40, 100, 3, true);
    for (int v = 8; v < image.rows - 8; ++v)
      for (int u = 8; u < image.cols - 8; ++u) {
        if (!edges(v, u)) continue;
        const double gx = (image(v - 1, u + 1) + 2 * image(v, u + 1) + image(v + 1, u + 1)) -
                          (image(v - 1, u - 1) + 2 * image(v, u - 1) + image(v + 1, u - 1));
        const double gy = (image(v + 1, u - 1) + 2 * image(v + 1, u) + image(v + 1, u + 1)) -
                          (image(v - 1, u - 1) + 2 * image(v - 1, u) + image(v - 1, u + 1));
        const Eigen::Vector2d n = Eigen::Vector2d(gx, gy).normalized();
        const ProfileAxis a = ClosestProfileAxis(n);
        d.pixels.push_back({u, v});
        d.axes.push_back(a);
        d.sigmas.push_back(std::sqrt(1.0 + 1.0 / 12) * a.Length() / std::abs(n.dot(Eigen::Vector2d(a.du, a.dv))));
      }
    return d;
  }();
  return data;
}

// Arg 0: one pixel at a time with the likelihood step, 1: centroid only, 2: batched
// (MeasureProfileCrossings, SIMD lanes), as the detector runs it.
void BM_ProfileCrossingStage(benchmark::State& state) {
  const CannyPixels& d = TexturedCannyPixels();
  const cv::Mat1b& image = TexturedFrame();
  std::vector<ProfileRequest> requests(d.pixels.size());
  for (size_t i = 0; i < d.pixels.size(); ++i)
    requests[i] = {d.pixels[i].x, d.pixels[i].y, d.axes[i], static_cast<float>(d.sigmas[i])};
  std::vector<ProfileCrossing> out;
  double sum = 0;
  for (auto _ : state) {
    if (state.range(0) == 2) {
      MeasureProfileCrossings(image, requests, 1.2, out);
      sum += out[0].position;
    } else {
      for (size_t i = 0; i < d.pixels.size(); ++i)
        sum += MeasureProfileCrossing(image, d.pixels[i].x, d.pixels[i].y, d.axes[i], 1.2,
                                      state.range(0) ? 0.0 : d.sigmas[i]).position;
    }
    benchmark::DoNotOptimize(sum);
  }
  state.counters["time_per_point"] = benchmark::Counter(static_cast<double>(d.pixels.size()) * state.iterations(),
                                                        benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_ProfileCrossingStage)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

void BM_SmoothChainStage(benchmark::State& state) {
  // A closed chain along a circle of radius 40 px with noise, 160 k points in chains of 250.
  std::vector<std::vector<ChainPoint>> chains(640);
  Random rng(3);
  for (auto& chain : chains)
    for (int i = 0; i < 250; ++i) {
      const double a = 2 * M_PI * i / 250;
      ChainPoint p;
      p.normal = Eigen::Vector2d(std::cos(a), std::sin(a));
      p.p = (40 + rng.Normal(0, 0.02)) * p.normal;
      chain.push_back(p);
    }
  for (auto _ : state) {
    for (auto& chain : chains) {
      std::vector<ChainPoint> copy = chain;
      SmoothAndCorrectChain(copy, true, 1.08);
      benchmark::DoNotOptimize(copy.data());
    }
  }
  state.counters["time_per_point"] = benchmark::Counter(640.0 * 250 * state.iterations(),
                                                      benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_SmoothChainStage)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace flatscan

BENCHMARK_MAIN();
