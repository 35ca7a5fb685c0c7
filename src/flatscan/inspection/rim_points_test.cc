#include "flatscan/inspection/rim_points.h"

#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

#include "flatscan/simulation/simulation_test_util.h"

namespace flatscan {
namespace {

// A warped part resting tilted on its three contacts (about 0.019 rad; paper rig, true
// calibration): the triangulated rim against the true bottom rim.
struct RimScene {
  Station station = BuildStation(ScenePreset("paper"));
  StereoRectification rectification{station.rig};
  PartGeometry geometry;
  PartTruth truth;
  StereoOutline outline;
  RimScene() {
    geometry.half_width = 7.5;
    geometry.half_height = 5.2;
    geometry.corner_radius = 0.9;
    geometry.thickness = 0.25;
    geometry.warp = {-0.1212, 0.1662, 0.1103, -0.0475, -0.0397, 0.0567, -0.0252};
    truth = RestAndPlacePart(geometry, 33.0, {0.5, 1.0});
    const auto [left, right] = testing::RenderPair(station, geometry, truth.support_from_part, 300);
    std::vector<std::pair<std::string, double>> stages;
    StageTimer timer(&stages);
    outline = MatchStereoOutline(rectification, station.plane, left, right, Params(), "L", "R", &timer);
  }
  InspectionParams Params() const {
    InspectionParams params;
    params.thickness_mm = geometry.SideHeight();
    return params;
  }
  // |measured - true| height of each rim point, the truth taken at the nearest true
  // rim sample (0.05 mm apart: the rim's height changes by well under 0.1 um there).
  std::vector<double> HeightErrors(const RimPoints& rim) const {
    std::vector<Eigen::Vector3d> true_rim;
    for (const Eigen::Vector3d& p : truth.rim) true_rim.push_back(station.cam1_from_support * p);
    std::vector<double> errors;
    for (size_t i = 0; i < rim.rim.size(); ++i) {
      const Eigen::Vector3d& p = rim.rim.points[i];
      const auto nearest = std::min_element(true_rim.begin(), true_rim.end(), [&](const auto& a, const auto& b) {
        return (a - p).squaredNorm() < (b - p).squaredNorm();
      });
      errors.push_back(std::abs(rim.rim.heights[i] - station.plane.Height(*nearest)));
    }
    std::sort(errors.begin(), errors.end());
    return errors;
  }
};

const RimScene& Scene() {
  static const RimScene scene;
  return scene;
}

TEST(TriangulateRim, HeightsOfTheBottomRimWithinMicrons) {
  const RimScene& sc = Scene();
  const RimPoints rim = TriangulateRim(sc.rectification, sc.station.plane, sc.outline, sc.Params());
  ASSERT_GT(rim.rim.size(), 1500u);
  ASSERT_EQ(rim.rim_chain_index.size(), rim.rim.size());
  ASSERT_EQ(rim.rim_point.size(), rim.rim.size());
  // Chain order, and each rim sample is its point's.
  EXPECT_TRUE(std::is_sorted(rim.rim_chain_index.begin(), rim.rim_chain_index.end()));
  for (size_t i = 0; i < rim.rim.size(); ++i) EXPECT_EQ(rim.points[rim.rim_point[i]].cam1, rim.rim.points[i]);
  const std::vector<double> errors = sc.HeightErrors(rim);
  std::printf("rim heights: |error| median %.2f um, p95 %.2f um (%zu points), side tilt %.4f rad\n",
              1000 * errors[errors.size() / 2], 1000 * errors[errors.size() * 95 / 100], errors.size(), rim.side_tilt_rad);
  EXPECT_LT(errors[errors.size() / 2], 0.002);
  EXPECT_LT(errors[errors.size() * 95 / 100], 0.006);
}

TEST(TriangulateRim, SideFacesFollowTheRestTiltAndTheThicknessMatters) {
  const RimScene& sc = Scene();
  const RimPoints rim = TriangulateRim(sc.rectification, sc.station.plane, sc.outline, sc.Params());
  // The sheet's normal at rest: the part's z axis in the support frame.
  const double true_tilt = std::acos(sc.truth.support_from_part.rotation(2, 2));
  ASSERT_GT(true_tilt, 0.012);
  EXPECT_NEAR(rim.side_tilt_rad, true_tilt, 0.15 * true_tilt);
  InspectionParams no_tilt = sc.Params();
  no_tilt.side_faces = SideFaceModel::kSupportNormal;
  EXPECT_EQ(TriangulateRim(sc.rectification, sc.station.plane, sc.outline, no_tilt).side_tilt_rad, 0.0);
  InspectionParams no_correction = sc.Params();
  no_correction.thickness_correction = false;
  const std::vector<double> uncorrected =
      sc.HeightErrors(TriangulateRim(sc.rectification, sc.station.plane, sc.outline, no_correction));
  EXPECT_GT(uncorrected[uncorrected.size() / 2], 0.05);  // a large fraction of the 0.25 mm sheet
}

// The face directions per model: the support normal, the fitted sheet's normal at the
// centre or at the point, and a tilt beyond the cap taken at the cap in its azimuth.
TEST(SideFaceField, DirectionsPerModelAndTheTiltCap) {
  SupportPlane plane;
  plane.normal = Eigen::Vector3d(0, 0, -1);
  plane.point = Eigen::Vector3d(0, 0, 200);
  // A sheet bent along x: height 0.002 x^2 (mm), slope 0.004 x.
  HeightSamples rim;
  // (A rectangle's sides: on an ellipse x^2 and y^2 would not be told apart.)
  for (int k = 0; k < 400; ++k) {
    const double u = -1 + 2.0 * (k % 100) / 100;
    const int side = k / 100;
    const double x = side < 2 ? (side == 0 ? 8 : -8) : 8 * u, y = side < 2 ? 5 * u : (side == 2 ? 5 : -5);
    const double h = 0.002 * x * x;
    rim.Add(Eigen::Vector3d(x, y, 200 - h), h, 1.0);
  }
  WarpFitOptions fit;
  fit.curvature_ridge = fit.curvature_prior_mm = 0;
  const WarpSurface warp = WarpSurface::Fit(plane, rim, {}, fit);
  const Eigen::Vector3d centre(0, 0, 200), edge(8, 0, 200 - 0.128);
  EXPECT_EQ(SideFaceField(plane).At(edge), plane.normal);
  const SideFaceField at_centre(SideFaceModel::kCentreNormal, warp, centre, 0.25);
  EXPECT_LT((at_centre.At(edge) - plane.normal).norm(), 1e-9);
  const SideFaceField local(SideFaceModel::kLocalNormal, warp, centre, 0.25);
  EXPECT_NEAR(local.Tilt(edge), std::atan(0.032), 1e-6);
  // Heights grow toward -z here: the sheet rises toward +x, its normal leans to -x.
  EXPECT_NEAR(local.At(edge).x(), -std::sin(std::atan(0.032)), 1e-6);
  const SideFaceField capped(SideFaceModel::kLocalNormal, warp, centre, 0.02);
  EXPECT_NEAR(capped.Tilt(edge), 0.02, 1e-12);
  EXPECT_LT((capped.At(edge).head<2>().normalized() - local.At(edge).head<2>().normalized()).norm(), 1e-12);
  // A point never triangulated gets the centre's direction.
  EXPECT_LT((local.At(Eigen::Vector3d::Constant(NAN)) - plane.normal).norm(), 1e-9);
}

}  // namespace
}  // namespace flatscan
