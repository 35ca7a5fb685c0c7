#include "flatscan/inspection/stereo_outline.h"

#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "flatscan/simulation/simulation_test_util.h"
#include "flatscan/util/error.h"
#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {

using testing::InputErrorOf;

struct OutlineScene {
  Station station = BuildStation(ScenePreset("paper"));
  StereoRectification rectification{station.rig};
  testing::RenderedPair pair;
  OutlineScene() {
    Random rng(12);
    pair = testing::RenderRandomPart(station, 0, rng, 512);
  }
  StereoOutline Match(const cv::Mat1b& left, const cv::Mat1b& right, const InspectionParams& params = {},
                      std::vector<std::pair<std::string, double>>* stages = nullptr) const {
    std::vector<std::pair<std::string, double>> ignored;
    StageTimer timer(stages ? stages : &ignored);
    return MatchStereoOutline(rectification, station.plane, left, right, params, "L.png", "R.png", &timer);
  }
};

const OutlineScene& Scene() {
  static const OutlineScene scene;
  return scene;
}

TEST(StereoOutline, FindsThePartInBothImagesAndMatchesItsCrossings) {
  const OutlineScene& sc = Scene();
  std::vector<std::pair<std::string, double>> stages;
  const StereoOutline out = sc.Match(sc.pair.left, sc.pair.right, {}, &stages);
  ASSERT_GE(out.left_part, 0);
  ASSERT_GE(out.right_part, 0);
  // The outer contour is the part's; the other closed contours are its holes.
  EXPECT_TRUE(out.left.contours[out.left_part].closed);
  int closed = 0;
  for (const ContourInfo& c : out.left.contours) closed += c.closed;
  EXPECT_EQ(closed, 1 + static_cast<int>(sc.pair.part.geometry.holes.size()));
  int outer_crossings = 0, outer_matched = 0;
  for (const RowCrossing& c : out.left_crossings) outer_crossings += c.contour == out.left_part;
  for (const StereoMatch& m : out.matches) outer_matched += out.left_crossings[m.left].contour == out.left_part;
  EXPECT_GT(outer_crossings, 1000);
  EXPECT_GT(outer_matched, 0.9 * outer_crossings);
  // The right chains are the right image's contours rectified, one per contour.
  ASSERT_EQ(out.right_chains.size(), out.right.contours.size());
  const ContourInfo& right_outer = out.right.contours[out.right_part];
  EXPECT_EQ(static_cast<int>(out.right_chains[out.right_part].size()), right_outer.end - right_outer.begin);
  // Every crossing lies on the rectified row it names.
  for (const RowCrossing& c : out.left_crossings) {
    const Eigen::Vector2d rect = sc.rectification.left().RawToRectified({c.raw_x, c.raw_y});
    ASSERT_NEAR(rect.y(), c.row, 0.02);
  }
  ASSERT_EQ(stages.size(), 4u);
  EXPECT_EQ(stages[0].first, "boundary_left");
  EXPECT_EQ(stages[3].first, "matching");
}

TEST(StereoOutline, ImageAcceptanceThresholdsAreTheParameters) {
  const OutlineScene& sc = Scene();
  InspectionParams params;
  params.acceptance.min_backlight_grey = 250;
  const std::string message = InputErrorOf([&] { sc.Match(sc.pair.left, sc.pair.right, params); });
  EXPECT_EQ(message.rfind("L.png: under-exposed (backlight grey level ", 0), 0u) << message;
  EXPECT_NE(message.find("expected at least 250): increase exposure or light"), std::string::npos) << message;
  params = {};
  params.acceptance.min_part_area_fraction = 0.5;  // the part covers a few percent of the image
  EXPECT_EQ(InputErrorOf([&] { sc.Match(sc.pair.left, sc.pair.right, params); }),
            "L.png: no part found (expected a dark part on the bright backlight, fully in view)");
  params = {};
  params.acceptance.max_saturated_fraction = -1;
  EXPECT_EQ(InputErrorOf([&] { sc.Match(sc.pair.left, sc.pair.right, params); }).rfind("L.png: over-exposed", 0), 0u);
}

TEST(StereoOutline, SwappedOrForeignImagesAreRejected) {
  const OutlineScene& sc = Scene();
  const std::string swapped = InputErrorOf([&] { sc.Match(sc.pair.right, sc.pair.left); });
  EXPECT_EQ(swapped.rfind("L.png and R.png: ", 0), 0u) << swapped;
  EXPECT_NE(swapped.find("swapped"), std::string::npos) << swapped;
  cv::Mat1b small;
  cv::resize(sc.pair.left, small, cv::Size(), 0.5, 0.5);
  EXPECT_EQ(InputErrorOf([&] { sc.Match(small, sc.pair.right); }),
            "L.png: image is 1296x972 but the rig was calibrated for 2592x1944: use the images of the calibrated cameras");
}

}  // namespace
}  // namespace flatscan
