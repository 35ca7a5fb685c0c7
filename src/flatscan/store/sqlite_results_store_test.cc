// The embedded results store on a real SQLite file.
#include <sqlite3.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "flatscan/store/results_store.h"
#include "flatscan/store/store_test_util.h"
#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {
namespace fs = std::filesystem;

using testing::AllRecords;

StationRecord Record(const std::string& source_id, const std::string& left_sha256, double flatness_mm) {
  return testing::TestRecord(source_id, left_sha256, flatness_mm);
}

// A PRAGMA's value as the file reports it.
std::string Pragma(const fs::path& file, const std::string& name) {
  sqlite3* db = nullptr;
  EXPECT_EQ(sqlite3_open_v2(file.c_str(), &db, SQLITE_OPEN_READONLY, nullptr), SQLITE_OK);
  sqlite3_stmt* stmt = nullptr;
  sqlite3_prepare_v2(db, ("PRAGMA " + name).c_str(), -1, &stmt, nullptr);
  std::string value;
  if (sqlite3_step(stmt) == SQLITE_ROW) value = reinterpret_cast<const char*>(sqlite3_column_text(stmt, 0));
  sqlite3_finalize(stmt);
  sqlite3_close(db);
  return value;
}

TEST(SqliteResultsStore, CommitsInSequenceAndReadsBackEveryKey) {
  testing::ScratchDir dir("store");
  const fs::path file = dir.path() / "results.db";
  std::vector<StationRecord> written = {Record("a", std::string(64, '1'), 0.05), Record("b", std::string(64, '2'), -1),
                                        Record("c", std::string(64, '3'), 0.2)};
  {
    auto store = OpenSqliteStore(file.string(), true);
    EXPECT_EQ(store->LastSequence(), 0);
    for (StationRecord& r : written) store->Commit(r);
    EXPECT_EQ(written[2].sequence, 3);
    EXPECT_TRUE(store->Contains("b", std::string(64, '2'), std::string(64, 'e')));
    EXPECT_FALSE(store->Contains("b", std::string(64, '1'), std::string(64, 'e')));  // same id, other image
  }
  auto store = OpenSqliteStore(file.string(), true);  // a station restarted: nothing lost
  const std::vector<StationRecord> read = AllRecords(*store);
  ASSERT_EQ(read.size(), 3u);
  for (size_t i = 0; i < read.size(); ++i) {
    EXPECT_EQ(read[i].sequence, int64_t(i + 1));
    EXPECT_EQ(StationRecordToJson(read[i]), StationRecordToJson(written[i]));
    if (i > 0) {
      EXPECT_GE(read[i].time_utc, read[i - 1].time_utc);
    }
  }
  EXPECT_FALSE(read[1].inspection.measured);
  EXPECT_EQ(read[1].inspection.error, "no part in the images");
  StationRecord d = Record("d", std::string(64, '4'), 0.01);
  store->Commit(d);
  EXPECT_EQ(d.sequence, 4);  // sequence numbers continue after a restart
  std::vector<int64_t> batch;  // the outbox read: after #1, at most 2
  store->ForEachAfter(1, 2, [&](const StationRecord& r) { batch.push_back(r.sequence); });
  EXPECT_EQ(batch, (std::vector<int64_t>{2, 3}));
  EXPECT_EQ(Pragma(file, "journal_mode"), "wal");
  EXPECT_EQ(Pragma(file, "user_version"), std::to_string(kSqliteStoreSchemaVersion));
}

TEST(SqliteResultsStore, ARecordOfTheSamePairIsNotCommittedTwiceAndOneStationHoldsTheStore) {
  testing::ScratchDir dir("store-once");
  const fs::path file = dir.path() / "r.db";
  auto store = OpenSqliteStore(file.string(), true);
  StationRecord a = Record("a", std::string(64, '1'), 0.05), again = a;
  again.record_id = NewRecordId();
  EXPECT_TRUE(store->Commit(a));
  EXPECT_FALSE(store->Commit(again));
  EXPECT_EQ(store->LastSequence(), 1);
  try {
    OpenSqliteStore(file.string(), true);
    ADD_FAILURE() << "a second station opened the store";
  } catch (const StoreError& e) {
    EXPECT_EQ(std::string(e.what()),
              file.string() + ": another station is using this store (it holds " + file.string() + ".lock)");
  }
  EXPECT_EQ(AllRecords(*OpenSqliteStore(file.string(), false)).size(), 1u);  // a reader is welcome
  store.reset();
  EXPECT_NO_THROW(OpenSqliteStore(file.string(), true));  // released with the store
}

TEST(SqliteResultsStore, TimeRangesIncludeFromAndExcludeTo) {
  testing::ScratchDir dir("store-range");
  auto store = OpenSqliteStore((dir.path() / "r.db").string(), true);
  std::vector<StationRecord> records = {Record("a", std::string(64, '1'), 0.05), Record("b", std::string(64, '2'), 0.05),
                                        Record("c", std::string(64, '3'), 0.05)};
  for (StationRecord& r : records) store->Commit(r);
  const std::string t1 = records[1].time_utc;
  std::vector<StationRecord> from = AllRecords(*store, {t1, ""});
  ASSERT_FALSE(from.empty());
  EXPECT_GE(from.front().time_utc, t1);
  for (const StationRecord& r : AllRecords(*store, {"", t1})) EXPECT_LT(r.time_utc, t1);
  EXPECT_EQ(AllRecords(*store, {"", t1}).size() + from.size(), 3u);
  EXPECT_TRUE(AllRecords(*store, {"2000-01-01T00:00:00.000Z", "2000-01-02T00:00:00.000Z"}).empty());
}

TEST(SqliteResultsStore, RefusesWhatItCannotUse) {
  testing::ScratchDir dir("store-bad");
  const auto error_of = [](const fs::path& file, bool create) {
    try {
      OpenSqliteStore(file.string(), create);
    } catch (const StoreError& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  const fs::path missing = dir.path() / "missing.db";
  EXPECT_EQ(error_of(missing, false), missing.string() + ": cannot open the results store (unable to open database file)");
  EXPECT_FALSE(fs::exists(missing));  // `results` never creates a store

  const fs::path other = dir.path() / "other.db";
  sqlite3* db = nullptr;
  sqlite3_open(other.c_str(), &db);
  sqlite3_exec(db, "CREATE TABLE t (x)", nullptr, nullptr, nullptr);
  sqlite3_close(db);
  EXPECT_EQ(error_of(other, true), other.string() + ": is an SQLite file but not a flatscan results store");

  const fs::path newer = dir.path() / "newer.db";
  OpenSqliteStore(newer.string(), true);
  sqlite3_open(newer.c_str(), &db);
  sqlite3_exec(db, "PRAGMA user_version = 99", nullptr, nullptr, nullptr);
  sqlite3_close(db);
  EXPECT_EQ(error_of(newer, true), newer.string() + ": written by a newer flatscan (store schema version 99, this one "
                                                    "knows up to 1); use that version");
  EXPECT_EQ(error_of(newer, false), newer.string() + ": written by a newer flatscan (store schema version 99, this one "
                                                     "knows up to 1); use that version");

  EXPECT_EQ(error_of(other, false), other.string() + ": is not a flatscan results store (it has no store schema version)");
  const fs::path empty = dir.path() / "empty.db";
  std::ofstream(empty).close();
  EXPECT_EQ(error_of(empty, false), empty.string() + ": is not a flatscan results store (it has no store schema version)");
  EXPECT_EQ(fs::file_size(empty), 0u);  // reading never writes

  const fs::path text = dir.path() / "text.db";
  {
    std::ofstream(text) << "not a database at all, just some text that is long enough to have a header\n";
  }
  const std::string text_before = testing::ReadFileBytes(text);
  EXPECT_EQ(error_of(text, true), text.string() + ": is not a flatscan results store (file is not a database)");
  EXPECT_EQ(error_of(text, false), text.string() + ": is not a flatscan results store (file is not a database)");
  EXPECT_EQ(testing::ReadFileBytes(text), text_before);
  EXPECT_FALSE(fs::exists(text.string() + ".lock"));  // the lock file it made is gone again
}

}  // namespace
}  // namespace flatscan
