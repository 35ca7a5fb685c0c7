// Forwarding to the plant store: a station's SQLite store and a real PostgreSQL server
// on a free loopback port, stopped and started again mid-run.
#include "flatscan/outputs/plant_forwarder.h"

#include <libpq-fe.h>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "flatscan/store/postgres_results_store.h"
#include "flatscan/store/postgres_test_util.h"
#include "flatscan/store/store_test_util.h"

namespace flatscan {
namespace {
namespace fs = std::filesystem;

using testing::PostgresCluster;

class PlantForwarderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(cluster_.initialized()) << cluster_.Log();
    local_ = OpenSqliteStore(LocalStore(), true);
  }
  std::string LocalStore() const { return (dir_.path() / "results.db").string(); }
  PlantForwarderOptions Options() const { return {cluster_.Uri(), "line-1", LocalStore()}; }

  // Commits record `i` locally and hands it to `forwarder`, as the station does.
  void CommitAndPublish(int i, PlantForwarder* forwarder) {
    StationRecord r = testing::TestRecord(fmt::format("part{}", i), std::string(64, 'a'), 0.001 * i, "line-1");
    ASSERT_TRUE(local_->Commit(r));
    if (forwarder) forwarder->Publish(r, StationCounts{});
  }

  // The plant table's (rows, distinct record ids, min sequence, max sequence) of line-1.
  std::string PlantCounts() {
    PGconn* conn = PQconnectdb(cluster_.Uri().c_str());
    PGresult* r = PQexec(conn, "SELECT count(*), count(DISTINCT record_id), min(sequence), max(sequence) "
                               "FROM flatscan_records WHERE station_id = 'line-1'");
    const std::string counts = PQntuples(r) == 1 ? fmt::format("{} {} {} {}", PQgetvalue(r, 0, 0), PQgetvalue(r, 0, 1),
                                                              PQgetvalue(r, 0, 2), PQgetvalue(r, 0, 3))
                                                  : PQerrorMessage(conn);
    PQclear(r);
    PQfinish(conn);
    return counts;
  }

  testing::ScratchDir dir_{"plant"};
  PostgresCluster cluster_{"line-pw"};
  std::unique_ptr<ResultsStore> local_;
};

// The outage test: the server is stopped mid-run and started again; the plant
// table ends with every record once (records produced = rows = distinct ids).
TEST_F(PlantForwarderTest, EveryRecordOnceThroughAServerOutage) {
  ASSERT_TRUE(cluster_.Start()) << cluster_.Log();
  PlantForwarder forwarder(Options());
  for (int i = 1; i <= 20; ++i) CommitAndPublish(i, &forwarder);
  ASSERT_TRUE(forwarder.Drain(std::chrono::seconds(20)));
  EXPECT_EQ(PlantCounts(), "20 20 1 20");
  ASSERT_TRUE(cluster_.Stop());
  for (int i = 21; i <= 40; ++i) CommitAndPublish(i, &forwarder);  // the station goes on
  EXPECT_EQ(forwarder.ForwardedThrough(), 20);
  ASSERT_TRUE(cluster_.Start()) << cluster_.Log();
  for (int i = 41; i <= 60; ++i) CommitAndPublish(i, &forwarder);
  ASSERT_TRUE(forwarder.Drain(std::chrono::seconds(30)));
  EXPECT_EQ(PlantCounts(), "60 60 1 60");
  // Every key as the station stored it.
  PostgresResultsStore plant(cluster_.Uri(), "", false);
  std::vector<StationRecord> local = testing::AllRecords(*local_), forwarded = testing::AllRecords(plant);
  ASSERT_EQ(forwarded.size(), local.size());
  for (size_t i = 0; i < local.size(); ++i) EXPECT_EQ(StationRecordToJson(forwarded[i]), StationRecordToJson(local[i]));
}

// A station that recorded while it had no plant connection (the server down, then the
// station stopped) forwards the backlog when it starts again, and a second start adds
// nothing.
TEST_F(PlantForwarderTest, CatchesUpAfterTheStationStartsAgainWithoutDuplicates) {
  {
    PlantForwarder forwarder(Options());  // the server is down: records stay local
    for (int i = 1; i <= 450; ++i) CommitAndPublish(i, &forwarder);
    EXPECT_EQ(forwarder.ForwardedThrough(), 0);
  }
  ASSERT_TRUE(cluster_.Start()) << cluster_.Log();
  {
    PlantForwarder forwarder(Options());  // three batches of at most 200
    ASSERT_TRUE(forwarder.Drain(std::chrono::seconds(30)));
    EXPECT_EQ(forwarder.ForwardedThrough(), 450);
  }
  EXPECT_EQ(PlantCounts(), "450 450 1 450");
  for (int i = 451; i <= 455; ++i) CommitAndPublish(i, nullptr);  // committed, then the station stopped
  PlantForwarder again(Options());
  ASSERT_TRUE(again.Drain(std::chrono::seconds(30)));
  EXPECT_EQ(PlantCounts(), "455 455 1 455");
}

// A station whose local store was deleted starts again at #1: its new records must not
// be taken for the old ones (neither skipped as "already there" nor appended after them).
TEST_F(PlantForwarderTest, RefusesAStationWhoseLocalStoreWasReplaced) {
  ASSERT_TRUE(cluster_.Start()) << cluster_.Log();
  {
    PlantForwarder forwarder(Options());
    for (int i = 1; i <= 5; ++i) CommitAndPublish(i, &forwarder);
    ASSERT_TRUE(forwarder.Drain(std::chrono::seconds(20)));
  }
  local_.reset();
  for (const char* end : {"", "-wal", "-shm"}) std::filesystem::remove(LocalStore() + end);
  local_ = OpenSqliteStore(LocalStore(), true);  // a new, shorter history
  for (int i = 1; i <= 3; ++i) CommitAndPublish(i, nullptr);
  PlantForwarder shorter(Options());
  for (int i = 4; i <= 8; ++i) CommitAndPublish(i, &shorter);  // now longer, still another history
  EXPECT_FALSE(shorter.Drain(std::chrono::milliseconds(1500)));
  EXPECT_EQ(shorter.ForwardedThrough(), 0);
  EXPECT_EQ(PlantCounts(), "5 5 1 5");  // the old five, nothing of the new history
}

TEST_F(PlantForwarderTest, NeedsTheLocalStoreToExist) {
  PlantForwarderOptions options = Options();
  options.local_store = (dir_.path() / "missing.db").string();
  EXPECT_THROW(PlantForwarder forwarder(options), StoreError);
}

}  // namespace
}  // namespace flatscan
