#pragma once
// The station's web page (`flatscan station --http ADDR:PORT`): a publisher that keeps the
// figures a page shows (live_summary.h) and serves them over HTTP (cpp-httplib, Debian
// libcpp-httplib-dev). Everything the page needs is served here: no CDN, no internet.
//
//   GET  /                 the page; it polls /api/summary every second
//   GET  /api/summary      {"station_id", "state": "ready"|"not_ready", "not_ready_reason",
//                          "started_utc", "counts": {"measured", "pass", "fail", "marginal",
//                          "not_measured"} over the whole store (so that they match it after
//                          a restart), "yield" (pass / measured over the store, null before
//                          the first), "since_start" and "shift": {"name", "start_utc",
//                          "counts"} (counts with their "yield"), "rate_per_min", "last" (the
//                          last record, the record schema of docs/station.md, or null),
//                          "trend": {"flatness_mm": [the last 300], "tolerance_mm"},
//                          "recent_problems": [the last 10 fails and not-measured parts,
//                          latest first], "health": what the station reports (cameras,
//                          store, outputs, calibration files, active recipe)}
//   GET  /api/trend.svg    the trend as an individuals control chart (SVG)
//   GET  /api/moving-range.svg  its moving-range chart (the MR of the I-MR pair)
//   GET  /api/parts/N/image.jpg  the part's thumbnail (inspection_report.h, DrawRimThumbnail),
//                          kept for the last part and the last 10 fails and not-measured
//                          parts (404 otherwise)
//   GET  /api/parts/N      the record with sequence N (404 when the store has none; 400
//                          when N is not a sequence number)
//   GET  /api/parts?from=T&to=T&limit=N   the records committed in [from, to) (ISO 8601
//                          UTC), the first N (at most 1000, default 100) by sequence (400 on
//                          a malformed query)
//   POST /api/recipe       {"recipe": NAME} with "Authorization: Bearer TOKEN": makes NAME
//                          the active recipe (403 without the token or when the station was
//                          started without one: read-only; 404 for an unknown recipe)
//   anything else          404 with a one-line reason
//
// Requests beyond max_requests_per_s (a token bucket over all clients) get 429 at once, and
// the server's two worker threads run at a lower CPU priority (nice 10) than measuring: a
// page left open, or a misbehaving client on the network, cannot slow the line.
#include <atomic>
#include <chrono>
#include <ctime>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "flatscan/outputs/live_summary.h"
#include "flatscan/station/inspection_station.h"
#include "flatscan/store/results_store.h"

namespace httplib {
class Server;
}

namespace flatscan {

struct HttpServerOptions {
  std::string address = "127.0.0.1";
  int port = 0;                       // 0: a free one (StationHttpServer::Port())
  std::string token;                  // empty: read-only
  double max_requests_per_s = 200;    // the bucket's rate and (one second of) burst
};

// What the server asks of the station. Each may be empty (the feature is then absent).
// Called from the server's threads: each must be thread-safe.
struct StationHooks {
  // The record with this sequence number, if the store has it (the store's own reader).
  std::function<std::optional<StationRecord>(int64_t sequence)> record;
  // The records in a time range, the first `limit` by sequence.
  std::function<std::vector<StationRecord>(const TimeRange& range, size_t limit)> records;
  std::function<std::vector<std::string>()> recipe_names;
  std::function<void(size_t index)> set_active_recipe;
  std::function<nlohmann::json()> health;
};

// Sets hooks.record and hooks.records to read `reader` (a store opened for reading, one
// request at a time).
void ReadRecordsFrom(std::unique_ptr<ResultsStore> reader, StationHooks& hooks);

class StationHttpServer : public RecordPublisher {
 public:
  // Listens from construction until destruction. Throws InputError naming address:port
  // when it cannot listen there.
  StationHttpServer(const HttpServerOptions& options, LiveSummary summary, StationHooks hooks);
  ~StationHttpServer() override;

  int Port() const { return port_; }
  nlohmann::json Summary();
  // Summary() as the text /api/summary answers: made again after a Publish or Readiness,
  // otherwise at most every kSummaryMaxAge (the rate, the shift and the health change with
  // time), so that many pages, or a flood of requests, cost one JSON build per period.
  std::string SummaryText();
  static constexpr std::chrono::milliseconds kSummaryMaxAge{250};

  void Publish(const StationRecord& record, const StationCounts& counts) override;
  void PublishImage(const StationRecord& record, const std::string& jpeg) override;
  void Readiness(bool ready, const std::string& reason, const StationCounts& counts) override;
  static constexpr size_t kProblemImages = 10;

  // The CPU time the server has cost the station: its threads' (listening, reading and
  // answering requests, refusing them) and Publish's (keeping the page's figures, on the
  // station's commit thread). For the benchmark of the CPU per part with a page open.
  struct CpuUsed {
    double serving_s = 0, publishing_s = 0;
  };
  CpuUsed Cpu();

 private:
  void Route();
  // Called first on each request: lowers the worker thread's priority and counts its CPU.
  void JoinWorker();
  bool TakeToken();

  std::unique_ptr<httplib::Server> server_;
  std::thread thread_;
  int port_ = 0;
  HttpServerOptions options_;
  StationHooks hooks_;
  std::mutex mutex_;  // guards summary_ and the images
  LiveSummary summary_;
  std::map<int64_t, std::string> images_;  // JPEG by sequence: the last part's and the problems'
  std::deque<int64_t> problem_images_;     // the last kProblemImages fails and not-measured parts
  int64_t last_image_ = 0;
  std::mutex bucket_mutex_;  // apart: a flood of refused requests does not hold up Publish()
  double bucket_ = 0;
  std::chrono::steady_clock::time_point bucket_time_;
  std::atomic<uint64_t> version_{0};  // counts Publish and Readiness calls
  std::mutex cache_mutex_;           // guards the three below
  std::string summary_text_;
  uint64_t summary_version_ = 0;
  std::chrono::steady_clock::time_point summary_time_;
  std::mutex cpu_mutex_;  // guards the two below
  std::vector<clockid_t> thread_clocks_;  // the listening thread's and every worker's
  double publishing_s_ = 0;
};

}  // namespace flatscan
