#pragma once
// Forwards a station's committed records to the plant store (PostgreSQL,
// store/postgres_results_store.h), catching up after an outage without duplicates.
//
// The station's own SQLite store is the outbox: the forwarder keeps no records in
// memory. On its own thread it asks the plant store for the last sequence it holds of
// this station, reads the records after it from the local store (a read-only
// connection of its own, in batches of at most 200) and appends each batch in one
// transaction, idempotent on station id + sequence. A committed record wakes it. When
// the plant database is unreachable it tries again after 1, 2, 4, then every 5 s, and
// a station that stops with records not yet forwarded forwards them when it starts
// again: the plant table ends with every record once. Memory does not grow with an
// outage, however long. A station whose local store was replaced (its history no longer
// the one the plant holds) is refused, with a message, until it gets a new station id.
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "flatscan/station/inspection_station.h"
#include "flatscan/store/results_store.h"

namespace flatscan {

class PostgresResultsStore;

struct PlantForwarderOptions {
  std::string conninfo;     // libpq connection string (postgres_results_store.h)
  std::string station_id;
  std::string local_store;  // the station's SQLite store (the outbox)
  int64_t batch = 200;      // records per transaction
  std::chrono::milliseconds drain_at_stop{5000};  // a stopping station waits this long for the plant
};

class PlantForwarder : public RecordPublisher {
 public:
  // Opens the local store for reading (throws StoreError naming it when it cannot) and
  // starts forwarding in the background; does not wait for the plant database.
  explicit PlantForwarder(PlantForwarderOptions options);
  // Waits (at most drain_at_stop each) for the first connection attempt and, when the
  // plant store is connected, until everything committed is forwarded; then stops.
  ~PlantForwarder() override;
  PlantForwarder(const PlantForwarder&) = delete;
  PlantForwarder& operator=(const PlantForwarder&) = delete;

  void Publish(const StationRecord& record, const StationCounts& counts) override;

  // Waits at most `timeout` until the plant store holds every record committed so far;
  // whether it does.
  bool Drain(std::chrono::milliseconds timeout);
  // The last sequence the plant store is known to hold (0 before the first connection).
  int64_t ForwardedThrough() const { return forwarded_; }

 private:
  void Loop();
  void MarkTried();
  void CheckSameHistory(PostgresResultsStore& plant, int64_t held);
  bool ForwardBatch(PostgresResultsStore& plant);
  void WaitBeforeRetry(std::chrono::seconds& backoff);

  PlantForwarderOptions options_;
  std::string name_;                        // the database, without secrets
  std::unique_ptr<ResultsStore> local_;
  std::atomic<int64_t> committed_{0};       // the newest sequence committed locally
  std::atomic<int64_t> forwarded_{0};
  std::atomic<bool> connected_{false};
  std::atomic<bool> stop_{false};
  bool woken_ = false;                      // a record was committed since the thread last looked (mutex_)
  bool tried_ = false;                      // the first connection was tried (mutex_)
  std::mutex mutex_;
  std::condition_variable wake_, forwarded_changed_;
  std::thread thread_;
};

}  // namespace flatscan
