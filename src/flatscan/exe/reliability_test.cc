// The reliability table of docs/reliability.md: every bad input listed there is run
// through the flatscan binary here, its exit code is checked against the expected one,
// and no file the command did not create may change. The table in the docs is the one
// this test renders from what the commands print; when they differ the test fails, and
//   FLATSCAN_UPDATE_DOCS=1 build/src/flatscan/flatscan_tests --gtest_filter='Reliability.*'
// rewrites it (then read the diff: it is what users will see).
#include <sys/stat.h>
#include <sys/types.h>

#include <algorithm>
#include <cstring>
#include <limits>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "flatscan/io/rig_file.h"
#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {
namespace fs = std::filesystem;

// One bad input: what a user does, the command line (placeholders below), the exit code
// it must give, and the files (relative to $D) it may create.
struct BadInput {
  std::string item;   // the hardening issue's item, or the area
  std::string input;  // in words
  std::string args;   // flatscan's arguments
  int exit_code = 2;
  std::vector<std::string> creates = {};
};

// Placeholders in `args`: $D the fixture folder; $RIG, $PLANE the simulator's rig and
// true plane; $LEFT, $RIGHT one part's images; $T its thickness; $INSPECT is
// "inspect --rig $RIG --plane $PLANE --left $LEFT --right $RIGHT".
const std::vector<BadInput>& Cases() {
  static const std::vector<BadInput> cases = {
      // 1-2: the plane file against the rig.
      {"1", "plane file whose normal points away from the cameras",
       "inspect --rig $RIG --plane $D/bad/plane_reversed.yml --thickness $T --tolerance 0.1 --left $LEFT --right $RIGHT"},
      {"1", "the same, with --allow-foreign-plane",
       "inspect --rig $RIG --plane $D/bad/plane_reversed.yml --thickness $T --tolerance 0.1 --left $LEFT --right $RIGHT "
       "--allow-foreign-plane"},
      {"2", "plane file calibrated with another rig",
       "inspect --rig $RIG --plane $D/bad/plane_foreign.yml --thickness $T --tolerance 1 --left $LEFT --right $RIGHT"},
      {"2", "the same, with --allow-foreign-plane: measured, with a warning",
       "inspect --rig $RIG --plane $D/bad/plane_foreign.yml --thickness $T --tolerance 1 --left $LEFT --right $RIGHT "
       "--allow-foreign-plane",
       0},
      {"2", "plane file written before rig_sha256 existed: measured, with a warning",
       "inspect --rig $RIG --plane $D/bad/plane_old.yml --thickness $T --tolerance 1 --left $LEFT --right $RIGHT", 0},
      // 3: numbers.
      {"3", "--tolerance nan", "$INSPECT --thickness $T --tolerance nan"},
      {"3", "--tolerance abc", "$INSPECT --thickness $T --tolerance abc"},
      {"3", "--tolerance 1e400", "$INSPECT --thickness $T --tolerance 1e400"},
      {"3", "--tolerance 0", "$INSPECT --thickness $T --tolerance 0"},
      {"3", "--thickness nan", "$INSPECT --thickness nan --tolerance 1"},
      {"3", "--guard-band nan", "$INSPECT --thickness $T --tolerance 1 --guard-band nan"},
      {"3", "--blur -1", "$INSPECT --thickness $T --tolerance 1 --blur -1"},
      {"3", "demo --tolerance -1", "demo --tolerance -1 -o $D/demo"},
      {"3", "--threads abc", "--threads abc $INSPECT --thickness $T --tolerance 1"},
      {"3", "rig file with a NaN in M1", "inspect --rig $D/bad/rig_nan.yml --plane $PLANE --thickness $T "
                                         "--tolerance 1 --left $LEFT --right $RIGHT"},
      {"3", "plane file with a NaN in its normal", "inspect --rig $RIG --plane $D/bad/plane_nan.yml --thickness $T "
                                                   "--tolerance 1 --left $LEFT --right $RIGHT"},
      {"3", "scene file with pixel_size_um: .nan", "simulate --scene $D/bad/scene_nan.yml -o $D/sim"},
      // 4: runaway memory from the rig or the blur.
      {"4", "--blur 1e6 (16.8 GB before)", "$INSPECT --thickness $T --tolerance 1 --blur 1e6"},
      {"4", "rig whose baseline is along the optical axis, T = [0, 0, 60] (16.8 GB, 103 s before)",
       "inspect --rig $D/bad/rig_along_z.yml --plane $PLANE --thickness $T --tolerance 1 --left $LEFT --right $RIGHT"},
      {"4", "rig with a vertical baseline, T = [0, 60, 0]",
       "inspect --rig $D/bad/rig_vertical.yml --plane $PLANE --thickness $T --tolerance 1 --left $LEFT --right $RIGHT"},
      {"4", "rig with T = [1e-300, 0, 0]",
       "inspect --rig $D/bad/rig_tiny.yml --plane $PLANE --thickness $T --tolerance 1 --left $LEFT --right $RIGHT"},
      // 5: images checked by their header before decoding.
      {"5", "PNG whose header claims 100000 x 100000 px",
       "inspect --rig $RIG --plane $PLANE --thickness $T --tolerance 1 --left $D/bad/huge_header.png --right $RIGHT"},
      {"5", "image of another size than the rig's", "inspect --rig $RIG --plane $PLANE --thickness $T --tolerance 1 "
                                                   "--left $D/bad/small.png --right $RIGHT"},
      {"5", "edges on a PNG whose header claims 100000 x 100000 px", "edges $D/bad/huge_header.png --csv $D/e.csv"},
      // 6: calibration.
      {"6", "calibrate-rig --board 100000x100000",
       "calibrate-rig --left '$D/small/calib/left_*.png' --right '$D/small/calib/right_*.png' --board 100000x100000 "
       "--square 2 -o $D/r.yml"},
      {"6", "calibrate-rig --board 7x5 on images of a 9x6 board",
       "calibrate-rig --left '$D/board/left*.jpg' --right '$D/board/right*.jpg' --board 7x5 --square 25 -o $D/r.yml -q"},
      {"6", "calibrate-rig on patterns that match nothing",
       "calibrate-rig --left '$D/none_*.png' --right '$D/none_*.png' --board 9x6 --square 2 -o $D/r.yml"},
      // 7: sizes of the work.
      {"7", "simulate --parts 1000000000 (11.6 GB after 120 s before)", "simulate --parts 1000000000 -o $D/sim"},
      {"7", "simulate --shots 1000000000", "simulate --shots 1000000000 -o $D/sim"},
      {"7", "simulate --calib-poses 1000000000", "simulate --calib-poses 1000000000 -o $D/sim"},
      {"7", "scene file with dataset.parts: 1000000000", "simulate --scene $D/bad/scene_many_parts.yml -o $D/sim"},
      {"7", "evaluate --rotation-step 1e-9", "evaluate --rotation-step 1e-9 -o $D/eval"},
      // 8: outputs never replace inputs or what is not a regular file.
      {"8", "--json onto the left image", "$INSPECT --thickness $T --tolerance 1 --json $LEFT"},
      {"8", "--ply onto the rig file", "$INSPECT --thickness $T --tolerance 1 --ply $RIG"},
      {"8", "calibrate-plane -o onto its own --rig",
       "calibrate-plane --rig $RIG --left $LEFT --right $RIGHT -o $RIG"},
      {"8", "edges --csv onto its input image", "edges $LEFT --csv $LEFT"},
      {"8", "--json onto a FIFO", "$INSPECT --thickness $T --tolerance 1 --json $D/fifo"},
      {"8", "--json onto a symbolic link", "$INSPECT --thickness $T --tolerance 1 --json $D/link.json"},
      {"8", "--json onto a device", "$INSPECT --thickness $T --tolerance 1 --json /dev/null"},
      // 9: all outputs or none.
      {"9", "--json a.json --overlay onto an existing file", "$INSPECT --thickness $T --tolerance 1 --json $D/a.json --overlay $D/a_file"},
      {"9", "--json a.json --ply in a missing folder", "$INSPECT --thickness $T --tolerance 1 --json $D/a.json --ply /missing/x.ply"},
      {"9", "calibrate-plane -o p.yml --json in a missing folder",
       "calibrate-plane --rig $RIG --left $LEFT --right $RIGHT -o $D/p.yml --json /missing/p.json"},
      // 10-11: folders.
      {"10", "simulate -o onto a folder flatscan did not write", "simulate -o $D/not_ours"},
      {"10", "evaluate -o onto a folder flatscan did not write", "evaluate --batch 2 -o $D/not_ours"},
      {"11", "evaluate -o onto an existing file (failed after the whole run before)", "evaluate --batch 2 -o $D/a_file"},
      // 12-14: batches.
      {"12", "batch id ../../escape with --overlay: a safe folder name",
       "inspect --rig $RIG --plane $PLANE --thickness $T --tolerance 1 --pairs $D/bad/escape.csv --overlay $D/ov "
       "--overlay-scale 0.1 -q",
       0,
       {"ov"}},
      {"13", "pairs file that is a folder", "inspect --rig $RIG --plane $PLANE --thickness $T --tolerance 1 --pairs $D"},
      {"13", "pairs row p0,,", "inspect --rig $RIG --plane $PLANE --thickness $T --tolerance 1 --pairs $D/bad/p0.csv"},
      {"13", "pairs file with a misspelt column (thicknes)",
       "inspect --rig $RIG --plane $PLANE --thickness $T --tolerance 1 --pairs $D/bad/misspelt.csv"},
      {"13", "pairs file with an unterminated quote", "inspect --rig $RIG --plane $PLANE --thickness $T --tolerance 1 "
                                                     "--pairs $D/bad/open_quote.csv"},
      {"13", "pairs file with thickness abc", "inspect --rig $RIG --plane $PLANE --tolerance 1 "
                                             "--pairs $D/bad/thickness_abc.csv"},
      {"13", "pairs file without thickness, and no --thickness",
       "inspect --rig $RIG --plane $PLANE --tolerance 1 --pairs $D/bad/escape.csv"},
      {"13", "pairs file with a BOM, CRLF, quotes, a comma in a path and padding: accepted",
       "inspect --rig $RIG --plane $PLANE --tolerance 1 --pairs $D/bad/bom_crlf.csv -q", 0},
      {"14", "--ply with a batch", "inspect --rig $RIG --plane $PLANE --thickness $T --tolerance 1 "
                                  "--pairs $D/bad/escape.csv --ply $D/b.ply"},
      // 15: a part that is not measured still gets its record.
      {"15", "a pair without a part, with --json: a record with measured: false",
       "inspect --rig $RIG --plane $PLANE --thickness $T --tolerance 1 --left $D/bad/backlight.png --right $RIGHT "
       "--json $D/nm.json",
       2,
       {"nm.json"}},
      // Messages.
      {"messages", "a command that does not exist", "no-such-command --seed 1"},
      {"messages", "uniform 16-bit image at half range", "edges $D/bad/uniform16.png --csv $D/e.csv"},
      {"messages", "truncated PNG (a file copied while it was written)",
       "inspect --rig $RIG --plane $PLANE --thickness $T --tolerance 1 --left $D/bad/truncated.png --right $RIGHT"},
      {"messages", "PNG with a damaged chunk",
       "inspect --rig $RIG --plane $PLANE --thickness $T --tolerance 1 --left $D/bad/bad_crc.png --right $RIGHT"},
      {"messages", "text file named .png", "edges $D/bad/text.png --csv $D/e.csv"},
      {"messages", "empty image file", "edges $D/bad/empty.png --csv $D/e.csv"},
      {"messages", "image path that is a folder", "edges $D/bad --csv $D/e.csv"},
      {"messages", "missing image", "inspect --rig $RIG --plane $PLANE --thickness $T --tolerance 1 --left $D/none.png --right $RIGHT"},
      {"messages", "missing rig file", "inspect --rig $D/none.yml --plane $PLANE --thickness $T --tolerance 1 "
                                       "--left $LEFT --right $RIGHT"},
      {"messages", "rig file without T", "inspect --rig $D/bad/rig_no_t.yml --plane $PLANE --thickness $T "
                                         "--tolerance 1 --left $LEFT --right $RIGHT"},
      {"messages", "rig file with a 3x2 camera matrix", "inspect --rig $D/bad/rig_m1_3x2.yml --plane $PLANE "
                                                       "--thickness $T --tolerance 1 --left $LEFT --right $RIGHT"},
      {"messages", "scene file with an unknown key", "simulate --scene $D/bad/scene_unknown.yml -o $D/sim"},
      // The station's inputs (docs/station.md).
      {"station", "recipe without tolerance_mm", "recipe check $D/bad/recipe_no_tolerance.yml"},
      {"station", "recipe with a misspelt key", "recipe check $D/bad/recipe_misspelt.yml"},
      {"station", "recipe whose plane was calibrated with another rig", "recipe check $D/bad/recipe_foreign.yml"},
      {"station", "recipe whose pinned rig hash does not match", "recipe check $D/bad/recipe_pinned.yml"},
      {"station", "station with a bad recipe: no store is created",
       "station --recipe $D/bad/recipe_no_tolerance.yml --source pairs:$D/bad/escape.csv --store $D/s.db --until-idle 0"},
      {"station", "station with an unknown source",
       "station --recipe $D/bad/recipe_good.yml --source camera:0 --store $D/s.db --until-idle 0"},
      {"station", "results of a store that does not exist", "results --store $D/none.db"},
      {"station", "results of a file that is not a store", "results --store $D/a_file"},
      {"station", "results --from in local time", "results --store $D/a_file --from 2026-12-04T08:00+01:00"},
      // Found by the fuzzers (fuzz/).
      {"fuzz", "rig file of nested brackets (kept OpenCV's parser busy for minutes)",
       "inspect --rig $D/bad/rig_nested.yml --plane $PLANE --thickness $T --tolerance 1 --left $LEFT --right $RIGHT"},
      {"fuzz", "rig file whose top level is a list", "inspect --rig $D/bad/rig_list.yml --plane $PLANE --thickness $T "
                                                     "--tolerance 1 --left $LEFT --right $RIGHT"},
      {"fuzz", "rig file with a 100000-row matrix", "inspect --rig $D/bad/rig_huge_matrix.yml --plane $PLANE "
                                                   "--thickness $T --tolerance 1 --left $LEFT --right $RIGHT"},
      {"fuzz", "plane file of document markers and tags",
       "inspect --rig $RIG --plane $D/bad/plane_markers.yml --thickness $T --tolerance 1 --left $LEFT --right $RIGHT"},
      {"fuzz", "18-byte plane file on which OpenCV's YAML parser never returned",
       "inspect --rig $RIG --plane $D/bad/plane_hang.yml --thickness $T --tolerance 1 --left $LEFT --right $RIGHT"},
      {"fuzz", "pairs file of one NUL byte", "inspect --rig $RIG --plane $PLANE --thickness $T --tolerance 1 "
                                            "--pairs $D/bad/nul.csv"},
  };
  return cases;
}

// The fixture: the simulator's data and the bad files, made once.
class Reliability : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::ScratchDir("reliability");
    const fs::path d = dir_->path();
    auto r = testing::RunFlatscan("simulate --preset paper --parts 1 --no-calibration --no-markers --seed 3 -q -o " +
                                  (d / "data").string());
    ASSERT_EQ(r.exit_code, 0) << r.err;
    std::ofstream(d / "small.yml") << "camera:\n  width: 960\n  height: 720\n  pixel_size_um: 6.0\n"
                                      "board:\n  poses: 3\ndataset:\n  parts: 1\n";
    r = testing::RunFlatscan(fmt::format("simulate --scene {0}/small.yml --no-markers --seed 4 -q -o {0}/small",
                                         d.string()));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    thickness_ = nlohmann::json::parse(testing::ReadFileBytes(d / "data/truth.json"))["parts"][0]["thickness_mm"];
    fs::create_directories(d / "bad");
    // Three of OpenCV's stereo sample pairs (a 9x6 board; Debian package opencv-doc):
    // the classic corner search with a wrong board size is slow on the simulator's crisp
    // images (about 12 s per image), fast on these.
    fs::create_directories(d / "board");
    for (const char* side : {"left", "right"})
      for (int i = 1; i <= 3; ++i) {
        const std::string name = fmt::format("{}0{}.jpg", side, i);
        fs::copy_file(fs::path("/usr/share/doc/opencv-doc/examples/data") / name, d / "board" / name);
      }
    WriteBadPlanes(d);
    WriteBadRigs(d);
    WriteBadImages(d);
    WriteBadTables(d);
    WriteBadRecipes(d);
    fs::create_directories(d / "not_ours");
    std::ofstream(d / "not_ours/thesis.txt") << "four years of work\n";
    std::ofstream(d / "a_file") << "x";
    std::ofstream(d / "target.json") << "{}";
    fs::create_symlink(d / "target.json", d / "link.json");
    ASSERT_EQ(::mkfifo((d / "fifo").c_str(), 0600), 0);
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }

  static void WriteBadPlanes(const fs::path& d) {
    const PlaneFile file = ReadPlaneFile(d / "data/plane_true.yml");
    SupportPlane reversed = file.plane;
    reversed.normal = -reversed.normal;
    WritePlaneFile(d / "bad/plane_reversed.yml", reversed, file.rig_sha256);
    WritePlaneFile(d / "bad/plane_foreign.yml", file.plane, std::string(64, 'a'));
    WritePlaneFile(d / "bad/plane_old.yml", file.plane, "");
    std::string text = testing::ReadFileBytes(d / "bad/plane_old.yml");
    const size_t normal = text.find("data: [", text.find("normal:"));
    text.replace(normal + 7, text.find(',', normal) - normal - 7, ".nan");
    std::ofstream(d / "bad/plane_nan.yml") << text;
    std::ofstream(d / "bad/plane_markers.yml") << "%YAML:1.0\n----!!\n----!!\n----!!\n----!!\n----!!\n----!!\n";
    std::ofstream(d / "bad/plane_hang.yml") << "%YAML:1.\n L:1\n- \n-";
  }

  // A rig file of two copies of camera matrix `m` without distortion, R = I and the
  // translation `t` (keys of docs/conventions.md, no rectification: the reader computes it).
  static void WriteRig(const fs::path& path, const Camera& camera, const cv::Mat& m, const cv::Mat& t) {
    cv::FileStorage fs(path.string(), cv::FileStorage::WRITE);
    fs << "image_width" << camera.width << "image_height" << camera.height << "M1" << m;
    fs << "D1" << cv::Mat::zeros(1, 5, CV_64F) << "M2" << m << "D2" << cv::Mat::zeros(1, 5, CV_64F);
    fs << "R" << cv::Mat::eye(3, 3, CV_64F) << "T" << t;
  }

  static void WriteBadRigs(const fs::path& d) {
    const Camera camera = ReadRigFile(d / "data/rig.yml").left;
    const cv::Mat m = camera.CameraMatrix();
    const auto t = [](double x, double y, double z) {
      cv::Mat_<double> v(3, 1);
      v << x, y, z;
      return cv::Mat(v);
    };
    WriteRig(d / "bad/rig_along_z.yml", camera, m, t(0, 0, 60));
    WriteRig(d / "bad/rig_vertical.yml", camera, m, t(0, 60, 0));
    WriteRig(d / "bad/rig_tiny.yml", camera, m, t(1e-300, 0, 0));
    cv::Mat nan_m = m.clone();
    nan_m.at<double>(0, 0) = std::numeric_limits<double>::quiet_NaN();
    WriteRig(d / "bad/rig_nan.yml", camera, nan_m, t(-60, 0, 0));
    WriteRig(d / "bad/rig_m1_3x2.yml", camera, m.colRange(0, 2).clone(), t(-60, 0, 0));
    WriteRig(d / "bad/rig_no_t.yml", camera, m, t(-60, 0, 0));
    const std::string text = testing::ReadFileBytes(d / "bad/rig_no_t.yml");
    std::ofstream(d / "bad/rig_no_t.yml") << text.substr(0, text.find("T: "));
    std::ofstream(d / "bad/rig_nested.yml") << "%YAML:1.0\nM1: " << std::string(200, '[') << "\n";
    std::ofstream(d / "bad/rig_list.yml") << "%YAML:1.0\n- 1\n- 2\n";
    std::ofstream(d / "bad/rig_huge_matrix.yml")
        << "%YAML:1.0\nimage_width: 2592\nimage_height: 1944\nM1: !!opencv-matrix\n   rows: 100000\n   cols: 1\n   dt: d\n   data: [ 1. ]\n";
  }

  static void WriteBadImages(const fs::path& d) {
    // A grey pattern of the rig's size, so that only the damage is wrong with it.
    cv::Mat1b pattern(1944, 2592);
    cv::randu(pattern, 0, 256);
    std::vector<uchar> png;
    cv::imencode(".png", pattern, png);
    std::ofstream(d / "bad/truncated.png", std::ios::binary).write(reinterpret_cast<const char*>(png.data()),
                                                                 static_cast<std::streamsize>(png.size() / 2));
    png[png.size() / 2] ^= 0x40;  // a flipped bit inside the image data
    std::ofstream(d / "bad/bad_crc.png", std::ios::binary).write(reinterpret_cast<const char*>(png.data()),
                                                                static_cast<std::streamsize>(png.size()));
    // The signature and a 100000 x 100000 IHDR chunk, nothing after.
    const unsigned char header[] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n', 0, 0, 0, 13, 'I', 'H', 'D', 'R',
                                    0, 1, 0x86, 0xA0, 0, 1, 0x86, 0xA0, 8, 0, 0, 0, 0, 0, 0, 0, 0};
    std::ofstream(d / "bad/huge_header.png", std::ios::binary).write(reinterpret_cast<const char*>(header), sizeof(header));
    cv::imwrite((d / "bad/small.png").string(), cv::Mat1b(100, 100, uchar{128}));
    cv::imwrite((d / "bad/uniform16.png").string(), cv::Mat1w(480, 640, uint16_t{32768}));
    cv::imwrite((d / "bad/backlight.png").string(), cv::Mat1b(1944, 2592, uchar{230}));
    std::ofstream(d / "bad/text.png") << "these are not the pixels you are looking for\n";
    std::ofstream(d / "bad/empty.png");
  }

  static void WriteBadRecipes(const fs::path& d) {
    const std::string files = "rig: ../data/rig.yml\nplane: ../data/plane_true.yml\n";
    std::ofstream(d / "bad/recipe_good.yml") << "name: shield\nthickness_mm: 0.2\ntolerance_mm: 0.1\n" << files;
    std::ofstream(d / "bad/recipe_no_tolerance.yml") << "name: shield\nthickness_mm: 0.2\n" << files;
    std::ofstream(d / "bad/recipe_misspelt.yml") << "name: shield\nthickness_mm: 0.2\ntolerance_mm: 0.1\n"
                                                    "guardband_mm: 0.01\n" << files;
    std::ofstream(d / "bad/recipe_foreign.yml") << "name: shield\nthickness_mm: 0.2\ntolerance_mm: 0.1\n"
                                                   "rig: ../data/rig.yml\nplane: plane_foreign.yml\n";
    std::ofstream(d / "bad/recipe_pinned.yml") << "name: shield\nthickness_mm: 0.2\ntolerance_mm: 0.1\nrig_sha256: "
                                               << std::string(64, '0') << "\n" << files;
  }

  static void WriteBadTables(const fs::path& d) {
    const std::string left = (d / "data/parts/part_000_left.png").string();
    const std::string right = (d / "data/parts/part_000_right.png").string();
    std::ofstream(d / "bad/escape.csv") << "id,left,right\n../../escape," << left << "," << right << "\n";
    std::ofstream(d / "bad/p0.csv") << "id,left,right\np0,,\n";
    std::ofstream(d / "bad/misspelt.csv") << "id,left,right,thicknes\np0," << left << "," << right << ",0.2\n";
    std::ofstream(d / "bad/open_quote.csv") << "id,left,right\np0,\"" << left << "," << right << "\n";
    std::ofstream(d / "bad/thickness_abc.csv") << "id,left,right,thickness\np0," << left << "," << right << ",abc\n";
    fs::copy_file(left, d / "data/parts/a, \"b\".png");
    std::ofstream(d / "bad/bom_crlf.csv", std::ios::binary)
        << "\xEF\xBB\xBFid , left,right,thickness\r\n  p0 ,\"" << (d / "data/parts/a, \"\"b\"\".png").string()
        << "\"," << right << ", " << thickness_ << "\r\n";
    std::ofstream(d / "bad/nul.csv", std::ios::binary) << std::string(1, '\0');
    std::ofstream(d / "bad/scene_nan.yml") << "camera:\n  pixel_size_um: .nan\n";
    std::ofstream(d / "bad/scene_many_parts.yml") << "dataset:\n  parts: 1000000000\n";
    std::ofstream(d / "bad/scene_unknown.yml") << "camera:\n  pixel_size: 6.0\n";
  }

  static std::string Expand(std::string args) {
    const std::string d = dir_->path().string();
    const std::vector<std::pair<std::string, std::string>> names = {
        {"$INSPECT", "inspect --rig $RIG --plane $PLANE --left $LEFT --right $RIGHT"},
        {"$RIGHT", d + "/data/parts/part_000_right.png"},  // before $RIG, its prefix
        {"$RIG", d + "/data/rig.yml"},
        {"$PLANE", d + "/data/plane_true.yml"},
        {"$LEFT", d + "/data/parts/part_000_left.png"},
        {"$T", fmt::format("{}", thickness_)},
        {"$D", d}};
    for (const auto& [name, value] : names)
      for (size_t at = args.find(name); at != std::string::npos; at = args.find(name, at + value.size()))
        args.replace(at, name.size(), value);
    return args;
  }

  static testing::ScratchDir* dir_;
  static double thickness_;
};
testing::ScratchDir* Reliability::dir_ = nullptr;
double Reliability::thickness_ = 0;

// What identifies a file's contents without reading it: a replaced file has another
// inode, a rewritten one another size or modification time.
struct FileState {
  fs::file_type type;
  ino_t inode = 0;
  off_t size = 0;
  long long mtime_ns = 0;
  bool operator==(const FileState&) const = default;
};

std::map<std::string, FileState> Snapshot(const fs::path& root) {
  std::map<std::string, FileState> files;
  for (const auto& entry : fs::recursive_directory_iterator(root)) {
    struct stat st {};
    if (::lstat(entry.path().c_str(), &st) != 0) continue;
    files[fs::relative(entry.path(), root).string()] = {
        entry.symlink_status().type(), st.st_ino, st.st_size,
        static_cast<long long>(st.st_mtim.tv_sec) * 1'000'000'000LL + st.st_mtim.tv_nsec};
  }
  return files;
}

// The line of stderr a user reads first: the first error or warning, else the first line.
std::string FirstMessage(const std::string& err, const std::string& dir) {
  std::vector<std::string> lines;
  for (size_t at = 0; at < err.size();) {
    const size_t end = std::min(err.find('\n', at), err.size());
    lines.push_back(err.substr(at, end - at));
    at = end + 1;
  }
  std::string chosen = "(nothing on stderr)";
  for (const std::string& line : lines)
    if (line.rfind("error: ", 0) == 0 || line.rfind("warning: ", 0) == 0) {
      chosen = line;
      break;
    }
  if (chosen == "(nothing on stderr)" && !lines.empty()) chosen = lines.front();
  for (size_t at = chosen.find(dir); at != std::string::npos; at = chosen.find(dir, at))
    chosen.replace(at, dir.size(), "$D");
  chosen = std::regex_replace(chosen, std::regex("[0-9a-f]{12,64}"), "<sha256>");
  return chosen;
}

std::string TableCell(std::string text) {
  for (size_t at = text.find('|'); at != std::string::npos; at = text.find('|', at + 2)) text.replace(at, 1, "\\|");
  return text;
}

std::string CodeCell(const std::string& text) {
  // A code span that holds backticks needs a longer fence (CommonMark).
  const std::string fence = text.find('`') == std::string::npos ? "`" : "``";
  return fence + TableCell(text) + fence;
}

constexpr const char* kBegin = "<!-- reliability-table: generated by src/flatscan/exe/reliability_test.cc -->\n";
constexpr const char* kEnd = "<!-- reliability-table: end -->\n";

TEST_F(Reliability, EveryBadInputGetsItsExitCodeAndChangesNoFileItDidNotCreate) {
  const fs::path d = dir_->path();
  std::string table = "| # | item | bad input | command | exit | what it gets (first line on stderr) |\n"
                      "|---|---|---|---|---|---|\n";
  int row = 0;
  for (const BadInput& c : Cases()) {
    ++row;
    const auto before = Snapshot(d);
    // Bounded, so that a hang fails here; the slowest case takes a few seconds.
    const auto r = testing::RunFlatscan(Expand(c.args), 300);
    EXPECT_EQ(r.exit_code, c.exit_code) << "case " << row << ": " << c.input << "\n" << r.err;
    const auto after = Snapshot(d);
    const auto created = [&](const std::string& name) {
      return std::any_of(c.creates.begin(), c.creates.end(),
                         [&](const std::string& p) { return name == p || name.rfind(p + "/", 0) == 0; });
    };
    for (const auto& [name, state] : before) {
      const auto now = after.find(name);
      EXPECT_TRUE(now != after.end() && now->second == state) << "case " << row << " changed " << name;
    }
    for (const auto& [name, state] : after)
      if (!before.count(name)) {
        EXPECT_TRUE(created(name)) << "case " << row << " created " << name;
        std::error_code ec;
        fs::remove_all(d / name, ec);
      }
    table += fmt::format("| {} | {} | {} | {} | {} | {} |\n", row, c.item, TableCell(c.input), CodeCell(c.args),
                         r.exit_code, CodeCell(FirstMessage(r.err, d.string())));
  }
  EXPECT_GE(row, 60);

  const fs::path doc = fs::path(FLATSCAN_SOURCE_DIR) / "docs/reliability.md";
  const std::string text = testing::ReadFileBytes(doc);
  const size_t begin = text.find(kBegin), end = text.find(kEnd);
  ASSERT_NE(begin, std::string::npos) << doc << " lacks the line " << kBegin;
  ASSERT_NE(end, std::string::npos) << doc << " lacks the line " << kEnd;
  const std::string documented = text.substr(begin + strlen(kBegin), end - begin - strlen(kBegin));
  if (documented != table && std::getenv("FLATSCAN_UPDATE_DOCS") != nullptr) {
    std::ofstream(doc, std::ios::binary) << text.substr(0, begin + strlen(kBegin)) << table << text.substr(end);
    return;
  }
  EXPECT_EQ(documented, table) << doc << " differs from what the commands print; if the change is intended, run "
                               << "FLATSCAN_UPDATE_DOCS=1 build/src/flatscan/flatscan_tests "
                                  "--gtest_filter='Reliability.*' and read the diff";
}

}  // namespace
}  // namespace flatscan
