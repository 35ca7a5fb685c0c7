// Station throughput from PNG files on 2 threads: `flatscan station`'s pipeline (hash,
// decode, inspect, commit to a real SQLite store with synchronous=FULL, in order) on
// paper-preset pairs (2 x 2592 x 1944), against decoding alone (the floor) on the same
// files in the same run; the ratio is printed at the end.
//   build/station_bench --benchmark_min_time=2
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include <benchmark/benchmark.h>
#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <spdlog/spdlog.h>
#include <tbb/global_control.h>

#include "flatscan/io/image_io.h"
#include "flatscan/station/inspection_station.h"
#include "flatscan/store/results_store.h"
#include "flatscan/util/ordered_parallel.h"
#include "paper_pair.h"

namespace flatscan {
namespace {
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr int kPairs = 48;  // per iteration: one paper pair's files under 48 ids

// A paper-preset pair written as PNG files, a pairs file listing it kPairs times, and the
// recipe a station measures it with.
struct Files {
  fs::path dir = fs::temp_directory_path() / "flatscan_station_bench";
  LoadedRecipe recipe;
  Files() {
    fs::remove_all(dir);
    fs::create_directories(dir);
    const PaperPair pair = RenderPaperPair();
    cv::imwrite((dir / "left.png").string(), pair.left);
    cv::imwrite((dir / "right.png").string(), pair.right);
    std::ofstream csv(dir / "pairs.csv");
    csv << "id,left,right\n";
    for (int i = 0; i < kPairs; ++i) csv << fmt::format("p{},left.png,right.png\n", i);
    recipe = pair.recipe;
  }
};

const Files& TheFiles() {
  static const Files files;
  return files;
}

// The time of the last commit: the station's throughput is kPairs over start to then
// (not to its idle exit, which waits for the source's poll).
class LastCommit : public RecordPublisher {
 public:
  void Publish(const StationRecord&, const StationCounts&) override { last = Clock::now(); }
  Clock::time_point last;
};

double pairs_per_s[2] = {0, 0};  // [0] decoding alone, [1] the station

void BM_DecodeFloor(benchmark::State& state) {
  tbb::global_control two_threads(tbb::global_control::max_allowed_parallelism, 2);
  cv::setNumThreads(1);
  const Files& f = TheFiles();
  const std::string left = (f.dir / "left.png").string(), right = (f.dir / "right.png").string();
  double seconds = 0;
  for (auto _ : state) {
    const auto start = Clock::now();
    ParallelInOrder<int>(
        kPairs, 4, [&](size_t) { return ReadGreyImage(left).rows + ReadGreyImage(right).rows; },
        [](size_t, int& rows) { benchmark::DoNotOptimize(rows); });
    seconds += std::chrono::duration<double>(Clock::now() - start).count();
  }
  pairs_per_s[0] = kPairs * state.iterations() / seconds;
  state.counters["pairs_per_s"] = pairs_per_s[0];
  state.SetLabel("decode only (floor)");
}
BENCHMARK(BM_DecodeFloor)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_StationFromPngFiles(benchmark::State& state) {
  tbb::global_control two_threads(tbb::global_control::max_allowed_parallelism, 2);
  cv::setNumThreads(1);
  spdlog::set_level(spdlog::level::warn);
  const Files& f = TheFiles();
  double seconds = 0;
  for (auto _ : state) {
    state.PauseTiming();
    fs::remove(f.dir / "results.db");
    auto store = OpenSqliteStore((f.dir / "results.db").string(), true);
    auto source = MakePairsFileSource(f.dir / "pairs.csv");
    StationOptions options;
    options.until_idle_s = 0;
    InspectionStation station({f.recipe}, *source, *store, options);
    LastCommit last;
    station.AddPublisher(&last);
    const std::atomic<bool> stop{false};
    state.ResumeTiming();
    const auto start = Clock::now();
    const StationCounts counts = station.Run(stop);
    seconds += std::chrono::duration<double>(last.last - start).count();
    if (counts.committed != kPairs || counts.not_measured != 0) state.SkipWithError("not every pair was measured");
  }
  pairs_per_s[1] = kPairs * state.iterations() / seconds;
  state.counters["pairs_per_s"] = pairs_per_s[1];
  state.SetLabel("hash + decode + inspect + commit");
}
BENCHMARK(BM_StationFromPngFiles)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace flatscan

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  if (flatscan::pairs_per_s[0] > 0 && flatscan::pairs_per_s[1] > 0)
    std::printf("station from PNG files on 2 threads: %.1f pairs/s (decoding alone: %.1f pairs/s); %.2f of the "
                "floor's rate\n",
                flatscan::pairs_per_s[1], flatscan::pairs_per_s[0], flatscan::pairs_per_s[1] / flatscan::pairs_per_s[0]);
  std::filesystem::remove_all(std::filesystem::temp_directory_path() / "flatscan_station_bench");
  return 0;
}
