// The embedded results store: one SQLite file.
//
// Schema (version 1, PRAGMA user_version): one table `records`, a row per record, with
// the keys a query filters or a spreadsheet shows as columns and the whole record as
// JSON (`record_json`, StationRecordToJson) so that nothing the record holds is lost
// to the columns. A newer flatscan migrates an older file forward (kMigrations); an
// older flatscan refuses a newer file rather than misread it.
#include <fcntl.h>
#include <sqlite3.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <vector>

#include <fmt/format.h>

#include "flatscan/store/results_store.h"
#include "flatscan/util/error.h"

namespace flatscan {
namespace {

// kMigrations[v] takes a store from version v to v + 1.
const std::vector<const char*> kMigrations = {
    R"(CREATE TABLE records (
         sequence       INTEGER PRIMARY KEY,
         record_id      TEXT NOT NULL UNIQUE,
         station_id     TEXT NOT NULL,
         time_utc       TEXT NOT NULL,
         source_id      TEXT NOT NULL,
         recipe         TEXT NOT NULL,
         recipe_sha256  TEXT NOT NULL,
         left_sha256    TEXT NOT NULL,
         right_sha256   TEXT NOT NULL,
         measured       INTEGER NOT NULL,
         verdict        TEXT,
         marginal       INTEGER NOT NULL,
         flatness_mm    REAL,
         lsq_pv_mm      REAL,
         minzone_mm     REAL,
         coverage       REAL,
         uncertainty_mm REAL,
         error          TEXT,
         record_json    TEXT NOT NULL);
       CREATE INDEX records_by_pair ON records (source_id, left_sha256, right_sha256);
       CREATE INDEX records_by_time ON records (time_utc);)",
};
static_assert(kSqliteStoreSchemaVersion == 1, "add the migration to the new version to kMigrations");

// A prepared statement, finalized when it goes out of scope.
class Statement {
 public:
  Statement(sqlite3* db, const char* sql, const std::string& file) : file_(file) {
    if (sqlite3_prepare_v2(db, sql, -1, &stmt_, nullptr) != SQLITE_OK)
      throw StoreError(fmt::format("{}: cannot read the results store ({})", file, sqlite3_errmsg(db)));
  }
  ~Statement() { sqlite3_finalize(stmt_); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  void Bind(int i, const std::string& s) { sqlite3_bind_text(stmt_, i, s.c_str(), int(s.size()), SQLITE_TRANSIENT); }
  void Bind(int i, int64_t v) { sqlite3_bind_int64(stmt_, i, v); }
  void BindOptional(int i, bool present, double v) {
    if (present) sqlite3_bind_double(stmt_, i, v);
    else sqlite3_bind_null(stmt_, i);
  }
  void BindOptional(int i, bool present, const std::string& s) {
    if (present) Bind(i, s);
    else sqlite3_bind_null(stmt_, i);
  }
  // True while there is a row; throws on an error.
  bool Step() {
    const int rc = sqlite3_step(stmt_);
    if (rc == SQLITE_ROW) return true;
    if (rc == SQLITE_DONE) return false;
    throw StoreError(fmt::format("{}: {} (SQLite error {})", file_, sqlite3_errmsg(sqlite3_db_handle(stmt_)), rc));
  }
  int64_t Int(int column) { return sqlite3_column_int64(stmt_, column); }
  std::string Text(int column) {
    const unsigned char* t = sqlite3_column_text(stmt_, column);
    return t ? std::string(reinterpret_cast<const char*>(t), size_t(sqlite3_column_bytes(stmt_, column))) : "";
  }

 private:
  sqlite3_stmt* stmt_ = nullptr;
  std::string file_;
};

class SqliteResultsStore : public ResultsStore {
 public:
  SqliteResultsStore(const std::string& path, bool create) : file_(path) {
    if (create) LockForThisStation();
    // Reading (`flatscan results`) opens the file read-only: it never changes a file,
    // not even one that is not a store.
    const int flags = create ? SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE : SQLITE_OPEN_READONLY;
    if (sqlite3_open_v2(path.c_str(), &db_, flags | SQLITE_OPEN_FULLMUTEX, nullptr) != SQLITE_OK) {
      const std::string reason = db_ ? sqlite3_errmsg(db_) : "out of memory";
      Release();
      throw StoreError(fmt::format("{}: cannot open the results store ({})", path, reason));
    }
    try {
      sqlite3_busy_timeout(db_, 10000);  // another process (results, a backup) holding the lock
      if (create) {
        CheckOurs();  // before anything is written to it
        Execute("PRAGMA journal_mode=WAL; PRAGMA synchronous=FULL;", "set the journal mode");
        Migrate();
      } else {
        CheckReadable();
      }
      opened_ = true;
    } catch (...) {
      Release();
      throw;
    }
  }
  ~SqliteResultsStore() override { Release(); }

  bool Commit(StationRecord& record) override {
    Execute("BEGIN IMMEDIATE", "start a transaction");
    try {
      if (Contains(record.source_id, record.left_sha256, record.right_sha256)) {
        Execute("ROLLBACK", "end the transaction");
        return false;
      }
      record.sequence = LastSequence() + 1;
      record.time_utc = std::max(UtcNowIso8601(), LastTime());
      Insert(record);
      Execute("COMMIT", "commit the record");
      return true;
    } catch (const StoreError&) {
      sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
      throw;
    } catch (const std::exception& e) {  // whatever it was, the record is not stored
      sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
      throw StoreError(fmt::format("{}: cannot commit the record of {} ({})", file_, record.source_id, e.what()));
    }
  }

  int64_t LastSequence() override {
    Statement s(db_, "SELECT COALESCE(MAX(sequence), 0) FROM records", file_);
    s.Step();
    return s.Int(0);
  }

  bool Contains(const std::string& source_id, const std::string& left, const std::string& right) override {
    Statement s(db_, "SELECT 1 FROM records WHERE source_id = ?1 AND left_sha256 = ?2 AND right_sha256 = ?3 LIMIT 1",
                file_);
    s.Bind(1, source_id);
    s.Bind(2, left);
    s.Bind(3, right);
    return s.Step();
  }

  void ForEach(const TimeRange& range, const std::function<void(const StationRecord&)>& visit) override {
    Statement s(db_,
                "SELECT sequence, record_json FROM records WHERE (?1 = '' OR time_utc >= ?1) AND "
                "(?2 = '' OR time_utc < ?2) ORDER BY sequence",
                file_);
    s.Bind(1, range.from);
    s.Bind(2, range.to);
    VisitRows(s, visit);
  }

  void ForEachAfter(int64_t after, int64_t limit, const std::function<void(const StationRecord&)>& visit) override {
    Statement s(db_, "SELECT sequence, record_json FROM records WHERE sequence > ?1 ORDER BY sequence LIMIT ?2", file_);
    s.Bind(1, after);
    s.Bind(2, limit);
    VisitRows(s, visit);
  }

 private:
  // Rows of (sequence, record_json) as records.
  void VisitRows(Statement& s, const std::function<void(const StationRecord&)>& visit) {
    while (s.Step()) {
      StationRecord record;
      try {
        record = StationRecordFromJsonText(s.Text(1));
      } catch (const InputError& e) {
        throw StoreError(fmt::format("{}: record #{}: {}", file_, s.Int(0), e.what()));
      }
      visit(record);
    }
  }

  void Execute(const char* sql, const char* what) {
    char* message = nullptr;
    if (sqlite3_exec(db_, sql, nullptr, nullptr, &message) != SQLITE_OK) {
      const std::string reason = message ? message : sqlite3_errmsg(db_);
      sqlite3_free(message);
      throw StoreError(fmt::format("{}: cannot {} ({})", file_, what, reason));
    }
  }

  // The schema version (0: a new file, or not ours); the first read of the file, so a
  // file that is not SQLite at all fails here.
  int Version() {
    sqlite3_stmt* stmt = nullptr;
    const int rc = sqlite3_prepare_v2(db_, "PRAGMA user_version", -1, &stmt, nullptr);
    const int step = rc == SQLITE_OK ? sqlite3_step(stmt) : rc;
    const int version = step == SQLITE_ROW ? sqlite3_column_int(stmt, 0) : -1;
    sqlite3_finalize(stmt);
    if (version >= 0) return version;
    if (sqlite3_errcode(db_) == SQLITE_NOTADB)
      throw StoreError(fmt::format("{}: is not a flatscan results store ({})", file_, sqlite3_errmsg(db_)));
    // A reader of a WAL store needs its "-shm" file, which it creates when the station
    // is not running: in a folder it may not write, the open fails.
    throw StoreError(fmt::format("{}: cannot read the results store ({}; reading needs the store's -shm file, "
                                 "which SQLite creates beside the store when no station has it open: check that "
                                 "the folder may be written)",
                                 file_, sqlite3_errmsg(db_)));
  }

  // A file this flatscan may write to: a store of a known version, or a new file.
  void CheckOurs() {
    const int version = Version();
    if (version > kSqliteStoreSchemaVersion) throw NewerStore(version);
    if (version == 0 && HasOtherTables())
      throw StoreError(fmt::format("{}: is an SQLite file but not a flatscan results store", file_));
  }

  // Brings the file to this version's schema, one migration per transaction (the version
  // read again inside it).
  void Migrate() {
    while (Version() < kSqliteStoreSchemaVersion) {
      Execute("BEGIN IMMEDIATE", "start a migration");
      const int version = Version();
      if (version < kSqliteStoreSchemaVersion) {
        Execute(kMigrations[size_t(version)], "migrate the store");
        Execute(fmt::format("PRAGMA user_version = {}", version + 1).c_str(), "set the schema version");
      }
      Execute("COMMIT", "commit the migration");
    }
  }

  // Closes the database and drops the lock (removing a lock file this store created when
  // the store could not be opened).
  void Release() {
    sqlite3_close(db_);
    db_ = nullptr;
    if (lock_fd_ >= 0) ::close(lock_fd_);
    lock_fd_ = -1;
    if (created_lock_file_ && !opened_) ::unlink((file_ + ".lock").c_str());
  }

  // One station per store: an exclusive lock on "<store>.lock", held while open (the
  // kernel drops it when the process ends, also by kill -9). A lock file beside the store,
  // not on it: closing any descriptor of the database file would drop SQLite's own locks.
  void LockForThisStation() {
    const std::string lock = file_ + ".lock";
    created_lock_file_ = ::access(lock.c_str(), F_OK) != 0;
    lock_fd_ = ::open(lock.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (lock_fd_ < 0)
      throw StoreError(fmt::format("{}: cannot open the store's lock file {} ({})", file_, lock, std::strerror(errno)));
    if (::flock(lock_fd_, LOCK_EX | LOCK_NB) != 0) {
      ::close(lock_fd_);
      lock_fd_ = -1;
      created_lock_file_ = false;
      throw StoreError(fmt::format("{}: another station is using this store (it holds {})", file_, lock));
    }
  }

  // A store opened read-only must already have this version's schema.
  void CheckReadable() {
    const int version = Version();
    if (version == 0)
      throw StoreError(fmt::format("{}: is not a flatscan results store (it has no store schema version)", file_));
    if (version > kSqliteStoreSchemaVersion) throw NewerStore(version);
    if (version < kSqliteStoreSchemaVersion)
      throw StoreError(fmt::format("{}: written by an older flatscan (store schema version {}); run `flatscan station` "
                                   "on it once to migrate it to version {}",
                                   file_, version, kSqliteStoreSchemaVersion));
  }

  StoreError NewerStore(int version) const {
    return StoreError(fmt::format("{}: written by a newer flatscan (store schema version {}, this one knows up to {}); "
                                  "use that version",
                                  file_, version, kSqliteStoreSchemaVersion));
  }

  bool HasOtherTables() {
    Statement s(db_, "SELECT 1 FROM sqlite_master LIMIT 1", file_);
    return s.Step();
  }

  std::string LastTime() {
    Statement s(db_, "SELECT time_utc FROM records ORDER BY sequence DESC LIMIT 1", file_);
    return s.Step() ? s.Text(0) : "";
  }

  void Insert(const StationRecord& r) {
    Statement s(db_,
                "INSERT INTO records (sequence, record_id, station_id, time_utc, source_id, recipe, recipe_sha256, "
                "left_sha256, right_sha256, measured, verdict, marginal, flatness_mm, lsq_pv_mm, minzone_mm, "
                "coverage, uncertainty_mm, error, record_json) "
                "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15, ?16, ?17, ?18, ?19)",
                file_);
    const InspectionRecord& in = r.inspection;
    const bool m = in.measured;
    s.Bind(1, r.sequence);
    s.Bind(2, r.record_id);
    s.Bind(3, r.station_id);
    s.Bind(4, r.time_utc);
    s.Bind(5, r.source_id);
    s.Bind(6, r.recipe_name);
    s.Bind(7, r.recipe_sha256);
    s.Bind(8, r.left_sha256);
    s.Bind(9, r.right_sha256);
    s.Bind(10, int64_t(m));
    s.BindOptional(11, m, std::string(VerdictName(in.judgement.verdict)));
    s.Bind(12, int64_t(m && in.judgement.marginal));
    s.BindOptional(13, m, in.values.flatness_mm);
    s.BindOptional(14, m, in.values.lsq_pv_mm);
    s.BindOptional(15, m, in.values.minzone_mm);
    s.BindOptional(16, m, in.coverage);
    s.BindOptional(17, m, in.uncertainty.expanded_mm);
    s.BindOptional(18, !m, in.error);
    // Text that is not UTF-8 (a Latin-1 file name) is stored with U+FFFD, not refused.
    s.Bind(19, StationRecordToJsonText(r));
    s.Step();
  }

  std::string file_;
  sqlite3* db_ = nullptr;
  int lock_fd_ = -1;
  bool created_lock_file_ = false, opened_ = false;
};

}  // namespace

std::unique_ptr<ResultsStore> OpenSqliteStore(const std::string& path, bool create) {
  return std::make_unique<SqliteResultsStore>(path, create);
}

}  // namespace flatscan
