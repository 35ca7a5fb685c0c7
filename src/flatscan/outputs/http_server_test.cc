// The station's web server on loopback, through cpp-httplib's client.
#include "flatscan/outputs/http_server.h"

#include <httplib.h>

#include <gtest/gtest.h>

#include "flatscan/store/store_test_util.h"
#include "flatscan/util/error.h"
#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {

nlohmann::json GetSummary(int port) {
  httplib::Client client("127.0.0.1", port);
  client.set_read_timeout(5, 0);
  const auto res = client.Get("/api/summary");
  EXPECT_TRUE(res);
  if (!res) return {};
  EXPECT_EQ(res->status, 200);
  EXPECT_EQ(res->get_header_value("Content-Type"), "application/json");
  return nlohmann::json::parse(res->body);
}

TEST(StationHttpServer, ServesTheCountsAndTheLastRecordAsTheyAreCommitted) {
  SummaryCounts start;
  start.measured = 3;
  start.pass = 2;
  start.fail = 1;
  start.not_measured = 1;
  StationHttpServer server("127.0.0.1", 0, "line-1", start, std::nullopt);  // a free port
  ASSERT_GT(server.Port(), 0);
  nlohmann::json s = GetSummary(server.Port());
  EXPECT_EQ(s["station_id"], "line-1");
  EXPECT_EQ(s["state"], "ready");
  EXPECT_EQ(s["counts"], (nlohmann::json{{"measured", 3}, {"pass", 2}, {"fail", 1}, {"marginal", 0}, {"not_measured", 1}}));
  EXPECT_TRUE(s["last"].is_null());

  StationRecord record = testing::TestRecord("part-9", std::string(64, 'a'), 0.15);  // tolerance 0.1: a fail
  record.sequence = 5;
  server.Publish(record, {});
  server.Publish(testing::TestRecord("part-10", std::string(64, 'b'), -1), {});  // not measured
  server.Readiness(false, "cameras", {});
  s = GetSummary(server.Port());
  EXPECT_EQ(s["counts"]["fail"], 2);
  EXPECT_EQ(s["counts"]["not_measured"], 2);
  EXPECT_EQ(s["state"], "not_ready");
  EXPECT_EQ(s["last"]["source_id"], "part-10");
  EXPECT_EQ(s["last"]["measured"], false);
  EXPECT_EQ(StationRecordFromJson(s["last"]).inspection.error, "no part in the images");

  httplib::Client client("127.0.0.1", server.Port());
  const auto page = client.Get("/");
  ASSERT_TRUE(page);
  EXPECT_EQ(page->status, 200);
  EXPECT_NE(page->body.find("fetch('/api/summary')"), std::string::npos);
  for (const char* external : {"src=", "href=", "http://", "https://"})
    EXPECT_EQ(page->body.find(external), std::string::npos) << external;  // nothing from elsewhere
  const auto missing = client.Get("/part/123");
  ASSERT_TRUE(missing);
  EXPECT_EQ(missing->status, 404);
  EXPECT_EQ(missing->body, "not found: /part/123 (the station serves / and /api/summary)\n");
  const auto post = client.Post("/api/summary", "{}", "application/json");
  ASSERT_TRUE(post);
  EXPECT_EQ(post->status, 404);  // read-only
}

TEST(StationHttpServer, APortInUseIsNamed) {
  StationHttpServer first("127.0.0.1", 0, "a", {}, std::nullopt);
  EXPECT_EQ(testing::InputErrorOf([&] { StationHttpServer second("127.0.0.1", first.Port(), "b", {}, std::nullopt); }),
            fmt::format("--http 127.0.0.1:{}: cannot listen there (in use, or not an address of this machine)",
                        first.Port()));
}

}  // namespace
}  // namespace flatscan
