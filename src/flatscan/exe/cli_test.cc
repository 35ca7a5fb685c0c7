// End-to-end tests of the flatscan binary: exit codes, messages, and outputs.
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <fstream>
#include <thread>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {

using testing::RunFlatscan;
using testing::ScratchDir;

// A reduced-resolution scene (same optics geometry as the paper rig) so that
// end-to-end runs take well under a second.
std::filesystem::path WriteSmallScene(const std::filesystem::path& dir, const std::string& extra = "") {
  const auto path = dir / "small.yml";
  std::ofstream(path) << "camera:\n  width: 960\n  height: 720\n  pixel_size_um: 6.0\n"
                         "board:\n  poses: 2\n"
                         "dataset:\n  parts: 2\n"
                      << extra;
  return path;
}

bool NothingNamedLike(const std::filesystem::path& dir, const std::string& stem) {
  for (const auto& entry : std::filesystem::directory_iterator(dir))
    if (entry.path().filename().string().rfind(stem, 0) == 0) return false;
  return true;
}

TEST(Cli, EverySubcommandHasHelp) {
  for (const std::string sub : {"", "simulate", "demo"}) {
    const auto r = RunFlatscan(sub + " --help");
    EXPECT_EQ(r.exit_code, 0) << sub;
    EXPECT_NE(r.out.find("Usage"), std::string::npos) << sub;
  }
  EXPECT_EQ(RunFlatscan("").exit_code, 2);
  // Before: "A subcommand is required" for a command that does not exist.
  const auto unknown = RunFlatscan("--threads 2 no-such-command --seed 1");
  EXPECT_EQ(unknown.exit_code, 2);
  EXPECT_EQ(unknown.err.rfind("unknown command 'no-such-command' (expected one of: ", 0), 0u) << unknown.err;
  EXPECT_NE(unknown.err.find("inspect"), std::string::npos) << unknown.err;
}

TEST(Cli, UnknownSideFaceModelExitsTwoNamingTheChoices) {
  const auto r = RunFlatscan("inspect --rig r.yml --plane p.yml --left l.png --right r.png --thickness 0.2 --side-faces sideways");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--side-faces: sideways not in {local,centre,support}"), std::string::npos) << r.err;
}

// Every numeric option is checked when the command line is parsed, before any file is
// read: NaN and infinity are refused, ranges print readably, text is "not a number".
// Before these checks, --tolerance nan gave exit 1 ("fail"), --thickness nan blamed focus
// and calibration, --blur -1 and --guard-band inf were accepted, and ranges printed
// 1.8e308 in 300 digits.
TEST(Cli, NumericOptionsAreCheckedAtParseTime) {
  const std::string inspect = "inspect --rig r.yml --plane p.yml --left l.png --right r.png ";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {inspect + "--thickness 0.2 --tolerance nan", "--tolerance: must be a finite number, got 'nan'"},
      {inspect + "--thickness 0.2 --tolerance abc", "--tolerance: not a number: 'abc' (expected a number in (0, 10])"},
      {inspect + "--thickness 0.2 --tolerance 0", "--tolerance: must be in (0, 10], got 0"},
      {inspect + "--thickness 0.2 --tolerance 1e400", "--tolerance: must be in (0, 10], got 1e400"},
      {inspect + "--thickness 0.2 --tolerance inf", "--tolerance: must be a finite number, got 'inf'"},
      {inspect + "--thickness 0.2 --tolerance 0x10", "--tolerance: not a number: '0x10' (expected a number in (0, 10])"},
      {inspect + "--thickness nan --tolerance 0.1", "--thickness: must be a finite number, got 'nan'"},
      {inspect + "--thickness -0.1 --tolerance 0.1", "--thickness: must be in [0, 5], got -0.1"},
      {inspect + "--thickness 0.2 --guard-band inf", "--guard-band: must be a finite number, got 'inf'"},
      {inspect + "--thickness 0.2 --blur -1", "--blur: must be in [0, 5], got -1"},
      {inspect + "--thickness 0.2 --blur 1e6", "--blur: must be in [0, 5], got 1e6"},
      {"demo --tolerance -1", "--tolerance: must be in (0, 10], got -1"},
      {"demo --parts 2.5", "--parts: must be a whole number in [1, 100000], got 2.5"},
      {"simulate --parts 1000000000 -o x", "--parts: must be in [0, 100000], got 1000000000"},
      {"simulate --shots 99999999999999999999 -o x", "--shots: must be in [1, 10000], got 99999999999999999999"},
      {"evaluate --rotation-step 1e-9", "--rotation-step: must be in [0.1, 360], got 1e-9"},
      {"evaluate --batch ten", "--batch: not a number: 'ten' (expected a whole number in [1, 1000000])"},
      {"edges i.png --csv o.csv --blur nan", "--blur: must be a finite number, got 'nan'"},
      {"calibrate-rig --left l --right r --board 9x6 --square -2.5 -o rig.yml", "--square: must be in (0, 1000], got -2.5"},
      {"--threads -1 demo", "--threads: must be in [0, 256], got -1"},
  };
  for (const auto& [args, message] : cases) {
    const auto r = RunFlatscan(args);
    EXPECT_EQ(r.exit_code, 2) << args;
    EXPECT_EQ(r.err, message + "\nRun with --help for more information.\n") << args;
  }
}

// Before: Ctrl-C left a "<out>.partial-PID" folder behind.
TEST(Cli, AnInterruptedRunLeavesNoPartialOutput) {
  ScratchDir dir("cli-interrupt");
  const auto scene = WriteSmallScene(dir.path());
  const std::string out = (dir.path() / "out").string();
  std::vector<std::string> args = {FLATSCAN_BINARY, "simulate", "--scene", scene.string(), "--parts", "200", "-q", "-o", out};
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  ASSERT_EQ(posix_spawn(&pid, FLATSCAN_BINARY, nullptr, nullptr, argv.data(), environ), 0);
  const std::filesystem::path partial = out + ".partial-" + std::to_string(pid);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (!std::filesystem::exists(partial / "rig.yml") && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_TRUE(std::filesystem::exists(partial)) << "the run did not start within 30 s";
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // in the middle of rendering
  ASSERT_EQ(kill(pid, SIGINT), 0);
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 2);
  EXPECT_TRUE(NothingNamedLike(dir.path(), "out"));
}

TEST(Cli, SimulateIsDeterministicForASeed) {
  ScratchDir dir("cli-determinism");
  const auto scene = WriteSmallScene(dir.path());
  for (const std::string out : {"a", "b", "c"}) {
    const std::string seed = out == "c" ? "6" : "5";
    const auto r = RunFlatscan("simulate --scene " + scene.string() + " --seed " + seed + " -q -o " + (dir.path() / out).string());
    ASSERT_EQ(r.exit_code, 0) << r.err;
  }
  int compared = 0;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(dir.path() / "a")) {
    if (!entry.is_regular_file()) continue;
    const auto rel = std::filesystem::relative(entry.path(), dir.path() / "a");
    EXPECT_EQ(testing::ReadFileBytes(entry.path()), testing::ReadFileBytes(dir.path() / "b" / rel)) << rel;
    ++compared;
  }
  // calib pairs + board.json, markers, parts, rig/plane/scene/pairs/truth, .flatscan-output
  EXPECT_EQ(compared, 2 * 2 + 1 + 2 + 2 * 2 + 5 + 1);
  EXPECT_NE(testing::ReadFileBytes(dir.path() / "a/parts/part_000_left.png"),
            testing::ReadFileBytes(dir.path() / "c/parts/part_000_left.png"));
  const auto truth = nlohmann::json::parse(testing::ReadFileBytes(dir.path() / "a/truth.json"));
  ASSERT_EQ(truth["parts"].size(), 2u);
  for (const auto& part : truth["parts"]) {
    EXPECT_GE(part["flatness_mm"].get<double>(), part["minzone_mm"].get<double>() - 1e-9);
    EXPECT_GT(part["rim_cam1_mm"].size(), 100u);
  }
}

TEST(Cli, RepeatedShotsShareThePartAndItsTruth) {
  ScratchDir dir("cli-shots");
  const auto scene = WriteSmallScene(dir.path());
  const auto r = RunFlatscan("simulate --scene " + scene.string() + " --parts 1 --shots 3 --no-calibration --no-markers -q -o " +
                             (dir.path() / "out").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto truth = nlohmann::json::parse(testing::ReadFileBytes(dir.path() / "out/truth.json"));
  ASSERT_EQ(truth["parts"][0]["shots"].size(), 3u);
  EXPECT_TRUE(std::filesystem::exists(dir.path() / "out/parts/part_000_shot_02_right.png"));
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "out/calib"));
  const std::string pairs = testing::ReadFileBytes(dir.path() / "out/pairs.csv");
  EXPECT_EQ(pairs.substr(0, 24), "id,left,right,thickness\n");
  EXPECT_NE(pairs.find(fmt::format("part_000_shot_01,parts/part_000_shot_01_left.png,parts/part_000_shot_01_right.png,{}\n",
                                   truth["parts"][0]["side_height_mm"].get<double>())),
            std::string::npos)
      << pairs;
}

TEST(Cli, BadSimulateInputExitsTwoWithoutOutput) {
  ScratchDir dir("cli-bad");
  const std::string out = (dir.path() / "out").string();
  auto r = RunFlatscan("simulate --preset nope -o " + out);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("unknown preset 'nope' (expected one of: paper, compact)"), std::string::npos) << r.err;

  const auto negative = WriteSmallScene(dir.path(), "optics:\n  noise_sigma_grey: -2\n");
  r = RunFlatscan("simulate --scene " + negative.string() + " -o " + out);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("small.yml: optics.noise_sigma_grey must be >= 0, got -2"), std::string::npos) << r.err;

  const auto missing = WriteSmallScene(dir.path(), "optics:\n  blur_sigma_px:\n");
  r = RunFlatscan("simulate --scene " + missing.string() + " -o " + out);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("small.yml: optics.blur_sigma_px has no value (expected a number in [0, 10])"), std::string::npos) << r.err;

  const auto huge = WriteSmallScene(dir.path(), "part:\n  width_mm: 80\n  height_mm: 10\n");
  r = RunFlatscan("simulate --scene " + huge.string() + " -o " + out);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("part: a 80.00 x 10.00 mm part does not fit in the common field of view"), std::string::npos) << r.err;

  std::ofstream(dir.path() / "file") << "x";
  const auto small = WriteSmallScene(dir.path());
  r = RunFlatscan("simulate --scene " + small.string() + " -o " + (dir.path() / "file" / "out").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("cannot create folder '" + (dir.path() / "file" / "out").string() + "'"), std::string::npos) << r.err;

  EXPECT_TRUE(NothingNamedLike(dir.path(), "out"));
}

}  // namespace
}  // namespace flatscan
