#include "flatscan/simulation/truth_file.h"

#include <fstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "flatscan/io/pairs_csv.h"
#include "flatscan/util/random.h"
#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {

// A study's parts written with WritePartPairs read back with ReadTruthFile: the same
// truth, poses and images, in the dataset schema `flatscan simulate` writes.
TEST(TruthFile, PartPairsRoundTrip) {
  testing::ScratchDir dir("truth-file");
  SceneConfig scene = ScenePreset("paper");
  scene.left_camera.width = scene.right_camera.width = 960;
  scene.left_camera.height = scene.right_camera.height = 720;
  scene.left_camera.pixel_size_um = scene.right_camera.pixel_size_um = 6.0;
  scene.part.wall_height_mm = {0.5, 0.5};
  const Station station = BuildStation(scene);
  Random rng(4);
  std::vector<PartPair> pairs;
  for (const char* id : {"part_0003", "part_0011"}) {
    SimulatedPart part = SampleSimulatedPart(station, 0, rng);
    pairs.push_back({id, part, cv::Mat1b(720, 960, uchar(200)), cv::Mat1b(720, 960, uchar(100))});
  }
  WritePartPairs(dir.path() / "worst", station, 9, pairs);
  const std::vector<TruthPart> truth = ReadTruthFile(dir.path() / "worst");
  ASSERT_EQ(truth.size(), 2u);
  for (size_t i = 0; i < truth.size(); ++i) {
    const PlacedShot& shot = pairs[i].part.shots[0];
    EXPECT_EQ(truth[i].id, pairs[i].id);
    EXPECT_EQ(truth[i].flatness_mm, shot.truth.flatness_mm);
    EXPECT_EQ(truth[i].minzone_mm, shot.truth.minzone_mm);
    EXPECT_EQ(truth[i].thickness_mm, pairs[i].part.geometry.thickness);
    EXPECT_EQ(truth[i].side_height_mm, pairs[i].part.geometry.thickness + 0.5);
    ASSERT_EQ(truth[i].shots.size(), 1u);
    const Rigid3d expected = station.cam1_from_support * shot.truth.support_from_part;
    EXPECT_LT((truth[i].shots[0].cam1_from_part.rotation - expected.rotation).norm(), 1e-12);
    EXPECT_LT((truth[i].shots[0].cam1_from_part.translation - expected.translation).norm(), 1e-9);
    EXPECT_EQ(cv::imread(truth[i].shots[0].right, cv::IMREAD_GRAYSCALE).at<uchar>(5, 5), 100);
  }
  const std::vector<PairEntry> csv = ReadPairsCsv(dir.path() / "worst/pairs.csv");
  ASSERT_EQ(csv.size(), 2u);
  EXPECT_EQ(csv[1].left, truth[1].shots[0].left);
}

TEST(TruthFile, MissingKeysAreNamed) {
  testing::ScratchDir dir("truth-file-bad");
  EXPECT_EQ(testing::InputErrorOf([&] { ReadTruthFile(dir.path()); }),
            (dir.path() / "truth.json").string() +
                ": cannot open the dataset's truth (expected the truth.json of a simulated dataset)");
  std::ofstream(dir.path() / "truth.json") << R"({"parts": [{"id": "p", "flatness_mm": 0.1}]})";
  EXPECT_EQ(testing::InputErrorOf([&] { ReadTruthFile(dir.path()); }),
            (dir.path() / "truth.json").string() + ": missing key 'lsq_pv_mm' (expected a number)");
}

}  // namespace
}  // namespace flatscan
