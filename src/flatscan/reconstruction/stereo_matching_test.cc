#include "flatscan/reconstruction/stereo_matching.h"

#include <cmath>
#include <set>

#include <gtest/gtest.h>

#include "flatscan/reconstruction/rectified_stereo.h"
#include "flatscan/simulation/simulation_test_util.h"

namespace flatscan {
namespace {

// A flat 12 x 8 mm part of a 0.1 mm sheet, turned 30 degrees on the paper rig's
// support, its two images cut by the rectified rows.
struct MatchingScene {
  Station station = BuildStation(ScenePreset("paper"));
  StereoRectification rectification{station.rig};
  cv::Mat1b left, right;
  std::vector<RowCrossing> left_crossings, right_crossings;
  MatchingScene() {
    PartGeometry g;
    g.half_width = 6.0;
    g.half_height = 4.0;
    g.corner_radius = 0.8;
    g.thickness = 0.1;
    std::tie(left, right) = testing::RenderPair(station, g, RestAndPlacePart(g, 30.0, {1.0, -2.0}).support_from_part, 41);
    left_crossings = CrossRows(DetectBoundary(left), [&](const Eigen::Vector2d& p) { return rectification.left().RawToRectified(p); });
    right_crossings =
        CrossRows(DetectBoundary(right), [&](const Eigen::Vector2d& p) { return rectification.right().RawToRectified(p); });
  }
  // Disparities of the left ray's points from `lo_mm` to `hi_mm` above the true plane.
  DisparityRange HeightRange(double lo_mm, double hi_mm) const {
    return [this, lo_mm, hi_mm](double x, int row) {
      const RectifiedStereo& s = rectification.stereo();
      const Eigen::Vector3d up = s.rect1_from_cam1 * station.plane.normal, on = s.rect1_from_cam1 * station.plane.point;
      const Eigen::Vector3d d = s.LeftRay(x, row);
      const double a = s.Disparity(d * (up.dot(on + lo_mm * up) / up.dot(d)));
      const double b = s.Disparity(d * (up.dot(on + hi_mm * up) / up.dot(d)));
      return std::pair<double, double>(std::min(a, b), std::max(a, b));
    };
  }
  double HeightOf(const StereoMatch& m) const {
    const RectifiedStereo& s = rectification.stereo();
    const RowCrossing& a = left_crossings[m.left];
    const Eigen::Vector3d rect1 = TriangulateRow(s, a.x, right_crossings[m.right].x, a.row);
    return station.plane.Height(s.rect1_from_cam1.transpose() * rect1);
  }
  std::vector<StereoMatch> Match(const DisparityRange& range, const MatchingParams& params = {}) const {
    return MatchCrossings(left_crossings, right_crossings, left, right, rectification.left(), rectification.right(), range,
                          params);
  }
};

const MatchingScene& Scene() {
  static const MatchingScene scene;
  return scene;
}

TEST(MatchCrossings, MatchesNearlyEveryUsableCrossingToItsOwnPartner) {
  const MatchingScene& sc = Scene();
  const std::vector<StereoMatch> matches = sc.Match(sc.HeightRange(-0.5, 5.0));
  int usable = 0;
  for (const RowCrossing& c : sc.left_crossings) usable += std::abs(c.nx) >= MatchingParams().min_abs_nx;
  ASSERT_GT(usable, 1000);
  EXPECT_GT(matches.size(), 0.97 * usable);
  std::set<int> rights;
  for (const StereoMatch& m : matches) {
    const RowCrossing &a = sc.left_crossings[m.left], &b = sc.right_crossings[m.right];
    EXPECT_EQ(a.row, b.row);
    EXPECT_EQ(a.nx > 0, b.nx > 0);
    EXPECT_TRUE(rights.insert(m.right).second) << "right crossing " << m.right << " matched twice";
    // Plain triangulation of a right match lies on the sheet's side face, up to the
    // thickness bias of edges seen differently ((Z / B) t, about 0.33 mm here); a
    // crossing of the part's other side would be tens of millimetres off.
    EXPECT_LT(std::abs(sc.HeightOf(m)), 0.4) << "row " << a.row;
  }
}

TEST(MatchCrossings, OnlyInsideTheDisparityRangeAndAwayFromTheRows) {
  const MatchingScene& sc = Scene();
  EXPECT_TRUE(sc.Match(sc.HeightRange(10.0, 20.0)).empty());  // no part there
  MatchingParams steep;
  steep.min_abs_nx = 0.5;
  const std::vector<StereoMatch> matches = sc.Match(sc.HeightRange(-0.5, 5.0), steep);
  ASSERT_FALSE(matches.empty());
  for (const StereoMatch& m : matches) {
    EXPECT_GE(std::abs(sc.left_crossings[m.left].nx), 0.5);
    EXPECT_GE(std::abs(sc.right_crossings[m.right].nx), 0.5);
  }
  EXPECT_LT(matches.size(), sc.Match(sc.HeightRange(-0.5, 5.0)).size());
}

TEST(MatchCrossings, TheLeftRightCheckOnlyRemovesMatches) {
  const MatchingScene& sc = Scene();
  MatchingParams unchecked;
  unchecked.left_right_check = false;
  const std::vector<StereoMatch> checked = sc.Match(sc.HeightRange(-0.5, 5.0));
  const std::vector<StereoMatch> all = sc.Match(sc.HeightRange(-0.5, 5.0), unchecked);
  EXPECT_GE(all.size(), checked.size());
  std::set<std::pair<int, int>> pairs;
  for (const StereoMatch& m : all) pairs.insert({m.left, m.right});
  for (const StereoMatch& m : checked) EXPECT_TRUE(pairs.count({m.left, m.right})) << m.left;
}

}  // namespace
}  // namespace flatscan
