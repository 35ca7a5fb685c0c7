#include "flatscan/reconstruction/outlier_filter.h"

#include <gtest/gtest.h>

#include "flatscan/util/random.h"

namespace flatscan {
namespace {

TEST(OutlierFilter, KeepsDenseCurveAndDropsIsolatedPoints) {
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 200; ++i) points.emplace_back(0.05 * i, 0.0, 200.0);  // 0.05 mm apart
  points.emplace_back(5.0, 3.0, 200.0);                                     // isolated
  points.emplace_back(5.0, 0.0, 203.0);                                     // 3 mm off the curve
  const std::vector<bool> keep = RadiusOutlierFilter(points, 0.2, 3);
  for (int i = 0; i < 200; ++i) EXPECT_TRUE(keep[i]) << i;
  EXPECT_FALSE(keep[200]);
  EXPECT_FALSE(keep[201]);
}

TEST(OutlierFilter, MatchesBruteForceCounts) {
  Random rng(3);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 500; ++i) points.emplace_back(rng.Uniform(0, 5), rng.Uniform(0, 5), rng.Uniform(0, 0.5));
  const double radius = 0.4;
  const std::vector<bool> keep = RadiusOutlierFilter(points, radius, 4);
  for (size_t i = 0; i < points.size(); ++i) {
    int count = 0;
    for (size_t j = 0; j < points.size(); ++j)
      if (j != i && (points[j] - points[i]).squaredNorm() <= radius * radius) ++count;
    EXPECT_EQ(keep[i], count >= 4) << i;
  }
}

// A boundary stretch near the epipolar rows is sampled sparsely (one crossing per row
// is 1 / |n_x| pixels along it): with one radius its points lose their neighbours;
// with a radius of 2.5 spacings they keep them, and an isolated point still goes.
TEST(OutlierFilter, PerPointRadiusKeepsSparseStretch) {
  std::vector<Eigen::Vector3d> points;
  std::vector<double> radii;
  for (int i = 0; i < 50; ++i) {
    points.emplace_back(0.15 * i, 0.0, 200.0);  // 0.15 mm apart
    radii.push_back(2.5 * 0.15);
  }
  points.emplace_back(3.0, 2.0, 200.0);
  radii.push_back(0.375);
  const std::vector<bool> one_radius = RadiusOutlierFilter(points, 0.25, 3);
  EXPECT_FALSE(one_radius[25]);
  const std::vector<bool> keep = RadiusOutlierFilter(points, radii, 3);
  for (int i = 2; i < 48; ++i) EXPECT_TRUE(keep[i]) << i;  // the ends have neighbours on one side only
  EXPECT_FALSE(keep[50]);
}

}  // namespace
}  // namespace flatscan
