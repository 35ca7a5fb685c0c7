// `flatscan station`, `flatscan recipe check` and `flatscan results` end to end, on
// simulated pairs and a real SQLite store (docs/station.md).
#include <csignal>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <modbus/modbus.h>
#include <sqlite3.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "flatscan/io/image_io.h"
#include "flatscan/outputs/mqtt_test_util.h"
#include "flatscan/store/postgres_test_util.h"
#include "flatscan/util/sha256.h"
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

// Copies part `k` of the simulated data into `folder` as pair `id` (write, then rename).
void DeliverPair(const fs::path& data, int k, const fs::path& folder, const std::string& id) {
  for (const char* side : {"left", "right"}) {
    const fs::path tmp = folder / fmt::format(".{}_{}.png.tmp", id, side);
    fs::copy_file(data / fmt::format("parts/part_{:03d}_{}.png", k, side), tmp, fs::copy_options::overwrite_existing);
    fs::rename(tmp, folder / fmt::format("{}_{}.png", id, side));
  }
}

// The station's `committed` count from its status file (-1 before there is one).
int Committed(const fs::path& status) {
  if (!fs::exists(status)) return -1;
  const json j = json::parse(testing::ReadFileBytes(status), nullptr, false);
  return j.is_discarded() ? -1 : j["committed"].get<int>();
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

// The whole camera path: two Aravis fake cameras show the dataset's pairs, one per
// trigger; the station measures the frames where the cameras put them, to the values of
// the same pairs read from their files.
TEST_F(StationCommand, FakeCamerasMeasureTheDatasetAsItsFilesDo) {
  const std::string data = (Dir() / "data").string();
  const auto files = Station("data/pairs.csv", "files.db");
  ASSERT_EQ(files.exit_code, 0) << files.err;
  for (const char* trigger : {"", "--trigger-rate 20"}) {  // on demand, then at a rate
    const std::string store = fmt::format("fake{}.db", std::string(trigger).size());
    const auto cams = testing::RunFlatscan(
        fmt::format("station --recipe {0}/shield.yml --source aravis-fake:{1} --store {0}/{2} --station-id test-1 "
                    "--until-idle 1 --archive {0}/fake_archive {3}",
                    Dir().string(), data, store, trigger),
        120);
    ASSERT_EQ(cams.exit_code, 0) << cams.err;
    const std::vector<json> expected = Results("files.db"), got = Results(store);
    ASSERT_EQ(got.size(), 3u) << trigger;  // a record per trigger, the dataset's three
    for (size_t i = 0; i < got.size(); ++i) {
      EXPECT_EQ(got[i]["source_id"], expected[i]["source_id"]);
      ASSERT_TRUE(got[i]["measured"].get<bool>()) << got[i].dump();
      for (const char* key : {"flatness_mm", "lsq_pv_mm", "minzone_mm", "coverage", "uncertainty_mm"})
        EXPECT_EQ(got[i][key].get<double>(), expected[i][key].get<double>()) << key;
      EXPECT_EQ(got[i]["verdict"], expected[i]["verdict"]);
      // A frame's hash is that of its pixels.
      const cv::Mat1b left = ReadGreyImage((Dir() / "data" / fmt::format("parts/part_{:03d}_left.png", i)).string());
      EXPECT_EQ(got[i]["left_sha256"], Sha256Hex(left.data, left.total())) << i;
    }
  }
  // The first pass was archived: its PNG holds the frame's pixels.
  const auto archived = Results("fake0.db")[0]["archive"]["left"].get<std::string>();
  const cv::Mat1b kept = ReadGreyImage(archived), shown = ReadGreyImage((Dir() / "data/parts/part_000_left.png").string());
  EXPECT_EQ(cv::norm(kept, shown, cv::NORM_INF), 0);
}

// The recipe's camera settings are set when the cameras start: settings the cameras
// refuse stop the station before it takes a pair (exit 2, the camera and the value named).
TEST_F(StationCommand, CameraSettingsTheCamerasRefuseAreBadInput) {
  std::ofstream(Dir() / "too_much_gain.yml") << "name: shield\nthickness_mm: 0.2\ntolerance_mm: 0.25\n"
                                                "rig: data/rig.yml\nplane: data/plane_true.yml\n"
                                                "camera:\n  exposure_us: 900\n  gain_db: 40\n";
  const auto r = testing::RunFlatscan(
      fmt::format("station --recipe {0}/too_much_gain.yml --source aravis-fake:{0}/data --store {0}/gain.db "
                  "--until-idle 0.2",
                  Dir().string()),
      60);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("error: camera Aravis Fake (FAKE-LEFT): cannot set the gain to 40 dB: "), std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(Dir() / "gain.db"));
}

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

  // Run again (quiet): every pair is already in the store, nothing is recorded twice; the
  // log file still has every line, stderr none of the info lines.
  const auto again = Station("all.csv", "all.db", "-q");
  ASSERT_EQ(again.exit_code, 0) << again.err;
  EXPECT_EQ(again.err, "");
  const std::string log = testing::ReadFileBytes(Dir() / "all.log");
  EXPECT_NE(log.find("5 pairs taken, 0 records committed (0 pass, 0 fail, 0 not measured), 5 already recorded"),
            std::string::npos)
      << log;
  EXPECT_NE(log.find(" info: #1 p0: "), std::string::npos) << log;
  EXPECT_EQ(Results("all.db").size(), 5u);
  const json status = json::parse(testing::ReadFileBytes(Dir() / "all.status.json"));
  EXPECT_EQ(status["state"], "stopped");
  EXPECT_EQ(status["already_recorded"], 5);
  EXPECT_NE(log.find(" warning: #5 half: not measured"), std::string::npos);
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
  EXPECT_NE(source.err.find("--source 'camera:0': expected folder:DIR (a folder to watch), pairs:FILE.csv"),
            std::string::npos)
      << source.err;
  EXPECT_FALSE(fs::exists(Dir() / "s.db"));
  const auto store_is_folder = testing::RunFlatscan(fmt::format(
      "station --recipe {0}/shield.yml --source pairs:{0}/good.csv --store {0}/data --until-idle 0", Dir().string()));
  EXPECT_EQ(store_is_folder.exit_code, 2);
  EXPECT_NE(store_is_folder.err.find("--store: " + (Dir() / "data").string() + ": cannot open the results store"),
            std::string::npos)
      << store_is_folder.err;
}

// SIGTERM while pairs are being measured: the station stops taking pairs, records those
// in flight and exits 0.
TEST_F(StationCommand, StopsGracefullyOnSigterm) {
  const fs::path store = Dir() / "term.db", status = Dir() / "term.status.json", csv = Dir() / "many.csv";
  constexpr int kPairs = 300;
  {
    std::ofstream out(csv);
    out << "id,left,right\n";
    for (int i = 0; i < kPairs; ++i)
      out << fmt::format("t{0:03d},data/parts/part_00{1}_left.png,data/parts/part_00{1}_right.png\n", i, i % 3);
  }
  testing::BackgroundFlatscan station({"station", "--recipe", (Dir() / "shield.yml").string(), "--source",
                                       "pairs:" + csv.string(), "--store", store.string()},
                                      Dir() / "term.log.txt");
  ASSERT_TRUE(station.started());
  ASSERT_TRUE(testing::WaitFor([&] { return Committed(status) >= 1; }, 60))
      << testing::ReadFileBytes(Dir() / "term.log.txt");
  station.Signal(SIGTERM);
  EXPECT_EQ(station.Wait(30), 0) << testing::ReadFileBytes(Dir() / "term.log.txt");
  const json last = json::parse(testing::ReadFileBytes(status));
  EXPECT_EQ(last["state"], "stopped");
  const std::vector<json> records = Results("term.db");
  EXPECT_LT(records.size(), size_t(kPairs)) << "it did not stop early";
  // Every pair it took is recorded: the input stage's count against the store's.
  const std::string log = testing::ReadFileBytes(Dir() / "term.log");
  EXPECT_NE(log.find(fmt::format("stopped; {0} pairs taken, {0} records committed", records.size())),
            std::string::npos)
      << log;
  for (size_t i = 0; i < records.size(); ++i) {
    EXPECT_EQ(records[i]["source_id"], fmt::format("t{:03d}", i));
    EXPECT_TRUE(records[i]["measured"].get<bool>());
  }
}

// A store that cannot be written (here: locked by another process for longer than the
// station waits, 10 s): the station stops with exit 2 and says why; it does not hang.
TEST_F(StationCommand, AStoreThatCannotBeWrittenStopsTheStation) {
  const fs::path in = Dir() / "locked_in", store = Dir() / "locked.db", status = Dir() / "locked.status.json";
  fs::create_directories(in);
  testing::BackgroundFlatscan station({"station", "--recipe", (Dir() / "shield.yml").string(), "--source",
                                       "folder:" + in.string(), "--store", store.string()},
                                      Dir() / "locked.log.txt");
  ASSERT_TRUE(testing::WaitFor([&] { return Committed(status) == 0; }, 30));
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(store.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, "BEGIN EXCLUSIVE", nullptr, nullptr, nullptr), SQLITE_OK);
  DeliverPair(Dir() / "data", 0, in, "x0");
  const int exit_code = station.Wait(60);
  sqlite3_exec(db, "ROLLBACK", nullptr, nullptr, nullptr);
  sqlite3_close(db);
  const std::string log = testing::ReadFileBytes(Dir() / "locked.log.txt");
  EXPECT_EQ(exit_code, 2) << log;
  EXPECT_NE(log.find("the station stops: it cannot record (" + store.string() + ": cannot start a transaction "
                     "(database is locked))"),
            std::string::npos)
      << log;
  EXPECT_EQ(json::parse(testing::ReadFileBytes(status))["state"], "failed");
  EXPECT_TRUE(fs::exists(in / "x0_left.png"));  // not recorded, so not moved: taken again after a restart
}

// A live folder: pairs delivered while the station runs, a half pair, a corrupt image.
TEST_F(StationCommand, WatchesAFolder) {
  const fs::path in = Dir() / "live", store = Dir() / "live.db", status = Dir() / "live.status.json";
  fs::create_directories(in);
  testing::BackgroundFlatscan station({"station", "--recipe", (Dir() / "shield.yml").string(), "--source",
                                       "folder:" + in.string(), "--store", store.string(), "--half-pair-timeout", "0.5",
                                       "--archive", (Dir() / "archive").string()},
                                      Dir() / "live.log.txt");
  ASSERT_TRUE(station.started());
  ASSERT_TRUE(testing::WaitFor([&] { return Committed(status) == 0; }, 30));  // running and watching
  DeliverPair(Dir() / "data", 0, in, "w0");
  DeliverPair(Dir() / "data", 1, in, "w1");
  fs::copy_file(Dir() / "data/parts/part_002_left.png", in / "lonely_left.png");
  fs::copy_file(Dir() / "data/parts/bad_left.png", in / "broken_left.png");
  fs::copy_file(Dir() / "data/parts/part_000_right.png", in / "broken_right.png");
  ASSERT_TRUE(testing::WaitFor([&] { return Committed(status) == 4; }, 60))
      << testing::ReadFileBytes(Dir() / "live.log.txt");
  station.Signal(SIGTERM);
  ASSERT_EQ(station.Wait(30), 0) << testing::ReadFileBytes(Dir() / "live.log.txt");
  std::map<std::string, json> by_id;
  for (const json& r : Results("live.db")) by_id[r["source_id"]] = r;
  ASSERT_EQ(by_id.size(), 4u);
  EXPECT_TRUE(by_id["w0"]["measured"].get<bool>());
  EXPECT_TRUE(by_id["w1"]["measured"].get<bool>());
  EXPECT_EQ(by_id["lonely"]["error"], "half pair: the right image " + (in / "lonely_right.png").string() +
                                          " did not arrive within 0.5 s of the left image " +
                                          (in / "lonely_left.png").string());
  EXPECT_NE(by_id["broken"]["error"].get<std::string>().find("broken_left.png: cannot read image"), std::string::npos);
  // The archive (default policy: every fail and not-measured pair, the first pass pair)
  // holds the very bytes each record hashed.
  for (const auto& [id, r] : by_id) {
    const bool must = !r["measured"].get<bool>() || r["verdict"] == "fail" || id == "w0";
    ASSERT_EQ(r["archive"].is_object(), must) << id << ": " << r["archive"];
    if (!must) continue;
    EXPECT_EQ(Sha256HexOfFile(r["archive"]["left"].get<std::string>()), r["left_sha256"]) << id;
    if (id != "lonely") {
      EXPECT_EQ(Sha256HexOfFile(r["archive"]["right"].get<std::string>()), r["right_sha256"]) << id;
    }
  }
  EXPECT_EQ(by_id["lonely"]["archive"]["right"], "");
  // A measured part's thumbnail beside its images (a JPEG cropped to the part); none where
  // no image was decoded. The report shows it, embedded.
  const cv::Mat thumbnail = cv::imread(by_id["w0"]["archive"]["thumbnail"].get<std::string>(), cv::IMREAD_COLOR);
  EXPECT_TRUE((thumbnail.cols == 480 && thumbnail.rows <= 360) || (thumbnail.rows == 360 && thumbnail.cols <= 480))
      << thumbnail.size();  // 480 wide or 360 high
  EXPECT_FALSE(by_id["lonely"]["archive"].contains("thumbnail"));
  EXPECT_FALSE(by_id["broken"]["archive"].contains("thumbnail"));
  const fs::path html = Dir() / "live-report.html";
  const auto report = testing::RunFlatscan(fmt::format("report --store {} -o {}", store.string(), html.string()), 60);
  ASSERT_EQ(report.exit_code, 0) << report.err;
  const std::string page = testing::ReadFileBytes(html);
  size_t embedded = 0;
  for (size_t at = page.find("src=\"data:image/jpeg;base64,/9j/"); at != std::string::npos;
       at = page.find("src=\"data:image/jpeg;base64,/9j/", at + 1))
    ++embedded;
  size_t with_thumbnail = 0;
  for (const auto& [id, r] : by_id) with_thumbnail += r["archive"].is_object() && r["archive"].contains("thumbnail");
  EXPECT_EQ(embedded, with_thumbnail);  // the worst parts' (all measured ones here)
  for (const char* file : {"w0_left.png", "w1_right.png", "lonely_left.png", "broken_right.png"}) {
    EXPECT_TRUE(fs::exists(in / "done" / file)) << file;
    EXPECT_FALSE(fs::exists(in / file)) << file;
  }
}

// kill -9 at any moment, then restart: no pair lost, none recorded twice, sequence
// numbers continue.
TEST_F(StationCommand, KillNineLosesNothingAndRecordsNothingTwice) {
  const fs::path in = Dir() / "incoming", store = Dir() / "kill.db", status = Dir() / "kill.status.json";
  fs::create_directories(in);
  constexpr int kPairs = 12;
  for (int i = 0; i < kPairs; ++i) DeliverPair(Dir() / "data", i % 3, in, fmt::format("k{:02d}", i));
  const std::vector<std::string> args = {"station", "--recipe", (Dir() / "shield.yml").string(), "--source",
                                         "folder:" + in.string(), "--store", store.string()};
  std::mt19937 rng(14);
  for (int kill = 0; kill < 3; ++kill) {
    fs::remove(status);
    testing::BackgroundFlatscan station(args, Dir() / "kill.log.txt");
    ASSERT_TRUE(station.started());
    // Killed once it has committed a record or two in this run, plus 0-40 ms (fixed
    // seed): wherever it then is (measuring, committing, moving files).
    ASSERT_TRUE(testing::WaitFor([&] { return Committed(status) >= 1 + kill % 2; }, 60))
        << testing::ReadFileBytes(Dir() / "kill.log.txt");
    std::this_thread::sleep_for(std::chrono::milliseconds(std::uniform_int_distribution<int>(0, 40)(rng)));
    station.Signal(SIGKILL);
    ASSERT_EQ(station.Wait(30), 128 + SIGKILL);
  }
  std::vector<std::string> last = args;
  last.insert(last.end(), {"--until-idle", "1"});
  testing::BackgroundFlatscan station(last, Dir() / "kill.log.txt");
  ASSERT_EQ(station.Wait(120), 0) << testing::ReadFileBytes(Dir() / "kill.log.txt");

  const std::vector<json> records = Results("kill.db");
  std::set<std::string> ids;
  for (size_t i = 0; i < records.size(); ++i) {
    EXPECT_EQ(records[i]["sequence"], i + 1);
    EXPECT_TRUE(records[i]["measured"].get<bool>()) << records[i]["error"];
    ids.insert(records[i]["source_id"].get<std::string>());
  }
  EXPECT_EQ(records.size(), size_t(kPairs));
  EXPECT_EQ(ids.size(), size_t(kPairs));
  for (const auto& entry : fs::directory_iterator(in))
    EXPECT_FALSE(entry.is_regular_file()) << entry.path() << " was left in the folder";
}

}  // namespace
}  // namespace flatscan

namespace flatscan {
namespace {

// --mqtt: every record of a station run reaches a subscriber of a real broker, the
// retained state ends "stopped", and the password is in no log, record or status file.
TEST_F(StationCommand, PublishesEveryRecordToMqtt) {
  const int port = testing::FreeLoopbackPort();
  const fs::path broker_dir = Dir() / "broker";
  fs::create_directories(broker_dir);
  testing::Broker broker(broker_dir, port);
  ASSERT_TRUE(broker.Start());
  testing::Subscriber subscriber(port, "test-1");
  ASSERT_TRUE(testing::WaitFor([&] { return subscriber.Subscribed(); }, 10));
  std::ofstream(Dir() / "mqtt.password") << "s3cret-pw\n";
  const auto run = Station("all.csv", "mqtt.db",
                           fmt::format("--mqtt 127.0.0.1:{} --mqtt-user line --mqtt-password-file {}", port,
                                       (Dir() / "mqtt.password").string()));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  ASSERT_TRUE(testing::WaitFor([&] { return subscriber.Sequences().size() >= 5; }, 10));
  EXPECT_EQ(subscriber.Sequences(), (std::vector<int64_t>{1, 2, 3, 4, 5}));
  ASSERT_TRUE(testing::WaitFor([&] { return !subscriber.States().empty() && subscriber.States().back() == "stopped"; }, 10));
  EXPECT_EQ(json::parse(testing::ReadFileBytes(Dir() / "mqtt.mqtt.json"))["acked_through"], 5);
  for (const char* file : {"mqtt.db", "mqtt.db-wal", "mqtt.log", "mqtt.status.json", "mqtt.mqtt.json"}) {
    if (fs::exists(Dir() / file)) {
      EXPECT_EQ(testing::ReadFileBytes(Dir() / file).find("s3cret-pw"), std::string::npos) << file;
    }
  }
  EXPECT_EQ(run.err.find("s3cret-pw"), std::string::npos);

  const auto bad = Station("good.csv", "mqtt-bad.db", "--mqtt localhost");
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("--mqtt 'localhost': expected HOST:PORT (a host name or address, a port 1-65535)"),
            std::string::npos)
      << bad.err;
  const auto lone = Station("good.csv", "mqtt-bad.db", "--mqtt-user line");
  EXPECT_EQ(lone.exit_code, 2);
  EXPECT_NE(lone.err.find("--mqtt-user, --mqtt-password-file and --mqtt-tls-ca need --mqtt HOST:PORT"),
            std::string::npos)
      << lone.err;
}

}  // namespace
}  // namespace flatscan

namespace flatscan {
namespace {

// --modbus: a libmodbus client playing the PLC reads and acknowledges every verdict of a
// station run (the pairs file: 3 measured pairs, 2 not measured).
TEST_F(StationCommand, ServesEveryVerdictToAPlcOverModbus) {
  const int port = testing::FreeLoopbackPort();
  testing::CommandResult run;
  std::thread station([&] {
    run = testing::RunFlatscan(fmt::format("station --recipe {} --source pairs:{} --store {} --modbus {} --until-idle 3",
                                           (Dir() / "shield.yml").string(), (Dir() / "all.csv").string(),
                                           (Dir() / "modbus.db").string(), port),
                               120);
  });
  modbus_t* plc = modbus_new_tcp("127.0.0.1", port);
  std::vector<std::pair<int, int>> seen;  // (sequence, outcome)
  testing::WaitFor(
      [&] {
        uint16_t r[12] = {};
        if (modbus_read_registers(plc, 0, 12, r) != 12) {
          modbus_close(plc);
          modbus_connect(plc);  // not listening yet, or dropped: again
          return false;
        }
        if (r[9] > 0) {  // pending: read the shown result, acknowledge it
          seen.emplace_back(r[5], r[6]);
          modbus_write_register(plc, 10, r[5]);
        }
        return seen.size() >= 5;
      },
      60);
  modbus_close(plc);
  modbus_free(plc);
  station.join();
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const std::vector<json> records = Results("modbus.db");
  ASSERT_EQ(seen.size(), records.size());
  for (size_t i = 0; i < seen.size(); ++i) {
    EXPECT_EQ(seen[i].first, records[i]["sequence"].get<int>());
    const bool measured = records[i]["measured"].get<bool>();
    const int expected = !measured ? 5 : records[i]["verdict"] == "pass" ? (records[i]["marginal"].get<bool>() ? 3 : 1)
                                                                         : (records[i]["marginal"].get<bool>() ? 4 : 2);
    EXPECT_EQ(seen[i].second, expected) << i;
  }
  const auto bad = Station("good.csv", "modbus-bad.db", "--modbus 127.0.0.1:0x50");
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("--modbus '127.0.0.1:0x50': expected HOST:PORT"), std::string::npos) << bad.err;
}

// --trigger software: the PLC starts each part (register 12). Nothing is measured before a
// trigger; after each, the first read shows busy or already the new result, never a
// ready station with nothing to show; then the PLC reads and acknowledges the result.
TEST_F(StationCommand, ATriggeredStationMeasuresOnePairPerPlcTrigger) {
  const int port = testing::FreeLoopbackPort();
  testing::CommandResult run;
  std::thread station([&] {
    run = testing::RunFlatscan(
        fmt::format("station --recipe {} --source pairs:{} --store {} --modbus {} --trigger software --until-idle 4",
                    (Dir() / "shield.yml").string(), (Dir() / "all.csv").string(), (Dir() / "trigger.db").string(),
                    port),
        120);
  });
  modbus_t* plc = modbus_new_tcp("127.0.0.1", port);
  uint16_t r[13] = {};
  const auto read = [&] { return modbus_read_registers(plc, 0, 13, r) == 13; };
  ASSERT_TRUE(testing::WaitFor(
      [&] {
        if (read()) return true;
        modbus_close(plc);
        modbus_connect(plc);  // not listening yet: again
        return false;
      },
      30));
  std::this_thread::sleep_for(std::chrono::seconds(1));
  ASSERT_TRUE(read());
  EXPECT_EQ(r[9], 0) << "measured without a trigger";
  std::vector<int> sequences;
  for (int part = 1; part <= 5; ++part) {
    // Gauge-study tags for this part (registers 13-15): part 7 three times, then part 8.
    const uint16_t tags[3] = {static_cast<uint16_t>(part <= 3 ? 7 : 8), 0, static_cast<uint16_t>(part <= 3 ? part : part - 3)};
    ASSERT_EQ(modbus_write_registers(plc, 13, 3, tags), 3);
    ASSERT_EQ(modbus_write_register(plc, 12, 1), 1);
    ASSERT_TRUE(read());
    EXPECT_TRUE(r[1] == 2 || r[9] > 0) << "part " << part << ": state " << r[1] << ", pending " << r[9];
    ASSERT_TRUE(testing::WaitFor([&] { return read() && r[9] > 0; }, 30)) << "part " << part;
    sequences.push_back(r[5]);
    EXPECT_EQ(r[9], 1);  // one trigger, one result
    modbus_write_register(plc, 10, r[5]);
  }
  modbus_close(plc);
  modbus_free(plc);
  station.join();
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(sequences, (std::vector<int>{1, 2, 3, 4, 5}));
  const std::vector<json> records = Results("trigger.db");
  ASSERT_EQ(records.size(), 5u);
  const char* expected[5][2] = {{"7", "1"}, {"7", "2"}, {"7", "3"}, {"8", "1"}, {"8", "2"}};
  for (size_t i = 0; i < records.size(); ++i)
    EXPECT_EQ(records[i]["study"], (json{{"part", expected[i][0]}, {"appraiser", ""}, {"trial", expected[i][1]}})) << i;
  const auto lone = Station("good.csv", "trigger-bad.db", "--trigger software");
  EXPECT_EQ(lone.exit_code, 2);
  EXPECT_NE(lone.err.find("--trigger software needs --modbus (the PLC triggers there)"), std::string::npos) << lone.err;
}

}  // namespace
}  // namespace flatscan

namespace flatscan {
namespace {

// --plant-store: the station forwards every record to a real PostgreSQL server, and
// `flatscan results` reads the plant store as it reads the station's own.
TEST_F(StationCommand, ForwardsEveryRecordToThePlantStore) {
  testing::PostgresCluster cluster("plant-s3cret");
  ASSERT_TRUE(cluster.initialized()) << cluster.Log();
  ASSERT_TRUE(cluster.Start()) << cluster.Log();
  const auto run = Station("all.csv", "plant.db", "--plant-store '" + cluster.Uri() + "'");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const std::vector<json> local = Results("plant.db");
  ASSERT_EQ(local.size(), 5u);
  const auto plant = testing::RunFlatscan("results --json --store '" + cluster.Uri() + "'", 60);
  ASSERT_EQ(plant.exit_code, 0) << plant.err;
  EXPECT_EQ(JsonLines(plant.out), local);  // every record once, every key
  for (const char* file : {"plant.db", "plant.db-wal", "plant.log", "plant.status.json"}) {
    if (fs::exists(Dir() / file)) {
      EXPECT_EQ(testing::ReadFileBytes(Dir() / file).find("plant-s3cret"), std::string::npos) << file;
    }
  }
  EXPECT_EQ(run.err.find("plant-s3cret"), std::string::npos) << run.err;

  const auto down = testing::RunFlatscan("results --json --store 'postgresql://flatscan:plant-s3cret@127.0.0.1:1/x'", 60);
  EXPECT_EQ(down.exit_code, 2);
  EXPECT_NE(down.err.find("--store: postgresql://flatscan@127.0.0.1:1/x: cannot connect to the plant store"),
            std::string::npos)
      << down.err;
  EXPECT_EQ(down.err.find("plant-s3cret"), std::string::npos) << down.err;
  const auto bad = Station("good.csv", "plant-bad.db", "--plant-store 'host=db password=plant-s3cret'");
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("--plant-store: expected a PostgreSQL URI (postgresql://user@host:port/dbname)"),
            std::string::npos)
      << bad.err;
  EXPECT_EQ(bad.err.find("plant-s3cret"), std::string::npos) << bad.err;
}

}  // namespace
}  // namespace flatscan

namespace flatscan {
namespace {

// The page in Chromium (headless; virtual time lets its first poll of /api/summary finish)
// as the DOM it built; with `screenshot`, also a PNG of it.
std::string BrowserDom(int port, const fs::path& out, const std::string& screenshot = "") {
  const std::string common = fmt::format(
      "timeout 90 chromium --headless --no-sandbox --disable-gpu --hide-scrollbars --virtual-time-budget=2500 "
      "--window-size=1100,900 --user-data-dir={} ",
      (out.parent_path() / "chromium-profile").string());
  const std::string url = fmt::format("http://127.0.0.1:{}/", port);
  if (!screenshot.empty()) {
    EXPECT_EQ(std::system((common + "--screenshot=" + screenshot + " " + url + " >/dev/null 2>&1").c_str()), 0);
  }
  EXPECT_EQ(std::system((common + "--dump-dom " + url + " >" + out.string() + " 2>/dev/null").c_str()), 0);
  return testing::ReadFileBytes(out);
}

// measured, pass, fail, marginal, not measured: the page's "whole store" row.
std::vector<int> StoreRow(const std::string& dom) {
  static const std::regex row(
      R"re(<tr id="c-store"><th>whole store</th><td>(\d+)</td><td>(\d+)</td><td>(\d+)</td><td>(\d+)</td><td>(\d+)</td>)re");
  std::smatch m;
  if (!std::regex_search(dom, m, row)) return {};
  return {std::stoi(m[1]), std::stoi(m[2]), std::stoi(m[3]), std::stoi(m[4]), std::stoi(m[5])};
}

std::vector<int> CountsOf(const std::vector<json>& records) {
  std::vector<int> c(5, 0);
  for (const json& r : records) {
    if (!r["measured"].get<bool>()) {
      ++c[4];
      continue;
    }
    ++c[0];
    ++c[r["verdict"] == "pass" ? 1 : 2];
    c[3] += r["marginal"].get<bool>();
  }
  return c;
}

// --http in a real browser: the page of a station watching a folder shows the store's
// counts and the last verdict, and follows when the next part arrives. With
// FLATSCAN_SCREENSHOTS=DIR the test leaves its screenshot there (docs/images/).
TEST_F(StationCommand, ItsWebPageInABrowserShowsTheStore) {
  const fs::path in = Dir() / "web_in", store = Dir() / "web.db", status = Dir() / "web.status.json";
  fs::create_directories(in);
  const int port = testing::FreeLoopbackPort();
  testing::BackgroundFlatscan station({"station", "--recipe", (Dir() / "shield.yml").string(), "--source",
                                       "folder:" + in.string(), "--store", store.string(), "--http",
                                       std::to_string(port), "--station-id", "line-7"},
                                      Dir() / "web.log.txt");
  ASSERT_TRUE(station.started());
  ASSERT_TRUE(testing::WaitFor([&] { return Committed(status) == 0 && testing::LoopbackPortAccepts(port); }, 30));
  DeliverPair(Dir() / "data", 0, in, "w0");
  ASSERT_TRUE(testing::WaitFor([&] { return Committed(status) == 1; }, 60)) << testing::ReadFileBytes(Dir() / "web.log.txt");
  std::string dom = BrowserDom(port, Dir() / "web1.html");
  std::vector<json> records = Results("web.db");
  EXPECT_EQ(StoreRow(dom), CountsOf(records)) << dom;
  EXPECT_NE(dom.find("flatscan station line-7"), std::string::npos);
  EXPECT_NE(dom.find(fmt::format("<div id=\"verdict\" class=\"{}\">{}", records[0]["verdict"].get<std::string>(),
                                 records[0]["verdict"] == "pass" ? "PASS" : "FAIL")),
            std::string::npos)
      << dom;

  DeliverPair(Dir() / "data", 1, in, "w1");  // the page follows
  ASSERT_TRUE(testing::WaitFor([&] { return Committed(status) == 2; }, 60));
  const char* shots = std::getenv("FLATSCAN_SCREENSHOTS");
  dom = BrowserDom(port, Dir() / "web2.html", shots ? (fs::path(shots) / "station-page.png").string() : "");
  records = Results("web.db");
  EXPECT_EQ(StoreRow(dom), CountsOf(records)) << dom;
  EXPECT_NE(dom.find("#2 w1 at " + records[1]["time_utc"].get<std::string>()), std::string::npos) << dom;
  // The last part's thumbnail, loaded (shown) from the station.
  std::smatch overlay;
  ASSERT_TRUE(std::regex_search(dom, overlay, std::regex(R"(<img id="overlay"[^>]*>)"))) << dom;
  EXPECT_NE(overlay.str().find("src=\"/api/parts/2/image.jpg\""), std::string::npos) << overlay.str();
  EXPECT_EQ(overlay.str().find("display: none"), std::string::npos) << overlay.str();
  station.Signal(SIGTERM);
  EXPECT_EQ(station.Wait(30), 0) << testing::ReadFileBytes(Dir() / "web.log.txt");
}

}  // namespace
}  // namespace flatscan
