// Station throughput from PNG files on 2 threads: `flatscan station`'s pipeline (hash,
// decode, inspect, commit to a real SQLite store with synchronous=FULL, in order) on
// paper-preset pairs (2 x 2592 x 1944), against decoding alone (the floor) on the same
// files in the same run; the ratio is printed at the end. Then the same station with its web
// page (--http) while a client on loopback sends 1,000 requests per second: the bound
// is a slowdown of at most 10 % (the ratio of the two rates, printed at the end), with the
// client at normal priority and at nice 19 (a client elsewhere on the network costs this
// machine nothing; on loopback its CPU is taken from the station's two cores). Then what one
// open page costs: its load (the page, the summary, the trend chart on a fresh connection),
// a poll after a commit (the page polls every second: it shows a part at most 1 s plus this
// after its commit), and the server's CPU per part while the station measures with a page
// polling (the server's threads and Publish, from their CPU clocks).
//   build/station_bench --benchmark_min_time=2
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <thread>

#include <benchmark/benchmark.h>
#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <spdlog/spdlog.h>
#include <tbb/global_control.h>

#include "flatscan/inspection/inspection_report.h"
#include "flatscan/io/image_io.h"
#include "flatscan/outputs/http_server.h"
#include "flatscan/station/inspection_station.h"
#include "flatscan/store/results_store.h"
#include "flatscan/util/ordered_parallel.h"
#include "paper_pair.h"

// Last: <resolv.h>, which it includes, defines _res, a name Eigen uses.
#include <httplib.h>

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

// [0] decoding alone, [1] the station, [2] under HTTP load from a client at nice 0, [3] at nice 19
double pairs_per_s[4] = {0, 0, 0, 0};
double requests_per_s[4] = {0, 0, 0, 0};  // answered during [2] and [3]
double interleaved_ratio[2] = {0, 0};       // BM_LoadRatioInterleaved: client at nice 0, at nice 19

// A client on loopback asking /api/summary at `per_s` (keep-alive) at priority `nice`,
// until destroyed.
class HttpLoad {
 public:
  HttpLoad(int port, double per_s, int nice) : thread_([this, port, per_s, nice] {
    setpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)), nice);
    Run(port, per_s);
  }) {}
  ~HttpLoad() {
    stop_ = true;
    thread_.join();
  }
  int64_t Answered() const { return answered_; }

 private:
  void Run(int port, double per_s) {
    httplib::Client client("127.0.0.1", port);
    client.set_keep_alive(true);
    client.set_tcp_nodelay(true);
    const auto step = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / per_s));
    for (auto next = Clock::now(); !stop_; next += step) {
      if (const auto res = client.Get("/api/summary"); res && (res->status == 200 || res->status == 429)) ++answered_;
      std::this_thread::sleep_until(next);
    }
  }
  std::atomic<bool> stop_{false};
  std::atomic<int64_t> answered_{0};
  std::thread thread_;
};

// One station run over the pairs file, timed from its start to its last commit; `extra`
// also gets every record (nullptr: none). With a web server (`extra`), each part also gets
// its thumbnail, as `flatscan station --http` makes them.
double TimedStationRun(benchmark::State& state, RecordPublisher* extra) {
  const Files& f = TheFiles();
  fs::remove(f.dir / "results.db");
  auto store = OpenSqliteStore((f.dir / "results.db").string(), true);
  auto source = MakePairsFileSource(f.dir / "pairs.csv");
  StationOptions options;
  options.until_idle_s = 0;
  if (extra) options.thumbnail_width = 480;
  InspectionStation station({f.recipe}, *source, *store, options);
  LastCommit last;
  station.AddPublisher(&last);
  if (extra) station.AddPublisher(extra);
  const std::atomic<bool> stop{false};
  const auto start = Clock::now();
  const StationCounts counts = station.Run(stop);
  if (counts.committed != kPairs || counts.not_measured != 0) state.SkipWithError("not every pair was measured");
  return std::chrono::duration<double>(last.last - start).count();
}

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
  double seconds = 0;
  for (auto _ : state) seconds += TimedStationRun(state, nullptr);
  pairs_per_s[1] = kPairs * state.iterations() / seconds;
  state.counters["pairs_per_s"] = pairs_per_s[1];
  state.SetLabel("hash + decode + inspect + commit");
}
BENCHMARK(BM_StationFromPngFiles)->Unit(benchmark::kMillisecond)->UseRealTime();

LiveSummary BenchSummary() { return LiveSummary("bench", ShiftCalendar::Parse("06:00", "--shifts"), SystemTime()); }

// state.range(0): the load client's nice value.
void BM_StationWithItsPageUnder1000RequestsPerSecond(benchmark::State& state) {
  tbb::global_control two_threads(tbb::global_control::max_allowed_parallelism, 2);
  cv::setNumThreads(1);
  spdlog::set_level(spdlog::level::warn);
  const int nice = int(state.range(0)), slot = nice == 0 ? 2 : 3;
  double seconds = 0;
  int64_t answered = 0;
  for (auto _ : state) {
    StationHttpServer server({}, BenchSummary(), {});
    HttpLoad load(server.Port(), 1000, nice);
    seconds += TimedStationRun(state, &server);
    answered += load.Answered();
  }
  pairs_per_s[slot] = kPairs * state.iterations() / seconds;
  requests_per_s[slot] = answered / seconds;
  state.counters["pairs_per_s"] = pairs_per_s[slot];
  state.counters["requests_per_s"] = requests_per_s[slot];
  state.SetLabel(fmt::format("the station while its page gets 1,000 requests/s from a client at nice {}", nice));
}
BENCHMARK(BM_StationWithItsPageUnder1000RequestsPerSecond)->Arg(0)->Arg(19)->Unit(benchmark::kMillisecond)->UseRealTime();

// The same three runs interleaved (alone, under load from a client at nice 0, at nice 19)
// and repeated: a drift of the machine's speed over the benchmark (this VM's rate alone
// varies by 10 % from one minute to the next) falls on the three alike. The ratios are of
// the summed times.
void BM_LoadRatioInterleaved(benchmark::State& state) {
  tbb::global_control two_threads(tbb::global_control::max_allowed_parallelism, 2);
  cv::setNumThreads(1);
  spdlog::set_level(spdlog::level::warn);
  double alone = 0, nice0 = 0, nice19 = 0, server_cpu0 = 0;
  for (auto _ : state) {
    alone += TimedStationRun(state, nullptr);
    for (const int nice : {0, 19}) {
      StationHttpServer server({}, BenchSummary(), {});
      HttpLoad load(server.Port(), 1000, nice);
      const double seconds = TimedStationRun(state, &server);
      (nice == 0 ? nice0 : nice19) += seconds;
      if (nice == 0) server_cpu0 += server.Cpu().serving_s;  // to the end of the load, a little past the run
    }
  }
  state.counters["ratio_nice0"] = alone / nice0;
  state.counters["ratio_nice19"] = alone / nice19;
  // The server's threads' share of the two cores while answering the load (nice 0 runs).
  state.counters["server_share_of_2_cores"] = server_cpu0 / (2 * nice0);
  interleaved_ratio[0] = alone / nice0;
  interleaved_ratio[1] = alone / nice19;
  state.SetLabel("rate under 1,000 requests/s over the rate alone, runs interleaved");
}
BENCHMARK(BM_LoadRatioInterleaved)->Unit(benchmark::kMillisecond)->UseRealTime();

// Records as the station commits them: one station run's, renumbered to `count`.
std::vector<StationRecord> SomeRecords(benchmark::State& state, size_t count) {
  class Keep : public RecordPublisher {
   public:
    void Publish(const StationRecord& r, const StationCounts&) override { records.push_back(r); }
    std::vector<StationRecord> records;
  } keep;
  spdlog::set_level(spdlog::level::warn);
  TimedStationRun(state, &keep);
  std::vector<StationRecord> out;
  for (size_t i = 0; i < count && !keep.records.empty(); ++i) {
    out.push_back(keep.records[i % keep.records.size()]);
    out.back().sequence = int64_t(i + 1);
  }
  return out;
}

// Loading the page as a browser does on a fresh connection: the page, the summary, the
// trend chart (of 300 parts).
// A part's thumbnail (crop, scale to 480, colour the rim, JPEG) from a paper-preset pair
// measured once: the CPU `--http` or `--archive` adds to each part's measuring.
void BM_Thumbnail(benchmark::State& state) {
  cv::setNumThreads(1);
  const PaperPair pair = RenderPaperPair();
  const LoadedRecipe& r = pair.recipe;
  const InspectionResult result = InspectPart(r.rig, r.plane, pair.left, pair.right, r.recipe.params);
  size_t bytes = 0;
  const int width = int(state.range(0));
  for (auto _ : state) bytes = EncodeJpeg(DrawRimThumbnail(pair.left, &result, r.recipe.spec, width)).size();
  state.counters["jpeg_kB"] = double(bytes) / 1024;
  state.SetLabel("DrawRimThumbnail + EncodeJpeg, one thread");
}
BENCHMARK(BM_Thumbnail)->Arg(480)->Arg(360)->Unit(benchmark::kMillisecond);

void BM_ThumbnailDrawingOnly(benchmark::State& state) {
  cv::setNumThreads(1);
  const PaperPair pair = RenderPaperPair();
  const LoadedRecipe& r = pair.recipe;
  const InspectionResult result = InspectPart(r.rig, r.plane, pair.left, pair.right, r.recipe.params);
  for (auto _ : state) benchmark::DoNotOptimize(DrawRimThumbnail(pair.left, &result, r.recipe.spec, 480).data);
}
BENCHMARK(BM_ThumbnailDrawingOnly)->Unit(benchmark::kMillisecond);

// The server without its rate limit: these measure a request, not the limiter.
HttpServerOptions Unlimited() {
  HttpServerOptions o;
  o.max_requests_per_s = 1e9;
  return o;
}

void BM_PageLoad(benchmark::State& state) {
  StationHttpServer server(Unlimited(), BenchSummary(), {});
  for (const StationRecord& r : SomeRecords(state, 300)) server.Publish(r, {});
  for (auto _ : state) {
    httplib::Client client("127.0.0.1", server.Port());
    for (const char* path : {"/", "/api/summary", "/api/trend.svg", "/api/moving-range.svg"}) {
      const auto res = client.Get(path);
      if (!res || res->status != 200)
        state.SkipWithError(fmt::format("GET {} failed: {}", path, res ? std::to_string(res->status) + " " + res->body
                                                                          : httplib::to_string(res.error()))
                                .c_str());
    }
  }
  state.SetLabel("GET /, /api/summary and the two charts on a new connection (300 parts in the trend)");
}
BENCHMARK(BM_PageLoad)->Unit(benchmark::kMillisecond)->UseRealTime();

// A commit, then the page's next poll (keep-alive, as the browser's): the poll's own time.
void BM_PollAfterACommit(benchmark::State& state) {
  StationHttpServer server(Unlimited(), BenchSummary(), {});
  std::vector<StationRecord> records = SomeRecords(state, 300);
  for (const StationRecord& r : records) server.Publish(r, {});
  httplib::Client client("127.0.0.1", server.Port());
  client.set_keep_alive(true);
  StationRecord next = records.back();
  for (auto _ : state) {
    ++next.sequence;
    server.Publish(next, {});
    const auto res = client.Get("/api/summary");
    if (!res || res->body.find(fmt::format("\"sequence\":{}", next.sequence)) == std::string::npos)
      state.SkipWithError("the poll did not show the commit");
  }
  state.SetLabel("Publish + GET /api/summary; the page shows a part within 1 s (its poll period) + this");
}
BENCHMARK(BM_PollAfterACommit)->Unit(benchmark::kMillisecond)->UseRealTime();

// The page as a browser runs it: /api/summary every second, the two charts and the part's
// image when a new part is in it, until destroyed.
class OpenPage {
 public:
  explicit OpenPage(int port) : thread_([this, port] { Run(port); }) {}
  ~OpenPage() {
    stop_ = true;
    thread_.join();
  }

 private:
  void Run(int port) {
    httplib::Client client("127.0.0.1", port);
    client.set_keep_alive(true);
    std::string last;
    while (!stop_) {
      const auto res = client.Get("/api/summary");
      if (res && res->body != last) {
        for (const char* chart : {"/api/trend.svg", "/api/moving-range.svg"}) client.Get(chart);
        const auto summary = nlohmann::json::parse(res->body, nullptr, false);
        if (summary.is_object() && summary["last"].is_object())
          client.Get(fmt::format("/api/parts/{}/image.jpg", summary["last"]["sequence"].get<int64_t>()));
      }
      if (res) last = res->body;
      for (int i = 0; i < 100 && !stop_; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  }
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

void BM_ServerCpuPerPartWithOnePageOpen(benchmark::State& state) {
  tbb::global_control two_threads(tbb::global_control::max_allowed_parallelism, 2);
  cv::setNumThreads(1);
  spdlog::set_level(spdlog::level::warn);
  double cpu_s = 0, publishing_s = 0;
  for (auto _ : state) {
    StationHttpServer server({}, BenchSummary(), {});
    {
      OpenPage page(server.Port());
      TimedStationRun(state, &server);
    }
    const StationHttpServer::CpuUsed used = server.Cpu();
    cpu_s += used.serving_s + used.publishing_s;
    publishing_s += used.publishing_s;
  }
  const double parts = double(kPairs) * double(state.iterations());
  state.counters["server_cpu_us_per_part"] = 1e6 * cpu_s / parts;
  state.counters["publish_cpu_us_per_part"] = 1e6 * publishing_s / parts;
  state.SetLabel("the server's threads and Publish, per part, one page polling every second");
}
BENCHMARK(BM_ServerCpuPerPartWithOnePageOpen)->Unit(benchmark::kMillisecond)->UseRealTime();

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
  for (const int slot : {2, 3})
    if (flatscan::pairs_per_s[1] > 0 && flatscan::pairs_per_s[slot] > 0)
      std::printf("with its web page answering %.0f requests/s from a client at nice %d: %.1f pairs/s, %.3f of the "
                  "rate without\n",
                  flatscan::requests_per_s[slot], slot == 2 ? 0 : 19, flatscan::pairs_per_s[slot],
                  flatscan::pairs_per_s[slot] / flatscan::pairs_per_s[1]);
  if (flatscan::interleaved_ratio[0] > 0)
    std::printf("interleaved runs: under load %.3f of the rate alone (client at nice 0), %.3f (client at nice 19)\n",
                flatscan::interleaved_ratio[0], flatscan::interleaved_ratio[1]);
  std::filesystem::remove_all(std::filesystem::temp_directory_path() / "flatscan_station_bench");
  return 0;
}
