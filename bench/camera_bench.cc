// The camera path through Aravis's in-process fake cameras, on paper-preset frames
// (2 x 2592 x 1944 Mono8):
//   BM_CameraPairs: triggered pairs taken and released, no inspection: pairs per second
//     and the CPU our side spends per pair (the thread that triggers, waits and pairs),
//     against BM_CopyFramePair, one copy of a pair's pixels (what a copy would add);
//   BM_ReduceMono12Pair: a Mono12 pair reduced to 8 bits (the one copy Mono12 costs);
//   BM_StationThroughFakeCameras: `flatscan station`'s pipeline fed by the fake cameras at
//     a rate the station keeps up with: latency from trigger to committed record.
// The fakes fill a frame with a memcpy from memory (standing in for the camera's DMA), on
// their own threads; the process's CPU per pair includes it.
//   build/camera_bench --benchmark_min_time=1
#include <sys/resource.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <mutex>
#include <vector>

#include <benchmark/benchmark.h>
#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <tbb/global_control.h>

#include "flatscan/acquisition/camera_pair_source.h"
#include "flatscan/station/inspection_station.h"
#include "flatscan/station/rate_trigger.h"
#include "flatscan/store/results_store.h"
#include "paper_pair.h"

namespace flatscan {
namespace {
using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

// The pair shown at every trigger.
const PaperPair& TheFrames() {
  static const PaperPair frames = RenderPaperPair();
  return frames;
}

class MemoryScene : public FakeScene {
 public:
  explicit MemoryScene(int64_t triggers) : triggers_(triggers) {}
  int64_t Triggers() const override { return triggers_; }
  cv::Size FrameSize() const override { return TheFrames().left.size(); }
  std::string Id(int64_t trigger) const override { return fmt::format("p{}", trigger); }
  void Fill(int64_t, bool left, int width, int height, uint8_t* pixels) override {
    const cv::Mat1b& image = left ? TheFrames().left : TheFrames().right;
    std::memcpy(pixels, image.data, size_t(width) * size_t(height));
  }

 private:
  int64_t triggers_;
};

double ThreadCpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return double(t.tv_sec) + double(t.tv_nsec) * 1e-9;
}

double ProcessCpuSeconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  const auto s = [](const timeval& t) { return double(t.tv_sec) + double(t.tv_usec) * 1e-6; };
  return s(u.ru_utime) + s(u.ru_stime);
}

double cpu_us_per_pair[2] = {0, 0};  // [0] one copy of a pair, [1] our side of the camera path

void BM_CopyFramePair(benchmark::State& state) {
  const PaperPair& f = TheFrames();
  cv::Mat1b left(f.left.size()), right(f.right.size());
  const double cpu0 = ThreadCpuSeconds();
  for (auto _ : state) {
    f.left.copyTo(left);
    f.right.copyTo(right);
    benchmark::DoNotOptimize(left.data);
    benchmark::DoNotOptimize(right.data);
  }
  cpu_us_per_pair[0] = (ThreadCpuSeconds() - cpu0) * 1e6 / double(state.iterations());
  state.counters["cpu_us_per_pair"] = cpu_us_per_pair[0];
  state.SetLabel("one copy of a pair's pixels (avoided)");
}
BENCHMARK(BM_CopyFramePair)->Unit(benchmark::kMillisecond);

// A Mono12 camera's pair (16-bit words) reduced to 8 bits (aravis_camera.h's rule): the
// copy that --pixel-format Mono12 costs, against BM_CopyFramePair.
void BM_ReduceMono12Pair(benchmark::State& state) {
  const PaperPair& f = TheFrames();
  cv::Mat_<uint16_t> left, right;
  f.left.convertTo(left, CV_16U, 16);
  f.right.convertTo(right, CV_16U, 16);
  for (auto _ : state) {
    cv::Mat1b l = ReduceToMono8(left.ptr<uint16_t>(), left.cols, left.rows, left.step1(), 12);
    cv::Mat1b r = ReduceToMono8(right.ptr<uint16_t>(), right.cols, right.rows, right.step1(), 12);
    benchmark::DoNotOptimize(l.data);
    benchmark::DoNotOptimize(r.data);
  }
  state.SetLabel("Mono12 -> 8 bits, both frames");
}
BENCHMARK(BM_ReduceMono12Pair)->Unit(benchmark::kMillisecond);

void BM_CameraPairs(benchmark::State& state) {
  spdlog::set_level(spdlog::level::warn);
  constexpr int kPairs = 60;
  double seconds = 0, our_cpu = 0, process_cpu = 0;
  for (auto _ : state) {
    state.PauseTiming();
    CameraSourceOptions options;
    options.trigger_on_demand = true;
    const auto source = MakeFakeSource("aravis-fake:bench", std::make_shared<MemoryScene>(kPairs), options);
    state.ResumeTiming();
    const auto start = Clock::now();
    const double cpu0 = ThreadCpuSeconds(), process0 = ProcessCpuSeconds();
    for (int k = 0; k < kPairs; ++k) {
      const std::optional<SourcePair> pair = source->Next(milliseconds(2000));
      if (!pair || pair->not_measurable) {
        state.SkipWithError(pair ? pair->not_measurable->c_str() : "no pair");
        return;
      }
      benchmark::DoNotOptimize(pair->left_image.data);
    }
    our_cpu += ThreadCpuSeconds() - cpu0;
    process_cpu += ProcessCpuSeconds() - process0;
    seconds += std::chrono::duration<double>(Clock::now() - start).count();
  }
  const double pairs = double(kPairs) * double(state.iterations());
  cpu_us_per_pair[1] = our_cpu * 1e6 / pairs;
  state.counters["pairs_per_s"] = pairs / seconds;
  state.counters["cpu_us_per_pair"] = cpu_us_per_pair[1];
  state.counters["process_cpu_us_per_pair"] = process_cpu * 1e6 / pairs;
  state.SetLabel("trigger + wait + pair + release (fakes fill at 4 ms ticks)");
}
BENCHMARK(BM_CameraPairs)->Unit(benchmark::kMillisecond)->UseRealTime();

// Trigger times and commit times: record k is trigger k's (one record per trigger, in order).
class CommitTimes : public RecordPublisher {
 public:
  void Publish(const StationRecord& record, const StationCounts&) override {
    std::lock_guard lock(mutex);
    times.push_back(Clock::now());
    measured += record.inspection.measured;
  }
  std::mutex mutex;
  std::vector<Clock::time_point> times;
  int measured = 0;
};

void BM_StationThroughFakeCameras(benchmark::State& state) {
  tbb::global_control two_threads(tbb::global_control::max_allowed_parallelism, 2);
  cv::setNumThreads(1);
  spdlog::set_level(spdlog::level::warn);
  const double hz = double(state.range(0));
  constexpr int kTriggers = 12;
  std::vector<double> latency_ms;
  for (auto _ : state) {
    const std::string db = (std::filesystem::temp_directory_path() / "flatscan_camera_bench.db").string();
    std::filesystem::remove(db);
    auto store = OpenSqliteStore(db, true);
    const auto source = MakeFakeSource("aravis-fake:bench", std::make_shared<MemoryScene>(kTriggers), {});
    StationOptions options;
    options.until_idle_s = 1.5;
    InspectionStation station({TheFrames().recipe}, *source, *store, options);
    CommitTimes commits;
    station.AddPublisher(&commits);
    std::vector<Clock::time_point> fired;
    std::mutex fired_mutex;
    const std::atomic<bool> stop{false};
    {
      RateTrigger rate(hz, [&] {
        {
          std::lock_guard lock(fired_mutex);
          if (fired.size() == size_t(kTriggers)) return;
          fired.push_back(Clock::now());
        }
        source->Trigger();
      });
      station.Run(stop);
    }
    if (commits.times.size() != fired.size() || commits.measured != kTriggers) {
      state.SkipWithError(fmt::format("{} triggers, {} records, {} measured", fired.size(), commits.times.size(),
                                      commits.measured).c_str());
      return;
    }
    for (size_t k = 0; k < fired.size(); ++k)
      latency_ms.push_back(std::chrono::duration<double, std::milli>(commits.times[k] - fired[k]).count());
  }
  std::sort(latency_ms.begin(), latency_ms.end());
  state.counters["latency_median_ms"] = latency_ms[latency_ms.size() / 2];
  state.counters["latency_max_ms"] = latency_ms.back();
  state.SetLabel(fmt::format("trigger -> committed record at {} Hz", hz));
}
BENCHMARK(BM_StationThroughFakeCameras)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(2);

}  // namespace
}  // namespace flatscan

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  if (flatscan::cpu_us_per_pair[0] > 0 && flatscan::cpu_us_per_pair[1] > 0)
    std::printf("camera path, our side: %.0f us CPU per pair; one copy of a pair's pixels: %.0f us (%.2f of a copy)\n",
                flatscan::cpu_us_per_pair[1], flatscan::cpu_us_per_pair[0],
                flatscan::cpu_us_per_pair[1] / flatscan::cpu_us_per_pair[0]);
  std::filesystem::remove(std::filesystem::temp_directory_path() / "flatscan_camera_bench.db");
  return 0;
}
