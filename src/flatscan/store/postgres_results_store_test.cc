// The plant store on a real PostgreSQL server: a throwaway cluster per test on a free
// loopback port (postgres_test_util.h), stopped whatever the test did.
#include "flatscan/store/postgres_results_store.h"

#include <libpq-fe.h>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "flatscan/store/postgres_test_util.h"
#include "flatscan/store/store_test_util.h"
#include "flatscan/util/error.h"

namespace flatscan {
namespace {

using testing::AllRecords;
using testing::PostgresCluster;
using testing::TestRecord;

constexpr const char* kPassword = "s3cret-Pw";

// Records 1..n of `station` as its own store numbered them, a millisecond apart.
std::vector<StationRecord> Numbered(const std::string& station, int first, int n) {
  std::vector<StationRecord> records;
  for (int i = first; i < first + n; ++i) {
    StationRecord r = TestRecord(fmt::format("{}-{}", station, i), std::string(64, 'a'), i % 3 ? 0.01 * i : -1, station);
    r.sequence = i;
    r.time_utc = fmt::format("2026-12-05T10:00:00.{:03d}Z", i);
    records.push_back(r);
  }
  return records;
}

// Runs `sql` over a plain libpq connection; its first value.
std::string Query(const std::string& uri, const std::string& sql) {
  PGconn* conn = PQconnectdb(uri.c_str());
  PGresult* r = PQexec(conn, sql.c_str());
  const std::string value = PQntuples(r) > 0 ? PQgetvalue(r, 0, 0) : PQresultErrorMessage(r);
  PQclear(r);
  PQfinish(conn);
  return value;
}

class PostgresStoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(cluster_.initialized()) << cluster_.Log();
  }
  PostgresCluster cluster_{kPassword};
};

TEST(PostgresUri, IsDescribedWithoutItsPassword) {
  EXPECT_TRUE(IsPostgresUri("postgresql://plant/db"));
  EXPECT_TRUE(IsPostgresUri("postgres://plant/db"));
  EXPECT_FALSE(IsPostgresUri("results.db"));
  EXPECT_EQ(DescribePostgres("postgresql://line:hunter2@db.plant:6543/quality?sslmode=verify-full"),
            "postgresql://line@db.plant:6543/quality");
  EXPECT_EQ(DescribePostgres("postgresql://db.plant/quality"), "postgresql://db.plant/quality");
  for (const char* bad : {"postgresql://line:hunter2@db.plant:6543/quality?nonsense=1",
                          "postgresql://line:hunter2%zz@db.plant/quality"}) {  // libpq quotes the bad token
    try {
      DescribePostgres(bad);
      ADD_FAILURE() << "expected an error for " << bad;
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()).find("hunter2"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("expected a PostgreSQL connection URI"), std::string::npos) << e.what();
    }
  }
}

TEST_F(PostgresStoreTest, AppendsEachStationsRecordsOnceAndReadsBackEveryKey) {
  ASSERT_TRUE(cluster_.Start()) << cluster_.Log();
  PostgresResultsStore line1(cluster_.Uri(), "line-1", true);
  const std::vector<StationRecord> first = Numbered("line-1", 1, 3);
  EXPECT_EQ(line1.Append(first), 3u);
  EXPECT_EQ(line1.Append(first), 0u);  // forwarded again after an outage: stored once
  EXPECT_EQ(line1.Append({first[2], Numbered("line-1", 4, 1)[0]}), 1u);
  PostgresResultsStore line2(cluster_.Uri(), "line-2", true);  // a second station: the table exists
  EXPECT_EQ(line2.Append(Numbered("line-2", 1, 2)), 2u);
  EXPECT_EQ(line1.LastSequence(), 4);
  EXPECT_EQ(line2.LastSequence(), 2);

  PostgresResultsStore reader(cluster_.Uri(), "", false);
  const std::vector<StationRecord> all = AllRecords(reader);
  ASSERT_EQ(all.size(), 6u);
  EXPECT_EQ(StationRecordToJson(all[0]), StationRecordToJson(first[0]));  // every key, every number
  EXPECT_EQ(all[0].station_id, "line-1");
  EXPECT_EQ(all[1].station_id, "line-2");  // by time, then station
  EXPECT_FALSE(all[4].inspection.measured);  // line-1 #3 is not measured: NULL columns
  EXPECT_EQ(all[4].inspection.error, "no part in the images");
  EXPECT_EQ(AllRecords(reader, {"2026-12-05T10:00:00.002Z", "2026-12-05T10:00:00.004Z"}).size(), 3u);
  std::vector<int64_t> after;
  line1.ForEachAfter(1, 2, [&](const StationRecord& r) { after.push_back(r.sequence); });
  EXPECT_EQ(after, (std::vector<int64_t>{2, 3}));
  // The columns a plant query filters on.
  EXPECT_EQ(Query(cluster_.Uri(), "SELECT count(*) FROM flatscan_records WHERE measured AND "
                                  "station_id = 'line-1' AND flatness_mm > 0.015"),
            "2");
  EXPECT_EQ(Query(cluster_.Uri(), "SELECT version FROM flatscan_schema"), std::to_string(kPlantStoreSchemaVersion));
}

TEST_F(PostgresStoreTest, RefusesARecordThatWouldBeTakenForAnother) {
  ASSERT_TRUE(cluster_.Start()) << cluster_.Log();
  PostgresResultsStore line1(cluster_.Uri(), "line-1", true);
  EXPECT_EQ(line1.Append(Numbered("line-1", 1, 2)), 2u);
  // A station whose local store was deleted starts again at #1 with new records.
  std::vector<StationRecord> restarted = Numbered("line-1", 1, 1);
  restarted.push_back(Numbered("line-1", 3, 1)[0]);
  std::swap(restarted[0], restarted[1]);
  try {
    line1.Append(restarted);
    ADD_FAILURE() << "expected a StoreError";
  } catch (const StoreError& e) {
    EXPECT_NE(std::string(e.what()).find("holds station 'line-1' #1 as record"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("was the station's local store replaced?"), std::string::npos);
    EXPECT_EQ(std::string(e.what()).find(kPassword), std::string::npos) << e.what();
  }
  EXPECT_EQ(line1.LastSequence(), 2);  // one transaction: #3 was not stored either
}

TEST_F(PostgresStoreTest, CommitNumbersEachStationAndRefusesAPairTwice) {
  ASSERT_TRUE(cluster_.Start()) << cluster_.Log();
  PostgresResultsStore a(cluster_.Uri(), "a", true), b(cluster_.Uri(), "b", true);
  StationRecord a1 = TestRecord("p1", std::string(64, '1'), 0.02, "a"), a2 = TestRecord("p2", std::string(64, '2'), 0.03, "a");
  StationRecord b1 = TestRecord("p1", std::string(64, '1'), 0.02, "b");
  EXPECT_TRUE(a.Commit(a1));
  EXPECT_TRUE(b.Commit(b1));
  EXPECT_TRUE(a.Commit(a2));
  EXPECT_EQ(a1.sequence, 1);
  EXPECT_EQ(a2.sequence, 2);
  EXPECT_EQ(b1.sequence, 1);
  EXPECT_GE(a2.time_utc, a1.time_utc);
  StationRecord again = TestRecord("p1", std::string(64, '1'), 0.02, "a");
  EXPECT_FALSE(a.Commit(again));
  EXPECT_TRUE(a.Contains("p2", std::string(64, '2'), std::string(64, 'e')));
  EXPECT_FALSE(b.Contains("p2", std::string(64, '2'), std::string(64, 'e')));
  StationRecord foreign = TestRecord("p3", std::string(64, '3'), 0.02, "b");
  EXPECT_THROW(a.Commit(foreign), StoreError);
  PostgresResultsStore reader(cluster_.Uri(), "", false);
  EXPECT_THROW(reader.Commit(a1), StoreError);
}

TEST_F(PostgresStoreTest, SaysWhyItCannotBeUsedWithoutShowingThePassword) {
  const auto error = [](const std::string& uri, bool create) {
    try {
      PostgresResultsStore store(uri, create ? "a" : "", create);
    } catch (const StoreError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string down = error(cluster_.Uri(), true);  // not started
  EXPECT_NE(down.find(fmt::format("postgresql://flatscan@127.0.0.1:{}/postgres: cannot connect to the plant store (",
                                  cluster_.port())),
            std::string::npos)
      << down;
  ASSERT_TRUE(cluster_.Start()) << cluster_.Log();
  const std::string wrong = error(fmt::format("postgresql://flatscan:wrong-pw@127.0.0.1:{}/postgres", cluster_.port()), true);
  EXPECT_NE(wrong.find("password authentication failed"), std::string::npos) << wrong;
  EXPECT_EQ(wrong.find("wrong-pw"), std::string::npos) << wrong;
  EXPECT_NE(error(cluster_.Uri(), false).find("has no flatscan plant table"), std::string::npos);
  Query(cluster_.Uri(), "CREATE TABLE flatscan_records (x integer)");
  EXPECT_NE(error(cluster_.Uri(), true).find("has a table flatscan_records that is not a flatscan plant table"),
            std::string::npos);
  Query(cluster_.Uri(), "DROP TABLE flatscan_records");
  { PostgresResultsStore created(cluster_.Uri(), "a", true); }
  Query(cluster_.Uri(), "UPDATE flatscan_schema SET version = 99");
  EXPECT_NE(error(cluster_.Uri(), false).find("plant table written by a newer flatscan (schema version 99"),
            std::string::npos);
  EXPECT_NE(error(cluster_.Uri(), true).find("plant table written by a newer flatscan (schema version 99"),
            std::string::npos);
}

TEST_F(PostgresStoreTest, ConnectsOverTlsVerifyingASelfSignedCertificate) {
  const std::filesystem::path ca = cluster_.UseSelfSignedTls();
  ASSERT_FALSE(ca.empty()) << "openssl failed";
  ASSERT_TRUE(cluster_.Start()) << cluster_.Log();
  PostgresResultsStore tls(cluster_.Uri("sslmode=verify-full&sslrootcert=" + ca.string()), "a", true);
  EXPECT_EQ(tls.Append(Numbered("a", 1, 2)), 2u);
  EXPECT_EQ(Query(cluster_.Uri("sslmode=verify-full&sslrootcert=" + ca.string()),
                  "SELECT ssl::text FROM pg_stat_ssl WHERE pid = pg_backend_pid()"),
            "true");
  try {  // the server takes TLS only
    PostgresResultsStore plain(cluster_.Uri("sslmode=disable"), "a", true);
    ADD_FAILURE() << "a plain connection was accepted";
  } catch (const StoreError& e) {
    EXPECT_NE(std::string(e.what()).find("no pg_hba.conf entry"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace flatscan
