#pragma once
// The station's web page (`flatscan station --http ADDR:PORT`): a publisher that keeps the
// figures a page shows and serves them over HTTP (cpp-httplib, Debian libcpp-httplib-dev),
// read-only:
//
//   GET /              one page that polls /api/summary every second: the last part's
//                      verdict in large type, its flatness against the tolerance, the counters
//   GET /api/summary   {"station_id", "state": "ready"|"not_ready", "counts": {"measured",
//                      "pass", "fail", "marginal", "not_measured"}, "last": the last record
//                      (the record schema, docs/station.md) or null}
//   anything else      404 with a one-line reason
//
// The counts are over the whole store (taken from it at start, then counted as records are
// committed), so that they match the store after a restart. Everything the page needs is
// served by the station: no CDN (a factory floor has no internet).
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "flatscan/station/inspection_station.h"

namespace httplib {
class Server;
}

namespace flatscan {

// The counters of /api/summary.
struct SummaryCounts {
  int64_t measured = 0, pass = 0, fail = 0, marginal = 0, not_measured = 0;
  void Add(const StationRecord& record);
};

class StationHttpServer : public RecordPublisher {
 public:
  // Listens on address:port (port 0: a free one, see Port()) from construction until
  // destruction. `counts` and `last`: the store's so far. Throws InputError naming
  // address:port when it cannot listen there.
  StationHttpServer(const std::string& address, int port, std::string station_id, SummaryCounts counts,
                    std::optional<StationRecord> last);
  ~StationHttpServer() override;

  int Port() const { return port_; }
  nlohmann::json Summary() const;

  void Publish(const StationRecord& record, const StationCounts& counts) override;
  void Readiness(bool ready, const std::string& reason, const StationCounts& counts) override;

 private:
  std::unique_ptr<httplib::Server> server_;
  std::thread thread_;
  int port_ = 0;
  std::string station_id_;
  mutable std::mutex mutex_;
  SummaryCounts counts_;
  std::optional<StationRecord> last_;
  bool ready_ = true;
};

}  // namespace flatscan
