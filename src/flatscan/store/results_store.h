#pragma once
// Where a station's records go: an interface, so that the embedded store (SQLite, a
// file beside the station) and the plant-wide one (PostgreSQL, postgres_results_store.h)
// are interchangeable.
//
// Contract for every implementation:
// - Commit() is durable when it returns: the record survives a power cut or kill -9
//   from then on (a record is committed before its verdict is published anywhere).
// - Sequence numbers are 1, 2, ... per store, with no gaps, in commit order; the
//   time_utc a record gets at commit never decreases along them (a clock stepped back
//   is held at the last stored time).
// - A record is never changed or deleted by the station.
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>

#include "flatscan/store/station_record.h"

namespace flatscan {

// The store cannot be written or read (a full disk, a read-only file, a corrupt or newer
// store). what() names the store and says what failed.
class StoreError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Records with from <= time_utc < to; an empty bound is open.
struct TimeRange {
  std::string from, to;  // in the stored form (ParseUtcTime)
};

class ResultsStore {
 public:
  virtual ~ResultsStore() = default;
  // Assigns record.sequence and record.time_utc, then commits it durably; true. False,
  // and nothing committed, when the store already holds a record of this pair (the same
  // source id and image hashes: checked in the same transaction). Throws StoreError
  // (nothing committed) when it cannot.
  virtual bool Commit(StationRecord& record) = 0;
  // The last committed sequence number; 0 for an empty store.
  virtual int64_t LastSequence() = 0;
  // Whether a record of this pair (the same source id and the same image bytes) exists.
  virtual bool Contains(const std::string& source_id, const std::string& left_sha256,
                        const std::string& right_sha256) = 0;
  // Calls `visit` with each record in the range, by sequence.
  virtual void ForEach(const TimeRange& range, const std::function<void(const StationRecord&)>& visit) = 0;
  // Calls `visit` with the records whose sequence is above `after`, by sequence, at most
  // `limit` of them: an outbox read in bounded batches (the MQTT and plant outputs).
  virtual void ForEachAfter(int64_t after, int64_t limit, const std::function<void(const StationRecord&)>& visit) = 0;
};

// The embedded store: an SQLite file (WAL journal, synchronous=FULL: each Commit is one
// transaction, on disk when it returns). `create` (a station): open for writing,
// creating the file when missing and migrating an older schema, and hold an exclusive
// lock on "<path>.lock" while open, so that a second station on the same store is
// refused; otherwise (`flatscan results`) open an existing store read-only. Throws
// StoreError naming the file when it cannot be opened, is not a flatscan store, was
// written by a newer flatscan (its schema version is higher than this one knows), or is
// in use by another station.
std::unique_ptr<ResultsStore> OpenSqliteStore(const std::string& path, bool create);

// The schema version this flatscan writes (docs/station.md, "Results store").
constexpr int kSqliteStoreSchemaVersion = 1;

}  // namespace flatscan
