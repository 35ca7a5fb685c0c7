// The station's web server on loopback, through cpp-httplib's client, with a real SQLite
// store behind /api/parts.
#include "flatscan/outputs/http_server.h"

#include <httplib.h>

#include <atomic>
#include <thread>

#include <gtest/gtest.h>

#include "flatscan/store/store_test_util.h"
#include "flatscan/util/error.h"
#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {

LiveSummary Summary(const std::string& station) {
  return LiveSummary(station, ShiftCalendar::Parse("06:00,14:00,22:00", "--shifts"), std::chrono::system_clock::now());
}

struct Reply {
  int status = 0;
  std::string body, content_type;
};

Reply Get(int port, const std::string& path) {
  httplib::Client client("127.0.0.1", port);
  client.set_read_timeout(5, 0);
  const auto res = client.Get(path.c_str());
  if (!res) return {};
  return {res->status, res->body, res->get_header_value("Content-Type")};
}

Reply PostRecipe(int port, const std::string& body, const std::string& token) {
  httplib::Client client("127.0.0.1", port);
  client.set_read_timeout(5, 0);
  httplib::Headers headers;
  if (!token.empty()) headers.emplace("Authorization", "Bearer " + token);
  const auto res = client.Post("/api/recipe", headers, body, "application/json");
  if (!res) return {};
  return {res->status, res->body, res->get_header_value("Content-Type")};
}

nlohmann::json GetSummary(int port) {
  const Reply r = Get(port, "/api/summary");
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.content_type, "application/json");
  return nlohmann::json::parse(r.body, nullptr, false);
}

// Thumbnails: the last part's, and those of the last 10 fails and not-measured parts; a
// pass's goes when the next part comes.
TEST(StationHttpServer, KeepsTheImagesOfTheLastPartAndOfTheRecentProblems) {
  StationHttpServer server({}, Summary("line-1"), {});
  const auto publish = [&](int64_t sequence, double flatness) {
    StationRecord r = testing::TestRecord(fmt::format("p{}", sequence), std::string(64, 'a'), flatness);
    r.sequence = sequence;
    server.PublishImage(r, fmt::format("jpeg of {}", sequence));
    server.Publish(r, {});
  };
  publish(1, 0.05);  // a pass
  Reply r = Get(server.Port(), "/api/parts/1/image.jpg");
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.content_type, "image/jpeg");
  EXPECT_EQ(r.body, "jpeg of 1");
  publish(2, 0.15);  // a fail
  for (int64_t k = 3; k <= 12; ++k) publish(k, k % 2 ? -1 : 0.2);  // 10 more problems
  publish(13, 0.05);
  EXPECT_EQ(Get(server.Port(), "/api/parts/1/image.jpg").status, 404);   // a pass, no longer the last
  EXPECT_EQ(Get(server.Port(), "/api/parts/2/image.jpg").status, 404);   // the 11th problem back
  EXPECT_EQ(Get(server.Port(), "/api/parts/3/image.jpg").body, "jpeg of 3");
  EXPECT_EQ(Get(server.Port(), "/api/parts/13/image.jpg").body, "jpeg of 13");
  r = Get(server.Port(), "/api/parts/2/image.jpg");
  EXPECT_EQ(r.body, "no image of part 2: the page keeps the last part's and those of the last 10 fails and "
                    "not-measured parts\n");
  EXPECT_EQ(Get(server.Port(), "/api/parts/x/image.jpg").status, 404);
}

// A flood of polls costs one summary per period: the health is asked once for requests
// within kSummaryMaxAge, again after a commit and after the period.
TEST(StationHttpServer, BuildsTheSummaryOncePerPeriodOrCommit) {
  std::atomic<int> asked{0};
  StationHooks hooks;
  hooks.health = [&] {
    ++asked;
    return nlohmann::json::object();
  };
  HttpServerOptions unlimited;
  unlimited.max_requests_per_s = 1e6;
  StationHttpServer server(unlimited, Summary("line-1"), hooks);
  const auto start = std::chrono::steady_clock::now();
  const std::string first = Get(server.Port(), "/api/summary").body;
  for (int i = 0; i < 20; ++i) EXPECT_EQ(Get(server.Port(), "/api/summary").body, first);
  const auto periods = (std::chrono::steady_clock::now() - start) / StationHttpServer::kSummaryMaxAge;
  EXPECT_LE(asked.load(), 1 + int(periods) + 1);  // once per period begun (1 here, more under a sanitizer)
  const int before = asked.load();
  server.Publish(testing::TestRecord("p1", std::string(64, 'a'), 0.05), {});
  EXPECT_NE(Get(server.Port(), "/api/summary").body.find("\"p1\""), std::string::npos);
  EXPECT_EQ(asked.load(), before + 1);
  std::this_thread::sleep_for(StationHttpServer::kSummaryMaxAge + std::chrono::milliseconds(50));
  Get(server.Port(), "/api/summary");
  EXPECT_EQ(asked.load(), before + 2);
}

TEST(StationHttpServer, ServesTheCountsAndTheLastRecordAsTheyAreCommitted) {
  LiveSummary start = Summary("line-1");
  for (int i = 1; i <= 4; ++i) start.AddStored(testing::TestRecord(fmt::format("old-{}", i), "a", i < 4 ? 0.05 : -1));
  StationHooks hooks;
  hooks.health = [] { return nlohmann::json{{"active_recipe", "shield"}}; };
  StationHttpServer server({}, std::move(start), hooks);  // 127.0.0.1, a free port
  ASSERT_GT(server.Port(), 0);
  nlohmann::json s = GetSummary(server.Port());
  EXPECT_EQ(s["station_id"], "line-1");
  EXPECT_EQ(s["state"], "ready");
  EXPECT_EQ(s["counts"], (nlohmann::json{{"measured", 3}, {"pass", 3}, {"fail", 0}, {"marginal", 0}, {"not_measured", 1}}));
  EXPECT_EQ(s["last"]["source_id"], "old-4");
  EXPECT_EQ(s["health"]["active_recipe"], "shield");

  StationRecord record = testing::TestRecord("part-9", std::string(64, 'a'), 0.15);  // tolerance 0.1: a fail
  record.sequence = 5;
  server.Publish(record, {});
  server.Publish(testing::TestRecord("part-10", std::string(64, 'b'), -1), {});  // not measured
  server.Readiness(false, "cameras: no frame", {});
  s = GetSummary(server.Port());
  EXPECT_EQ(s["counts"]["fail"], 1);
  EXPECT_EQ(s["counts"]["not_measured"], 2);
  EXPECT_EQ(s["since_start"]["measured"], 1);
  EXPECT_EQ(s["state"], "not_ready");
  EXPECT_EQ(s["not_ready_reason"], "cameras: no frame");
  EXPECT_EQ(s["last"]["source_id"], "part-10");
  EXPECT_EQ(StationRecordFromJson(s["last"]).inspection.error, "no part in the images");
  EXPECT_EQ(s["recent_problems"][1]["source_id"], "part-9");

  const Reply page = Get(server.Port(), "/");
  EXPECT_EQ(page.status, 200);
  EXPECT_NE(page.body.find("fetch('/api/summary')"), std::string::npos);
  for (const char* external : {"src=\"http", "href=", "src='http", "//cdn"})
    EXPECT_EQ(page.body.find(external), std::string::npos) << external;  // nothing from elsewhere
  const Reply trend = Get(server.Port(), "/api/trend.svg");
  EXPECT_EQ(trend.status, 200);
  EXPECT_EQ(trend.content_type, "image/svg+xml");
  EXPECT_NE(trend.body.find("polyline"), std::string::npos);  // 4 measured values
  const Reply mr = Get(server.Port(), "/api/moving-range.svg");
  EXPECT_EQ(mr.status, 200);
  EXPECT_EQ(mr.content_type, "image/svg+xml");
  EXPECT_NE(mr.body.find(">MRbar "), std::string::npos) << mr.body;
}

// Bad requests get their status and a reason; the records come from the store itself.
TEST(StationHttpServer, AnswersBadRequestsClearly) {
  testing::ScratchDir dir("http");
  auto store = OpenSqliteStore((dir.path() / "s.db").string(), true);
  for (int i = 1; i <= 3; ++i) {
    StationRecord r = testing::TestRecord(fmt::format("p{}", i), std::string(64, 'a' + i), 0.05);
    store->Commit(r);
  }
  StationHooks hooks;
  ReadRecordsFrom(OpenSqliteStore((dir.path() / "s.db").string(), false), hooks);
  StationHttpServer server({}, Summary("s"), hooks);
  const int port = server.Port();
  const Reply part = Get(port, "/api/parts/2");
  EXPECT_EQ(part.status, 200);
  EXPECT_EQ(nlohmann::json::parse(part.body)["source_id"], "p2");
  EXPECT_EQ(Get(port, "/api/parts/9").body, "not found: the store has no part with sequence 9\n");
  EXPECT_EQ(Get(port, "/api/parts/9").status, 404);
  const Reply malformed = Get(port, "/api/parts/x1");
  EXPECT_EQ(malformed.status, 400);
  EXPECT_EQ(malformed.body, "bad request: a part is named by its sequence number (/api/parts/17), found 'x1'\n");
  EXPECT_EQ(nlohmann::json::parse(Get(port, "/api/parts?limit=2").body).size(), 2u);
  EXPECT_EQ(nlohmann::json::parse(Get(port, "/api/parts?from=2000-01-01&to=2999-01-01").body).size(), 3u);
  EXPECT_EQ(nlohmann::json::parse(Get(port, "/api/parts?to=2000-01-01").body).size(), 0u);
  const Reply bad_time = Get(port, "/api/parts?from=yesterday");
  EXPECT_EQ(bad_time.status, 400);
  EXPECT_EQ(bad_time.body,
            "bad request: from: expected a UTC time in ISO 8601 (2026-12-04, 2026-12-04T17:03, "
            "2026-12-04T17:03:12.345Z), found 'yesterday'\n");
  EXPECT_EQ(Get(port, "/api/parts?limit=5000").body,
            "bad request: limit: expected a whole number from 1 to 1000, found '5000'\n");
  EXPECT_EQ(Get(port, "/api/parts?sort=x").status, 400);
  const Reply missing = Get(port, "/part/123");
  EXPECT_EQ(missing.status, 404);
  EXPECT_EQ(missing.body, "not found: /part/123 (the station serves /, /api/summary, /api/trend.svg, "
                          "/api/moving-range.svg, /api/parts and POST /api/recipe)\n");
  // Read-only: without a token set at start, a recipe change is refused.
  const Reply read_only = PostRecipe(port, R"({"recipe": "a"})", "guess");
  EXPECT_EQ(read_only.status, 403);
  EXPECT_EQ(read_only.body, "forbidden: this station is read-only (started without --http-token-file)\n");
}

TEST(StationHttpServer, ChangesTheRecipeOnlyWithTheToken) {
  std::atomic<int> active{0};
  StationHooks hooks;
  hooks.recipe_names = [] { return std::vector<std::string>{"shield", "cover"}; };
  hooks.set_active_recipe = [&](size_t i) { active = int(i); };
  HttpServerOptions options;
  options.token = "s3cret-token";
  StationHttpServer server(options, Summary("s"), hooks);
  const int port = server.Port();
  EXPECT_EQ(PostRecipe(port, R"({"recipe": "cover"})", "").status, 403);
  const Reply wrong = PostRecipe(port, R"({"recipe": "cover"})", "s3cret-tokem");
  EXPECT_EQ(wrong.status, 403);
  EXPECT_EQ(wrong.body, "forbidden: changing the recipe needs the station's token (Authorization: Bearer TOKEN)\n");
  EXPECT_EQ(active, 0);
  const Reply malformed = PostRecipe(port, "cover", "s3cret-token");
  EXPECT_EQ(malformed.status, 400);
  EXPECT_EQ(malformed.body, "bad request: expected a JSON body {\"recipe\": NAME}\n");
  const Reply unknown = PostRecipe(port, R"({"recipe": "lid"})", "s3cret-token");
  EXPECT_EQ(unknown.status, 404);
  EXPECT_EQ(unknown.body, "not found: no recipe 'lid' on this station (it has: shield, cover)\n");
  const Reply ok = PostRecipe(port, R"({"recipe": "cover"})", "s3cret-token");
  EXPECT_EQ(ok.status, 200);
  EXPECT_EQ(nlohmann::json::parse(ok.body)["active_recipe"], "cover");
  EXPECT_EQ(active, 1);
}

// Beyond its rate the server answers 429 at once; a second later it answers again.
TEST(StationHttpServer, RateLimitsItsClients) {
  HttpServerOptions options;
  options.max_requests_per_s = 20;
  StationHttpServer server(options, Summary("s"), {});
  httplib::Client client("127.0.0.1", server.Port());
  client.set_keep_alive(true);
  client.set_tcp_nodelay(true);
  int ok = 0, limited = 0;
  std::string limited_body;
  for (int i = 0; i < 60; ++i) {
    const auto res = client.Get("/api/summary");
    ASSERT_TRUE(res);
    if (res->status == 200) ++ok;
    if (res->status == 429) ++limited, limited_body = res->body;
  }
  EXPECT_GE(ok, 20);
  EXPECT_LE(ok, 35);  // the burst plus what refilled while the loop ran
  EXPECT_EQ(ok + limited, 60);
  EXPECT_EQ(limited_body, "too many requests: the station answers at most 20 per second\n");
  std::this_thread::sleep_for(std::chrono::milliseconds(1100));
  EXPECT_EQ(client.Get("/api/summary")->status, 200);
}

TEST(StationHttpServer, APortInUseIsNamed) {
  StationHttpServer first({}, Summary("a"), {});
  HttpServerOptions second_options;
  second_options.port = first.Port();
  EXPECT_EQ(testing::InputErrorOf([&] { StationHttpServer second(second_options, Summary("b"), {}); }),
            fmt::format("--http 127.0.0.1:{}: cannot listen there (in use, or not an address of this machine)",
                        first.Port()));
}

}  // namespace
}  // namespace flatscan
