#pragma once
// The plant store: every station's records in one PostgreSQL table, `flatscan_records`
// (docs/line-outputs.md, "Plant store"), with the columns of the SQLite store plus the
// whole record as jsonb. A row is keyed by (station_id, sequence): the sequence is the
// one the station's own store gave the record, so a plant table holds each station's
// numbering unchanged and a record forwarded twice is stored once.
//
// Two ways in, one table:
// - Append(): a record already numbered by a station's SQLite store (what the station's
//   forwarder does, outputs/plant_forwarder.h). Idempotent on station_id + sequence.
// - Commit() (ResultsStore): a station writing straight to the plant store; numbers the
//   record 1, 2, ... per station. The station itself always writes its SQLite store
//   first (a line must not stop when the plant network does) and forwards.
//
// Connection strings are libpq's (https://www.postgresql.org/docs/15/libpq-connect.html):
// "postgresql://user@host:port/dbname?sslmode=verify-full&sslrootcert=ca.pem". A password
// belongs in ~/.pgpass or PGPASSFILE, not in the string (a command line is visible to
// every user of the machine); a password in the string is used but never logged: the
// store describes itself as postgresql://user@host:port/dbname.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "flatscan/store/results_store.h"

namespace flatscan {

// Whether `spec` is a PostgreSQL connection URI ("postgresql://..." or "postgres://...").
bool IsPostgresUri(const std::string& spec);

// `conninfo` without secrets, for logs and messages: "postgresql://user@host:port/dbname".
// Throws InputError when libpq cannot parse it.
std::string DescribePostgres(const std::string& conninfo);

class PostgresResultsStore : public ResultsStore {
 public:
  // Connects (libpq's connect_timeout defaults to 5 s here) and, when `create`, creates
  // or migrates the plant table (several stations starting at once serialise on an
  // advisory lock). `station_id` scopes Commit, LastSequence, Contains and ForEachAfter
  // to one station; empty: a reader of every station (Commit refused). Throws StoreError
  // naming the database (without the password) when it cannot connect, the table is
  // not a flatscan plant table, or it was written by a newer flatscan.
  PostgresResultsStore(const std::string& conninfo, const std::string& station_id, bool create);
  ~PostgresResultsStore() override;
  PostgresResultsStore(const PostgresResultsStore&) = delete;
  PostgresResultsStore& operator=(const PostgresResultsStore&) = delete;

  bool Commit(StationRecord& record) override;
  int64_t LastSequence() override;
  bool Contains(const std::string& source_id, const std::string& left_sha256,
                const std::string& right_sha256) override;
  // Every station's records in the range, by time, then station, then sequence.
  void ForEach(const TimeRange& range, const std::function<void(const StationRecord&)>& visit) override;
  void ForEachAfter(int64_t after, int64_t limit, const std::function<void(const StationRecord&)>& visit) override;

  // Stores records numbered by a station's own store, keeping their sequence and time,
  // in one transaction: the number newly stored (a record already there is skipped).
  // Throws StoreError (nothing stored) when the table holds the same station and
  // sequence with another record_id: a station whose local store was replaced must get
  // a new station id, or its new records would silently be taken for the old ones.
  size_t Append(const std::vector<StationRecord>& records);

  // Whether the connection is still up (false after the server went away).
  bool Connected() const;

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

// The plant table's schema version (docs/line-outputs.md).
constexpr int kPlantStoreSchemaVersion = 1;

}  // namespace flatscan
