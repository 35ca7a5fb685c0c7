// The plant store in PostgreSQL, through libpq (the C client library every PostgreSQL
// tool uses; Debian's libpq-dev). Queries are parameterised ($1, $2, ...: no value is
// ever spliced into SQL text) and every write is one transaction.
#include "flatscan/store/postgres_results_store.h"

#include <libpq-fe.h>

#include <optional>
#include <vector>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "flatscan/util/error.h"

namespace flatscan {
namespace {

// kMigrations[v] takes the plant table from version v to v + 1. The columns are the
// SQLite store's (sqlite_results_store.cc) in PostgreSQL's types; record_json holds
// the whole record, so nothing is lost to the columns.
const std::vector<const char*> kMigrations = {
    R"(CREATE TABLE flatscan_schema (version integer NOT NULL);
       INSERT INTO flatscan_schema VALUES (0);
       CREATE TABLE flatscan_records (
         station_id     text NOT NULL,
         sequence       bigint NOT NULL,
         record_id      text NOT NULL UNIQUE,
         time_utc       timestamptz NOT NULL,
         source_id      text NOT NULL,
         recipe         text NOT NULL,
         recipe_sha256  text NOT NULL,
         left_sha256    text NOT NULL,
         right_sha256   text NOT NULL,
         measured       boolean NOT NULL,
         verdict        text,
         marginal       boolean NOT NULL,
         flatness_mm    double precision,
         lsq_pv_mm      double precision,
         minzone_mm     double precision,
         coverage       double precision,
         uncertainty_mm double precision,
         error          text,
         record_json    jsonb NOT NULL,
         stored_utc     timestamptz NOT NULL DEFAULT now(),
         PRIMARY KEY (station_id, sequence));
       CREATE INDEX flatscan_records_by_time ON flatscan_records (time_utc);
       CREATE INDEX flatscan_records_by_pair ON flatscan_records (station_id, source_id, left_sha256, right_sha256);)",
};
static_assert(kPlantStoreSchemaVersion == 1, "add the migration to the new version to kMigrations");

// Any fixed number: the key of the advisory lock under which stations create or migrate
// the plant table, one at a time.
constexpr const char* kSchemaLockKey = "7315001";

using Param = std::optional<std::string>;  // nullopt: SQL NULL

// libpq's message on one line (it spreads some over several, indented with tabs).
std::string Trimmed(const char* message) {
  std::string s;
  for (const char* c = message ? message : ""; *c; ++c) {
    if (*c == '\n' || *c == '\t') {
      if (!s.empty() && s.back() != ' ') s.push_back(' ');
    } else {
      s.push_back(*c);
    }
  }
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

// A query's result, cleared when it goes out of scope.
class Result {
 public:
  explicit Result(PGresult* result) : result_(result) {}
  ~Result() { PQclear(result_); }
  Result(Result&& other) noexcept : result_(other.result_) { other.result_ = nullptr; }
  Result(const Result&) = delete;
  Result& operator=(const Result&) = delete;
  int Rows() const { return PQntuples(result_); }
  std::string Text(int row, int column) const { return PQgetvalue(result_, row, column); }
  int64_t Int(int row, int column) const { return std::stoll(Text(row, column)); }
  PGresult* get() const { return result_; }

 private:
  PGresult* result_;
};

void LogNotice(void*, const char* message) { spdlog::debug("plant store: {}", Trimmed(message)); }

std::string Number(double v) { return fmt::format("{}", v); }

}  // namespace

bool IsPostgresUri(const std::string& spec) {
  return spec.rfind("postgresql://", 0) == 0 || spec.rfind("postgres://", 0) == 0;
}

std::string DescribePostgres(const std::string& conninfo) {
  char* error = nullptr;
  PQconninfoOption* options = PQconninfoParse(conninfo.c_str(), &error);
  if (!options) {
    PQfreemem(error);
    // libpq's reason is not repeated: it quotes the token it cannot read, which may be
    // the password ('invalid percent-encoded token: "<password>"').
    ThrowInputError("expected a PostgreSQL connection URI (postgresql://user@host:port/dbname) that libpq can "
                    "parse (an unknown parameter, or a % not followed by two hex digits?)");
  }
  std::string user, host, port, dbname;
  for (const PQconninfoOption* o = options; o->keyword; ++o) {
    const std::string key = o->keyword, value = o->val ? o->val : "";
    if (key == "user") user = value;
    if (key == "host" || (key == "hostaddr" && host.empty())) host = value;
    if (key == "port") port = value;
    if (key == "dbname") dbname = value;
  }
  PQconninfoFree(options);
  return fmt::format("postgresql://{}{}{}/{}", user.empty() ? "" : user + "@", host, port.empty() ? "" : ":" + port,
                     dbname);
}

class PostgresResultsStore::Impl {
 public:
  Impl(const std::string& conninfo, const std::string& station_id) : name_(DescribePostgres(conninfo)), station_(station_id) {
    // Defaults first: the URI's own values, processed after them, win (libpq: the last
    // value of a keyword is kept). Keepalives and the TCP user timeout end a query on a
    // vanished server in about 10 s.
    const std::string application = "flatscan" + (station_.empty() ? "" : "-" + station_);
    // tcp_user_timeout bounds a query whose data the vanished server never acknowledged
    // (keepalives only probe an idle connection; Linux otherwise retransmits ~15 min).
    const char* keywords[] = {"connect_timeout", "keepalives_idle", "keepalives_interval", "keepalives_count",
                              "tcp_user_timeout", "application_name", "dbname", nullptr};
    const char* values[] = {"5", "5", "2", "3", "10000", application.c_str(), conninfo.c_str(), nullptr};
    conn_ = PQconnectdbParams(keywords, values, 1);
    if (!conn_ || PQstatus(conn_) != CONNECTION_OK) {
      const std::string reason = conn_ ? Trimmed(PQerrorMessage(conn_)) : "out of memory";
      PQfinish(conn_);
      conn_ = nullptr;
      throw StoreError(fmt::format("{}: cannot connect to the plant store ({})", name_, reason));
    }
    PQsetNoticeProcessor(conn_, LogNotice, nullptr);
  }
  ~Impl() { PQfinish(conn_); }

  // Runs `sql` with `params`; throws StoreError naming the store and `what` on failure.
  Result Exec(const std::string& sql, const std::vector<Param>& params, const char* what) {
    std::vector<const char*> values;
    for (const Param& p : params) values.push_back(p ? p->c_str() : nullptr);
    // Without parameters, the simple protocol: it takes several statements (a migration).
    Result r(params.empty() ? PQexec(conn_, sql.c_str())
                            : PQexecParams(conn_, sql.c_str(), int(values.size()), nullptr, values.data(), nullptr,
                                           nullptr, 0));
    const ExecStatusType status = r.get() ? PQresultStatus(r.get()) : PGRES_FATAL_ERROR;
    if (status != PGRES_COMMAND_OK && status != PGRES_TUPLES_OK)
      throw StoreError(fmt::format("{}: cannot {} ({})", name_, what,
                                   Trimmed(r.get() ? PQresultErrorMessage(r.get()) : PQerrorMessage(conn_))));
    return r;
  }

  // Runs `body` in a transaction: committed when it returns, rolled back when it throws.
  template <typename Body>
  auto Transaction(const char* what, Body body) {
    Exec("BEGIN", {}, what);
    try {
      auto result = body();
      Exec("COMMIT", {}, what);
      return result;
    } catch (...) {
      PQclear(PQexec(conn_, "ROLLBACK"));  // a lost connection has nothing to roll back
      throw;
    }
  }

  void CreateOrMigrate() {
    Transaction("create the plant table", [&] {
      Exec(fmt::format("SELECT pg_advisory_xact_lock({})", kSchemaLockKey), {}, "lock the plant table's schema");
      int version = Version();
      if (version > kPlantStoreSchemaVersion) throw NewerStore(version);
      for (; version < kPlantStoreSchemaVersion; ++version) {
        Exec(kMigrations[size_t(version)], {}, "migrate the plant table");
        Exec("UPDATE flatscan_schema SET version = $1", {std::to_string(version + 1)}, "set the schema version");
      }
      return 0;
    });
  }

  void CheckReadable() {
    const int version = Version();
    if (version == 0)
      throw StoreError(fmt::format("{}: has no flatscan plant table (a station with --plant-store creates it)", name_));
    if (version > kPlantStoreSchemaVersion) throw NewerStore(version);
    if (version < kPlantStoreSchemaVersion)
      throw StoreError(fmt::format("{}: plant table of an older flatscan (schema version {}); run a station with "
                                   "--plant-store on it once to migrate it to version {}",
                                   name_, version, kPlantStoreSchemaVersion));
  }

  // 0 for a database without the table; throws when flatscan_records exists without it.
  int Version() {
    const Result tables = Exec(
        "SELECT to_regclass('flatscan_schema') IS NOT NULL, to_regclass('flatscan_records') IS NOT NULL", {},
        "read the plant table's schema");
    if (tables.Text(0, 0) == "t") {
      const Result version = Exec("SELECT version FROM flatscan_schema", {}, "read the schema version");
      if (version.Rows() != 1 || PQgetisnull(version.get(), 0, 0))
        throw StoreError(fmt::format("{}: flatscan_schema must hold one version, found {} rows", name_, version.Rows()));
      return int(version.Int(0, 0));
    }
    if (tables.Text(0, 1) == "t")
      throw StoreError(fmt::format("{}: has a table flatscan_records that is not a flatscan plant table", name_));
    return 0;
  }

  StoreError NewerStore(int version) const {
    return StoreError(fmt::format("{}: plant table written by a newer flatscan (schema version {}, this one knows up "
                                  "to {}); use that version",
                                  name_, version, kPlantStoreSchemaVersion));
  }

  void Insert(const StationRecord& r, bool skip_existing) {
    const InspectionRecord& in = r.inspection;
    const bool m = in.measured;
    const auto optional = [m](double v) { return m ? Param(Number(v)) : std::nullopt; };
    const std::string sql = std::string(
        "INSERT INTO flatscan_records (station_id, sequence, record_id, time_utc, source_id, recipe, recipe_sha256, "
        "left_sha256, right_sha256, measured, verdict, marginal, flatness_mm, lsq_pv_mm, minzone_mm, coverage, "
        "uncertainty_mm, error, record_json) VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13, $14, $15, "
        "$16, $17, $18, $19)") + (skip_existing ? " ON CONFLICT (station_id, sequence) DO NOTHING RETURNING 1" : "");
    last_insert_ = Exec(sql,
                        {r.station_id, std::to_string(r.sequence), r.record_id, r.time_utc, r.source_id,
                         r.recipe_name, r.recipe_sha256, r.left_sha256, r.right_sha256, m ? "t" : "f",
                         m ? Param(VerdictName(in.judgement.verdict)) : std::nullopt,
                         m && in.judgement.marginal ? "t" : "f", optional(in.values.flatness_mm),
                         optional(in.values.lsq_pv_mm), optional(in.values.minzone_mm), optional(in.coverage),
                         optional(in.uncertainty.expanded_mm), m ? std::nullopt : Param(in.error),
                         StationRecordToJsonText(r)},
                        "store the record")
                       .Rows();
  }

  // Rows of (station_id, sequence, record_json) as records.
  void Visit(const Result& rows, const std::function<void(const StationRecord&)>& visit) const {
    for (int i = 0; i < rows.Rows(); ++i) visit(Parse(rows.Text(i, 0), rows.Text(i, 1), rows.Text(i, 2)));
  }

  StationRecord Parse(const std::string& station, const std::string& sequence, const std::string& json) const {
    try {
      return StationRecordFromJsonText(json);
    } catch (const InputError& e) {
      throw StoreError(fmt::format("{}: record {} #{}: {}", name_, station, sequence, e.what()));
    }
  }

  // Every row of a query that may return many (a plant's history), one at a time, so
  // that memory does not grow with the table (libpq's single-row mode).
  void Stream(const std::string& sql, const std::vector<Param>& params,
              const std::function<void(const StationRecord&)>& visit) {
    std::vector<const char*> values;
    for (const Param& p : params) values.push_back(p ? p->c_str() : nullptr);
    if (!PQsendQueryParams(conn_, sql.c_str(), int(values.size()), nullptr, values.data(), nullptr, nullptr, 0) ||
        !PQsetSingleRowMode(conn_))
      throw StoreError(fmt::format("{}: cannot read the records ({})", name_, Trimmed(PQerrorMessage(conn_))));
    std::string error;
    while (PGresult* raw = PQgetResult(conn_)) {  // read to the end, also after an error, to keep the connection usable
      const Result row(raw);
      const ExecStatusType status = PQresultStatus(raw);
      if (status == PGRES_SINGLE_TUPLE && error.empty()) {
        try {
          Visit(row, visit);
        } catch (const std::exception& e) {
          error = e.what();
        }
      } else if (status != PGRES_SINGLE_TUPLE && status != PGRES_TUPLES_OK && error.empty()) {
        error = fmt::format("{}: cannot read the records ({})", name_, Trimmed(PQresultErrorMessage(raw)));
      }
    }
    if (!error.empty()) throw StoreError(error);
  }

  PGconn* conn_ = nullptr;
  std::string name_, station_;
  int last_insert_ = 0;  // rows the last Insert stored
};

PostgresResultsStore::PostgresResultsStore(const std::string& conninfo, const std::string& station_id, bool create)
    : impl_(std::make_unique<Impl>(conninfo, station_id)) {
  if (create) impl_->CreateOrMigrate();
  else impl_->CheckReadable();
}

PostgresResultsStore::~PostgresResultsStore() = default;

bool PostgresResultsStore::Commit(StationRecord& record) {
  Impl& s = *impl_;
  if (s.station_.empty()) throw StoreError(fmt::format("{}: opened for reading: cannot commit", s.name_));
  if (record.station_id != s.station_)
    throw StoreError(fmt::format("{}: a record of station '{}' given to the store of station '{}'", s.name_,
                                 record.station_id, s.station_));
  return s.Transaction("commit the record", [&] {
    // One station's numbering at a time (another process may commit for it too).
    s.Exec("SELECT pg_advisory_xact_lock(hashtext('flatscan:' || $1))", {s.station_}, "lock the station's numbering");
    if (Contains(record.source_id, record.left_sha256, record.right_sha256)) return false;
    const Result last = s.Exec(
        "SELECT sequence, record_json->>'time_utc' FROM flatscan_records WHERE station_id = $1 "
        "ORDER BY sequence DESC LIMIT 1",
        {s.station_}, "read the last record");
    record.sequence = last.Rows() ? last.Int(0, 0) + 1 : 1;
    record.time_utc = std::max(UtcNowIso8601(), last.Rows() ? last.Text(0, 1) : "");
    s.Insert(record, false);
    return true;
  });
}

int64_t PostgresResultsStore::LastSequence() {
  return impl_
      ->Exec("SELECT COALESCE(MAX(sequence), 0) FROM flatscan_records WHERE $1::text IS NULL OR station_id = $1",
             {impl_->station_.empty() ? std::nullopt : Param(impl_->station_)}, "read the last sequence")
      .Int(0, 0);
}

bool PostgresResultsStore::Contains(const std::string& source_id, const std::string& left, const std::string& right) {
  return impl_
             ->Exec("SELECT 1 FROM flatscan_records WHERE station_id = $1 AND source_id = $2 AND left_sha256 = $3 "
                    "AND right_sha256 = $4 LIMIT 1",
                    {impl_->station_, source_id, left, right}, "look for the pair")
             .Rows() > 0;
}

void PostgresResultsStore::ForEach(const TimeRange& range, const std::function<void(const StationRecord&)>& visit) {
  const auto bound = [](const std::string& t) { return t.empty() ? std::nullopt : Param(t); };
  impl_->Stream(
      "SELECT station_id, sequence, record_json::text FROM flatscan_records WHERE ($1::timestamptz IS NULL OR "
      "time_utc >= $1) AND ($2::timestamptz IS NULL OR time_utc < $2) ORDER BY time_utc, station_id, sequence",
      {bound(range.from), bound(range.to)}, visit);
}

void PostgresResultsStore::ForEachAfter(int64_t after, int64_t limit,
                                        const std::function<void(const StationRecord&)>& visit) {
  impl_->Visit(impl_->Exec("SELECT station_id, sequence, record_json::text FROM flatscan_records "
                           "WHERE station_id = $1 AND sequence > $2 ORDER BY sequence LIMIT $3",
                           {impl_->station_, std::to_string(after), std::to_string(limit)}, "read the records"),
               visit);
}

size_t PostgresResultsStore::Append(const std::vector<StationRecord>& records) {
  Impl& s = *impl_;
  return s.Transaction("store the records", [&] {
    size_t stored = 0;
    for (const StationRecord& r : records) {
      s.Insert(r, true);
      if (s.last_insert_ == 1) {
        ++stored;
        continue;
      }
      const Result held = s.Exec("SELECT record_id FROM flatscan_records WHERE station_id = $1 AND sequence = $2",
                                 {r.station_id, std::to_string(r.sequence)}, "read the stored record");
      if (held.Rows() && held.Text(0, 0) != r.record_id)
        throw StoreError(fmt::format("{}: holds station '{}' #{} as record {}, not {}: was the station's local store "
                                     "replaced? Give the station a new --station-id",
                                     s.name_, r.station_id, r.sequence, held.Text(0, 0), r.record_id));
    }
    return stored;
  });
}

bool PostgresResultsStore::Connected() const { return PQstatus(impl_->conn_) == CONNECTION_OK; }

}  // namespace flatscan
