// `flatscan capture-calibration` through Aravis's in-process fake cameras showing a
// simulated dataset's chessboard pairs: what it saves is what the cameras showed, and
// calibrate-rig calibrates from it as from the originals.
#include <csignal>
#include <fstream>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {

namespace fs = std::filesystem;

class CaptureCalibrationCommand : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::ScratchDir("capture_calibration");
    const fs::path d = dir_->path();
    // 960 x 720 images, six board poses: about 2 s to render.
    std::ofstream(d / "small.yml") << "camera:\n  width: 960\n  height: 720\n  pixel_size_um: 6.0\n"
                                      "board:\n  poses: 6\ndataset:\n  parts: 0\n";
    const auto r = testing::RunFlatscan(
        fmt::format("simulate --scene {0}/small.yml --no-markers --seed 4 -q -o {0}/data", d.string()));
    ASSERT_EQ(r.exit_code, 0) << r.err;
  }
  static void TearDownTestSuite() { delete dir_; }
  static fs::path D() { return dir_->path(); }
  static fs::path Calib() { return D() / "data/calib"; }

  static testing::CommandResult Capture(const std::string& cameras, const fs::path& out, const std::string& extra = "") {
    return testing::RunFlatscan(fmt::format("capture-calibration --cameras aravis-fake:{} --board 9x6 --square 2.5 "
                                            "-o {} --every 0 {}",
                                            cameras, out.string(), extra),
                                120);
  }
  static nlohmann::json CalibrateRig(const std::string& left, const std::string& right, const std::string& name) {
    const auto r = testing::RunFlatscan(fmt::format("calibrate-rig --left '{0}' --right '{1}' --board 9x6 --square 2.5 "
                                                    "-o {2}/{3}.yml --json {2}/{3}.json",
                                                    left, right, D().string(), name),
                                        120);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return nlohmann::json::parse(testing::ReadFileBytes(D() / (name + ".json")));
  }
  static testing::ScratchDir* dir_;
};
testing::ScratchDir* CaptureCalibrationCommand::dir_ = nullptr;

bool SamePixels(const fs::path& a, const fs::path& b) {
  const cv::Mat x = cv::imread(a.string(), cv::IMREAD_UNCHANGED), y = cv::imread(b.string(), cv::IMREAD_UNCHANGED);
  return !x.empty() && x.size() == y.size() && x.type() == y.type() && cv::norm(x, y, cv::NORM_INF) == 0;
}

TEST_F(CaptureCalibrationCommand, SavesWhatTheCamerasShowedAndCalibrateRigTakesIt) {
  const fs::path out = D() / "captured";
  const auto r = Capture(Calib().string(), out);
  ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
  for (int i = 1; i <= 6; ++i) {
    EXPECT_NE(r.out.find(fmt::format("pair {0}: left 54 of 54 corners, right 54 of 54 corners: saved as pair_{0:03d}", i)),
              std::string::npos)
        << r.out;
    EXPECT_TRUE(SamePixels(out / fmt::format("pair_{:03d}_left.png", i), Calib() / fmt::format("left_{:02d}.png", i - 1)));
    EXPECT_TRUE(SamePixels(out / fmt::format("pair_{:03d}_right.png", i), Calib() / fmt::format("right_{:02d}.png", i - 1)));
  }
  EXPECT_NE(r.out.find("  coverage left      right\n"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("  left: "), std::string::npos);
  EXPECT_NE(r.out.find(fmt::format("saved 6 pairs in {0}\nnext: flatscan calibrate-rig --left '{0}/pair_*_left.png' "
                                   "--right '{0}/pair_*_right.png' --board 9x6 --square 2.5 -o rig.yml",
                                   out.string())),
            std::string::npos)
      << r.out;
  // The same pixels give the same calibration.
  const nlohmann::json captured = CalibrateRig((out / "pair_*_left.png").string(), (out / "pair_*_right.png").string(), "cap");
  const nlohmann::json original = CalibrateRig((Calib() / "left_*.png").string(), (Calib() / "right_*.png").string(), "orig");
  EXPECT_EQ(captured["pairs_used"], 6);
  EXPECT_EQ(captured["rms_px"], original["rms_px"]);
  EXPECT_EQ(captured["epipolar_px"], original["epipolar_px"]);

  // A second capture into the same folder replaces nothing.
  const auto again = Capture(Calib().string(), out);
  EXPECT_EQ(again.exit_code, 2);
  EXPECT_NE(again.err.find(fmt::format("--output: {} holds the pairs of an earlier capture (pair_001_left.png): expected a "
                                       "new or empty folder",
                                       out.string())),
            std::string::npos)
      << again.err;
}

TEST_F(CaptureCalibrationCommand, APairWithoutTheBoardIsNotSavedAndTheCountStops) {
  const fs::path mixed = D() / "mixed";
  fs::create_directories(mixed);
  for (int i = 0; i < 6; ++i)
    for (const char* side : {"left", "right"})
      fs::copy_file(Calib() / fmt::format("{}_{:02d}.png", side, i), mixed / fmt::format("{}_{:02d}.png", side, i),
                    fs::copy_options::overwrite_existing);
  // Second in name order: a left image with no board (the backlight alone).
  cv::imwrite((mixed / "left_00b.png").string(), cv::Mat1b(720, 960, uchar{200}));
  fs::copy_file(Calib() / "right_01.png", mixed / "right_00b.png", fs::copy_options::overwrite_existing);
  const auto r = Capture(mixed.string(), D() / "mixed_out", "--pairs 4");
  ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
  EXPECT_NE(r.out.find("pair 2: left 0 of 54 corners (no 9x6 chessboard (inner corners) found), right 54 of 54 "
                       "corners: not saved"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("pair 3: left 54 of 54 corners, right 54 of 54 corners: saved as pair_002"), std::string::npos);
  EXPECT_NE(r.out.find("saved 4 pairs"), std::string::npos);  // --pairs 4: five taken, four saved
  EXPECT_EQ(r.out.find("pair 6:"), std::string::npos);
  EXPECT_TRUE(fs::exists(D() / "mixed_out/pair_004_right.png"));
  EXPECT_FALSE(fs::exists(D() / "mixed_out/pair_005_left.png"));
}

TEST_F(CaptureCalibrationCommand, TooFewPairsIsAnErrorAndBadInputIsNamed) {
  const fs::path two = D() / "two";
  fs::create_directories(two);
  for (int i = 0; i < 2; ++i)
    for (const char* side : {"left", "right"})
      fs::copy_file(Calib() / fmt::format("{}_{:02d}.png", side, i), two / fmt::format("{}_{:02d}.png", side, i),
                    fs::copy_options::overwrite_existing);
  auto r = Capture(two.string(), D() / "two_out");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find(fmt::format("2 pair(s) with the whole board in both images saved in {}: calibrate-rig needs 3 "
                                   "or more (check --board, the focus and the lighting)",
                                   (D() / "two_out").string())),
            std::string::npos)
      << r.err;
  r = testing::RunFlatscan("capture-calibration --cameras A --board 9x6 --square 2.5 -o " + (D() / "x").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--cameras 'A': expected LEFT,RIGHT (each camera's id or serial, from `flatscan cameras`) or "
                       "aravis-fake:DIR"),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(D() / "x"));  // nothing created for a capture that could not start
  r = Capture(Calib().string(), D() / "y", "--board 9");
  EXPECT_EQ(r.exit_code, 2);
}

TEST_F(CaptureCalibrationCommand, CtrlCEndsTheCaptureBetweenPairs) {
  const fs::path out = D() / "interrupted";
  const fs::path log = D() / "interrupted.log";
  testing::BackgroundFlatscan capture({"capture-calibration", "--cameras", "aravis-fake:" + Calib().string(), "--board",
                                       "9x6", "--square", "2.5", "-o", out.string(), "--every", "600000"},
                                      log);
  ASSERT_TRUE(testing::WaitFor([&] { return fs::exists(out / "pair_001_left.png"); }, 60));
  capture.Signal(SIGINT);
  EXPECT_EQ(capture.Wait(30), 2);  // one pair is too few to calibrate
  EXPECT_TRUE(SamePixels(out / "pair_001_left.png", Calib() / "left_00.png"));
  EXPECT_TRUE(SamePixels(out / "pair_001_right.png", Calib() / "right_00.png"));
  EXPECT_FALSE(fs::exists(out / "pair_002_left.png"));
  EXPECT_NE(testing::ReadFileBytes(log).find("1 pair(s) with the whole board in both images saved"), std::string::npos);
}

}  // namespace
}  // namespace flatscan
