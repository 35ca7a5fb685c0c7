#include "flatscan/inspection/part_uncertainty.h"

#include <cmath>

#include <gtest/gtest.h>

#include "flatscan/simulation/scene_config.h"
#include "flatscan/simulation/station.h"

namespace flatscan {
namespace {

// The paper station's true rig and plane, with four markers at (+-30, +-20) mm in
// the plane whose residuals are +r, -r, +r, -r.
struct PlaneAndRig {
  Station station = BuildStation(ScenePreset("paper"));
  SupportPlane plane = station.plane;
  Eigen::Vector3d e1 = plane.normal.unitOrthogonal(), e2 = plane.normal.cross(e1);
  static constexpr double kResidualMm = 0.0005;
  PlaneAndRig() {
    plane.markers.clear();
    plane.residuals_mm.clear();
    const double signs[4][3] = {{30, 20, 1}, {-30, 20, -1}, {-30, -20, 1}, {30, -20, -1}};
    for (const auto& s : signs) {
      plane.markers.push_back(At(s[0], s[1], s[2] * kResidualMm));
      plane.residuals_mm.push_back(s[2] * kResidualMm);
    }
  }
  // A point (x, y) in the plane's axes from its point, at height h.
  Eigen::Vector3d At(double x, double y, double h) const { return plane.point + x * e1 + y * e2 + h * plane.normal; }
  std::pair<Eigen::Vector2d, Eigen::Vector2d> Pixels(const Eigen::Vector3d& p) const {
    const StereoRig& rig = station.rig;
    return {rig.left.Project(p), rig.right.Project(rig.cam2_from_cam1 * p)};
  }
  RigReplicate Replicate(double baseline_scale) const {
    return {station.rig.left, station.rig.right,
            {station.rig.cam2_from_cam1.rotation, baseline_scale * station.rig.cam2_from_cam1.translation}};
  }
};

// Least-squares prediction variance of the plane from its residuals alone (no prior):
// s^2 = sum r^2 / (N - 3) = 4 r^2; at the centroid s^2 / N, at (30, 0) s^2 (1/4 + 30^2 /
// (4 30^2)).
TEST(PartUncertainty, PlaneHeightSdIsTheFittedPlanesPredictionSd) {
  const PlaneAndRig s;
  const StereoRig& rig = s.station.rig;
  const double r = PlaneAndRig::kResidualMm;
  UncertaintyOptions residuals_only;
  residuals_only.marker_prior_dof = 0;
  EXPECT_NEAR(PlaneHeightSd(rig, s.plane, s.At(0, 0, 0), residuals_only), r, 1e-12);
  EXPECT_NEAR(PlaneHeightSd(rig, s.plane, s.At(30, 0, 0.1), residuals_only), 2 * r * std::sqrt(0.5), 1e-12);
  SupportPlane three = s.plane;  // three markers define the plane: no estimate of their noise
  three.markers.pop_back();
  three.residuals_mm.pop_back();
  EXPECT_EQ(PlaneHeightSd(rig, three, s.At(0, 0, 0), residuals_only), 0.0);
}

// With the ring centres' noise e_m as a prior of nu0 degrees of freedom: one marker's
// height variance s^2 = (nu0 s0^2 + sum r^2) / (nu0 + N - 3), s0 = e_m g (g about 60
// um/px on the paper rig, so s0 about 0.27 um); three markers now get s0 alone.
TEST(PartUncertainty, PlaneHeightSdPoolsTheResidualsWithTheRingCentresNoise) {
  const PlaneAndRig s;
  const StereoRig& rig = s.station.rig;
  const UncertaintyOptions options;
  double s0_squared = 0;
  for (const Eigen::Vector3d& m : s.plane.markers) {
    const double g = HeightPerDisparityPx(rig, s.plane, rig.left.Project(m), rig.right.Project(rig.cam2_from_cam1 * m));
    s0_squared += std::pow(options.marker_disparity_px * g, 2) / 4;
  }
  EXPECT_GT(std::sqrt(s0_squared), 0.0002);
  EXPECT_LT(std::sqrt(s0_squared), 0.00035);
  const double r = PlaneAndRig::kResidualMm, nu0 = options.marker_prior_dof;
  const double pooled = (nu0 * s0_squared + 4 * r * r) / (nu0 + 1);
  EXPECT_NEAR(PlaneHeightSd(rig, s.plane, s.At(0, 0, 0)), std::sqrt(pooled / 4), 1e-9);

  SupportPlane three = s.plane;
  three.markers.pop_back();
  three.residuals_mm.assign(3, 0.0);
  const Eigen::Vector3d centroid = (three.markers[0] + three.markers[1] + three.markers[2]) / 3;
  const double u_three = PlaneHeightSd(rig, three, centroid);
  EXPECT_GT(u_three, 0.8 * std::sqrt(s0_squared / 3));
  EXPECT_LT(u_three, 1.2 * std::sqrt(s0_squared / 3));
}

// Scaling the baseline by 1 + e scales every triangulated point, markers included,
// about camera 1: a height h above the plane becomes (1 + e) h. Replicates at 1 + e and
// 1 - e in turn give heights h +- e h, whose jackknife SD is sqrt(n - 1) e h.
TEST(PartUncertainty, RigHeightSdIsTheJackknifeScatterOfTheHeight) {
  PlaneAndRig s;
  const auto [left, right] = s.Pixels(s.At(2, 3, 0.5));
  EXPECT_EQ(RigHeightSd(s.station.rig, s.plane, left, right), 0.0);  // no replicates
  constexpr double e = 1e-3;
  for (int i = 0; i < 4; ++i) s.station.rig.replicates.push_back(s.Replicate(i % 2 ? 1 - e : 1 + e));
  EXPECT_NEAR(RigHeightSd(s.station.rig, s.plane, left, right), std::sqrt(3.0) * e * 0.5, 1e-7);
  // A point on the plane stays on it under any scale.
  const auto [l0, r0] = s.Pixels(s.At(2, 3, 0.0));
  EXPECT_LT(RigHeightSd(s.station.rig, s.plane, l0, r0), 1e-8);
}

// The paper rig: Z = 202 mm, f = 11364 px (rectified), B = 60 mm, so a pixel of
// disparity is about Z^2 / (f B) = 60 um of depth; the height along the plane's normal
// differs from depth by the view's obliquity.
TEST(PartUncertainty, HeightPerDisparityPixelOfThePaperRig) {
  const PlaneAndRig s;
  const auto [left, right] = s.Pixels(s.At(0, 0, 0.1));
  const double g = HeightPerDisparityPx(s.station.rig, s.plane, left, right);
  EXPECT_GT(g, 0.045);
  EXPECT_LT(g, 0.075);
  std::printf("paper rig: %.1f um of height per pixel of disparity\n", 1000 * g);
  const std::vector<RimHeightPoint> points = {{s.At(0, 0, 0.1), 0.1, 0.0, false}};
  const PartUncertainty u = EstimatePartUncertainty(s.station.rig, s.plane, points, {{s.At(0, 0, 0.1), left, right}});
  EXPECT_NEAR(u.method_mm, UncertaintyOptions{}.method_disparity_px * g, 1e-12);
}

// U is the reach of the highest band: at the maximum 2 sqrt(u_rim^2 + u_cal^2); a
// completed point 3 um lower but 10 um uncertain reaches further, and says so.
TEST(PartUncertainty, TheHighestBandSetsUAndNamesAnUnmeasuredMaximum) {
  const PlaneAndRig s;
  const Eigen::Vector3d top = s.At(0, 0, 0.1), low = s.At(5, 0, 0.05);
  std::vector<RimHeightPoint> points = {{top, 0.1, 0.001, false}, {low, 0.05, 0.001, false}};
  const double u_plane = PlaneHeightSd(s.station.rig, s.plane, top);
  PartUncertainty u = EstimatePartUncertainty(s.station.rig, s.plane, points, {});
  EXPECT_NEAR(u.expanded_mm, 2 * std::sqrt(0.001 * 0.001 + u_plane * u_plane), 1e-12);
  EXPECT_FALSE(u.maximum_unmeasured);
  EXPECT_EQ(u.rig_replicates, 0);

  points.push_back({s.At(-5, 0, 0.097), 0.097, 0.010, true});
  u = EstimatePartUncertainty(s.station.rig, s.plane, points, {});
  EXPECT_NEAR(u.expanded_mm, -0.003 + 2 * std::sqrt(0.010 * 0.010 + u_plane * u_plane), 1e-12);
  EXPECT_TRUE(u.maximum_unmeasured);
  EXPECT_EQ(u.rim_mm, 0.010);
}

}  // namespace
}  // namespace flatscan
