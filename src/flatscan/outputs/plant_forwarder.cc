#include "flatscan/outputs/plant_forwarder.h"

#include <algorithm>
#include <vector>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "flatscan/store/postgres_results_store.h"

namespace flatscan {

PlantForwarder::PlantForwarder(PlantForwarderOptions options)
    : options_(std::move(options)), name_(DescribePostgres(options_.conninfo)) {
  local_ = OpenSqliteStore(options_.local_store, false);
  committed_ = local_->LastSequence();
  thread_ = std::thread([this] { Loop(); });
}

PlantForwarder::~PlantForwarder() {
  {  // a station stopping right after it started: let the first connection be tried
    std::unique_lock lock(mutex_);
    forwarded_changed_.wait_for(lock, options_.drain_at_stop, [&] { return tried_; });
  }
  if (connected_ && !Drain(options_.drain_at_stop))
    spdlog::warn("plant store {}: stopping with records up to #{} not yet forwarded: they are forwarded when the "
                 "station starts again",
                 name_, committed_.load());
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

void PlantForwarder::Publish(const StationRecord& record, const StationCounts&) {
  {
    std::lock_guard lock(mutex_);
    committed_ = std::max(committed_.load(), record.sequence);
    woken_ = true;
  }
  wake_.notify_all();
}

bool PlantForwarder::Drain(std::chrono::milliseconds timeout) {
  std::unique_lock lock(mutex_);
  const int64_t target = committed_;
  return forwarded_changed_.wait_for(lock, timeout, [&] { return forwarded_ >= target; });
}

void PlantForwarder::Loop() {
  std::unique_ptr<PostgresResultsStore> plant;
  std::chrono::seconds backoff{1};
  bool problem_reported = false;
  while (!stop_) {
    try {
      if (!plant) {
        plant = std::make_unique<PostgresResultsStore>(options_.conninfo, options_.station_id, true);
        const int64_t held = plant->LastSequence();
        CheckSameHistory(*plant, held);
        forwarded_ = held;
        connected_ = true;
        MarkTried();
        spdlog::info("plant store {}: connected; it holds this station's records through #{}", name_, held);
      }
      const bool more = ForwardBatch(*plant);
      backoff = std::chrono::seconds(1);  // a batch went through, or there was none to send
      if (problem_reported) spdlog::info("plant store {}: forwarding again", name_);
      problem_reported = false;
      if (more) continue;
      std::unique_lock lock(mutex_);  // all forwarded: sleep until a record is committed
      wake_.wait_for(lock, std::chrono::seconds(1), [&] { return stop_ || woken_; });
      woken_ = false;
    } catch (const std::exception& e) {  // whatever it was, the records are safe in the local store
      if (!problem_reported)
        spdlog::warn("{}; records are kept in the station's store and forwarded once this is resolved", e.what());
      problem_reported = true;
      MarkTried();
      // A connection that is still up and checked is kept (the server refused a statement:
      // a read-only standby, a full disk, a permission); it is tried again after the same
      // waits. One whose history was refused is made again (and checked again).
      if (plant && (!connected_ || !plant->Connected())) plant.reset();
      connected_ = plant != nullptr;
      WaitBeforeRetry(backoff);
    }
  }
}

// The plant's newest record of this station must be the local record of that sequence:
// otherwise the local store was replaced (deleted and started again at #1), and records
// after `held` would be taken for the old ones' successors while the new #1..#held were
// never forwarded.
void PlantForwarder::CheckSameHistory(PostgresResultsStore& plant, int64_t held) {
  if (held == 0) return;
  std::string plant_id, local_id;
  plant.ForEachAfter(held - 1, 1, [&](const StationRecord& r) { plant_id = r.record_id; });
  local_->ForEachAfter(held - 1, 1, [&](const StationRecord& r) { local_id = r.record_id; });
  if (plant_id == local_id) return;
  throw StoreError(fmt::format(
      "plant store {}: holds station '{}' #{} as record {}, but the station's store {} has {}: was the station's "
      "local store replaced? Give the station a new --station-id",
      name_, options_.station_id, held, plant_id, options_.local_store,
      local_id.empty() ? "no record of that sequence" : "record " + local_id));
}

void PlantForwarder::MarkTried() {
  {
    std::lock_guard lock(mutex_);
    tried_ = true;
  }
  forwarded_changed_.notify_all();
}

// The next batch after what the plant holds, from the local store, in one transaction;
// whether there was one.
bool PlantForwarder::ForwardBatch(PostgresResultsStore& plant) {
  std::vector<StationRecord> batch;
  local_->ForEachAfter(forwarded_, options_.batch, [&](const StationRecord& r) { batch.push_back(r); });
  if (batch.empty()) return false;
  plant.Append(batch);
  {
    std::lock_guard lock(mutex_);
    forwarded_ = batch.back().sequence;
  }
  forwarded_changed_.notify_all();
  return true;
}

void PlantForwarder::WaitBeforeRetry(std::chrono::seconds& backoff) {
  std::unique_lock lock(mutex_);
  wake_.wait_for(lock, backoff, [&] { return bool(stop_); });
  backoff = std::min(backoff * 2, std::chrono::seconds(5));
}

}  // namespace flatscan
