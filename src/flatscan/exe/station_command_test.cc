// `flatscan station`, `flatscan recipe check` and `flatscan results` end to end, on
// simulated pairs and a real SQLite store (docs/station.md).
#include <csignal>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {
namespace fs = std::filesystem;
using nlohmann::json;

std::vector<json> JsonLines(const std::string& text) {
  std::vector<json> out;
  std::stringstream s(text);
  for (std::string line; std::getline(s, line);)
    if (!line.empty()) out.push_back(json::parse(line));
  return out;
}

// Three simulated parts (compact rig), a recipe for them, and a pairs file that also
// lists a corrupt PNG and a pair whose right image is missing.
class StationCommand : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::ScratchDir("station");
    const auto sim = testing::RunFlatscan("simulate --preset compact --parts 3 --no-calibration --no-markers --seed 4 -q -o " +
                                          (Dir() / "data").string());
    ASSERT_EQ(sim.exit_code, 0) << sim.err;
    std::ofstream(Dir() / "shield.yml") << "name: shield\nthickness_mm: 0.2\ntolerance_mm: 0.25\n"
                                           "rig: data/rig.yml\nplane: data/plane_true.yml\n";
    std::ofstream(Dir() / "data/parts/bad_left.png") << "\x89PNG\r\n\x1a\n this is no image";
    std::ofstream(Dir() / "good.csv") << "id,left,right\n"
                                         "p0,data/parts/part_000_left.png,data/parts/part_000_right.png\n"
                                         "p1,data/parts/part_001_left.png,data/parts/part_001_right.png\n"
                                         "p2,data/parts/part_002_left.png,data/parts/part_002_right.png\n";
    std::ofstream(Dir() / "all.csv") << testing::ReadFileBytes(Dir() / "good.csv")
                                     << "corrupt,data/parts/bad_left.png,data/parts/part_000_right.png\n"
                                        "half,data/parts/part_001_left.png,data/parts/missing_right.png\n";
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static fs::path Dir() { return dir_->path(); }
  static testing::CommandResult Station(const std::string& csv, const std::string& store, const std::string& extra = "") {
    return testing::RunFlatscan(fmt::format("station --recipe {} --source pairs:{} --store {} --station-id test-1 "
                                            "--until-idle 0.2 {}",
                                            (Dir() / "shield.yml").string(), (Dir() / csv).string(),
                                            (Dir() / store).string(), extra),
                                120);
  }
  static std::vector<json> Results(const std::string& store, const std::string& extra = "") {
    const auto r = testing::RunFlatscan(fmt::format("results --store {} --json {}", (Dir() / store).string(), extra), 60);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return JsonLines(r.out);
  }
  static testing::ScratchDir* dir_;
};
testing::ScratchDir* StationCommand::dir_ = nullptr;

TEST_F(StationCommand, RecordsEveryPairWithTheValuesOfInspect) {
  const auto run = Station("all.csv", "all.db");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const std::vector<json> records = Results("all.db");
  ASSERT_EQ(records.size(), 5u);
  const auto inspect = testing::RunFlatscan(fmt::format(
      "inspect --rig {0}/data/rig.yml --plane {0}/data/plane_true.yml --pairs {0}/good.csv --thickness 0.2 "
      "--tolerance 0.25 --json -",
      Dir().string()));
  const std::vector<json> expected = JsonLines(inspect.out);  // three records and a summary line
  ASSERT_EQ(expected.size(), 4u) << inspect.err;
  const std::vector<std::string> ids = {"p0", "p1", "p2", "corrupt", "half"};
  for (size_t i = 0; i < records.size(); ++i) {
    const json& r = records[i];
    EXPECT_EQ(r["sequence"], i + 1);
    EXPECT_EQ(r["source_id"], ids[i]);
    EXPECT_EQ(r["station_id"], "test-1");
    EXPECT_EQ(r["recipe"], "shield");
    EXPECT_EQ(r["recipe_sha256"].get<std::string>().size(), 64u);
    if (i < 3) {
      ASSERT_TRUE(r["measured"].get<bool>()) << r.dump();
      for (const char* key : {"flatness_mm", "lsq_pv_mm", "minzone_mm", "coverage", "uncertainty_mm"})
        EXPECT_NEAR(r[key].get<double>(), expected[i][key].get<double>(), 1e-9) << key;
      EXPECT_EQ(r["verdict"], expected[i]["verdict"]);
      EXPECT_EQ(r["left_sha256"].get<std::string>().size(), 64u);
    }
  }
  EXPECT_FALSE(records[3]["measured"].get<bool>());
  EXPECT_TRUE(records[3]["verdict"].is_null());
  EXPECT_NE(records[3]["error"].get<std::string>().find("bad_left.png: cannot read image"), std::string::npos)
      << records[3]["error"];
  EXPECT_EQ(records[4]["error"], (Dir() / "data/parts/missing_right.png").string() + ": no such file");
  EXPECT_EQ(records[4]["right_sha256"], "");

  // Run again: every pair is already in the store, nothing is recorded twice.
  const auto again = Station("all.csv", "all.db");
  ASSERT_EQ(again.exit_code, 0) << again.err;
  EXPECT_NE(again.err.find("0 records committed (0 pass, 0 fail, 0 not measured), 5 already recorded"),
            std::string::npos)
      << again.err;
  EXPECT_EQ(Results("all.db").size(), 5u);
  const json status = json::parse(testing::ReadFileBytes(Dir() / "all.status.json"));
  EXPECT_EQ(status["state"], "stopped");
  EXPECT_EQ(status["already_recorded"], 5);
  EXPECT_NE(testing::ReadFileBytes(Dir() / "all.log").find("#5 half: not measured"), std::string::npos);
}

TEST_F(StationCommand, ResultsAsCsvAndByTime) {
  ASSERT_EQ(Station("good.csv", "csv.db").exit_code, 0);
  const auto csv = testing::RunFlatscan("results --store " + (Dir() / "csv.db").string() + " --csv");
  ASSERT_EQ(csv.exit_code, 0) << csv.err;
  std::stringstream lines(csv.out);
  std::string header, first;
  std::getline(lines, header);
  std::getline(lines, first);
  EXPECT_EQ(header,
            "sequence,time_utc,source_id,recipe,measured,verdict,marginal,flatness_mm,lsq_pv_mm,minzone_mm,"
            "uncertainty_mm,coverage,error,station_id,record_id,recipe_sha256,left_sha256,right_sha256,software_version");
  EXPECT_EQ(first.substr(0, 2), "1,");
  EXPECT_NE(first.find(",p0,shield,true,"), std::string::npos) << first;

  const std::vector<json> all = Results("csv.db");
  ASSERT_EQ(all.size(), 3u);
  const std::string t2 = all[1]["time_utc"];
  EXPECT_EQ(Results("csv.db", "--from " + t2).front()["sequence"], all[1]["sequence"]);
  EXPECT_TRUE(Results("csv.db", "--to 2000-01-01").empty());
  const fs::path out = Dir() / "out.csv";
  ASSERT_EQ(testing::RunFlatscan("results --store " + (Dir() / "csv.db").string() + " --csv " + out.string()).exit_code, 0);
  EXPECT_EQ(testing::ReadFileBytes(out), csv.out);

  const auto bad = testing::RunFlatscan("results --store " + (Dir() / "csv.db").string() + " --from yesterday");
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("--from: expected a UTC time in ISO 8601"), std::string::npos) << bad.err;
  const auto none = testing::RunFlatscan("results --store " + (Dir() / "none.db").string());
  EXPECT_EQ(none.exit_code, 2);
  EXPECT_NE(none.err.find((Dir() / "none.db").string() + "': no such results store"), std::string::npos) << none.err;
  EXPECT_FALSE(fs::exists(Dir() / "none.db"));
}

TEST_F(StationCommand, RecipeCheckAndBadInput) {
  const auto check = testing::RunFlatscan("recipe check " + (Dir() / "shield.yml").string());
  ASSERT_EQ(check.exit_code, 0) << check.err;
  EXPECT_NE(check.out.find("judges: fail when flatness > 0.2500 mm"), std::string::npos) << check.out;

  std::ofstream(Dir() / "bad.yml") << "name: shield\nthickness_mm: 0.2\nrig: data/rig.yml\nplane: data/plane_true.yml\n";
  const auto bad = testing::RunFlatscan("recipe check " + (Dir() / "bad.yml").string());
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find((Dir() / "bad.yml").string() + ": tolerance_mm: expected a number, found nothing"),
            std::string::npos)
      << bad.err;
  const auto station = testing::RunFlatscan(fmt::format("station --recipe {0}/bad.yml --source pairs:{0}/good.csv "
                                                        "--store {0}/bad.db --until-idle 0",
                                                        Dir().string()));
  EXPECT_EQ(station.exit_code, 2);
  EXPECT_FALSE(fs::exists(Dir() / "bad.db"));  // nothing created before the inputs are good

  const auto source = testing::RunFlatscan(fmt::format(
      "station --recipe {0}/shield.yml --source camera:0 --store {0}/s.db --until-idle 0", Dir().string()));
  EXPECT_EQ(source.exit_code, 2);
  EXPECT_NE(source.err.find("--source 'camera:0': expected pairs:FILE.csv"), std::string::npos) << source.err;
  EXPECT_FALSE(fs::exists(Dir() / "s.db"));
  const auto store_is_folder = testing::RunFlatscan(fmt::format(
      "station --recipe {0}/shield.yml --source pairs:{0}/good.csv --store {0}/data --until-idle 0", Dir().string()));
  EXPECT_EQ(store_is_folder.exit_code, 2);
  EXPECT_NE(store_is_folder.err.find("--store: " + (Dir() / "data").string() + ": cannot open the results store"),
            std::string::npos)
      << store_is_folder.err;
}

// SIGTERM: the station stops taking pairs, records those in flight and exits 0.
TEST_F(StationCommand, StopsGracefullyOnSigterm) {
  const fs::path store = Dir() / "term.db", status = Dir() / "term.status.json";
  testing::BackgroundFlatscan station({"station", "--recipe", (Dir() / "shield.yml").string(), "--source",
                                       "pairs:" + (Dir() / "good.csv").string(), "--store", store.string()},
                                      Dir() / "term.log.txt");
  ASSERT_TRUE(station.started());
  const auto committed = [&] {
    if (!fs::exists(status)) return -1;
    const json j = json::parse(testing::ReadFileBytes(status), nullptr, false);
    return j.is_discarded() ? -1 : j["committed"].get<int>();
  };
  ASSERT_TRUE(testing::WaitFor([&] { return committed() == 3; }, 60)) << testing::ReadFileBytes(Dir() / "term.log.txt");
  station.Signal(SIGTERM);
  EXPECT_EQ(station.Wait(30), 0) << testing::ReadFileBytes(Dir() / "term.log.txt");
  EXPECT_EQ(json::parse(testing::ReadFileBytes(status))["state"], "stopped");
  EXPECT_EQ(Results("term.db").size(), 3u);
}

}  // namespace
}  // namespace flatscan
