#include "flatscan/simulation/coverage_renderer.h"

#include <cmath>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "flatscan/simulation/part_model.h"
#include "flatscan/simulation/station.h"

namespace flatscan {
namespace {

TEST(CoverageRenderer, MeanOfClampedLinearMatchesNumericIntegral) {
  for (double a0 : {-1.3, -0.2, 0.0, 0.3, 0.9, 1.4})
    for (double a1 : {-0.7, 0.1, 0.5, 1.0, 2.2}) {
      double sum = 0.0;
      const int n = 200000;
      for (int i = 0; i < n; ++i) sum += std::clamp(a0 + (a1 - a0) * (i + 0.5) / n, 0.0, 1.0);
      EXPECT_NEAR(MeanOfClampedLinear(a0, a1), sum / n, 1e-9) << a0 << " " << a1;
    }
}

// A flat part on the paper rig, tilted plane, distortion on.
struct FlatPartScene {
  Station station = BuildStation(ScenePreset("paper"));
  PartGeometry geometry;
  PartTruth truth;
  FlatPartScene(double thickness, double rotation_deg, Eigen::Vector2d position) {
    geometry.half_width = 8.0;
    geometry.half_height = 6.0;
    geometry.corner_radius = 1.0;
    geometry.thickness = thickness;
    truth = RestAndPlacePart(geometry, rotation_deg, position);
  }
  // Image x where row v meets the projection of the part-frame line
  // p(s) = origin + s * direction (s in [s0, s1]) at height z.
  double ProjectedXAtRow(RigSide camera, Eigen::Vector2d origin, Eigen::Vector2d direction, double z, double v) const {
    auto project = [&](double s) {
      const Eigen::Vector2d p = origin + s * direction;
      return station.GetCamera(camera).Project(station.CamFromSupport(camera) * (truth.support_from_part * Eigen::Vector3d(p.x(), p.y(), z)));
    };
    double lo = -5.0, hi = 5.0;
    const bool increasing = project(hi).y() > project(lo).y();
    for (int i = 0; i < 200; ++i) {
      const double mid = 0.5 * (lo + hi);
      ((project(mid).y() < v) == increasing ? lo : hi) = mid;
    }
    return project(0.5 * (lo + hi)).x();
  }
};

// Area-equivalent boundary position along row v: (u_a - 0.5) + sum of the uncovered
// fraction from u_a (fully uncovered) to u_b (fully covered), for a boundary with
// the part on its right; mirrored for the part on its left. Exact for straight edges.
double MeasuredCrossing(const CoverageTile& tile, int v, double x_guess, bool part_on_right) {
  const int u_a = static_cast<int>(std::floor(x_guess)) - 5, u_b = u_a + 11;
  double sum = 0.0;
  for (int u = u_a; u <= u_b; ++u) {
    const float c = tile.coverage(v - tile.roi.y, u - tile.roi.x);
    sum += part_on_right ? 1.0 - c : c;
  }
  const float first = tile.coverage(v - tile.roi.y, u_a - tile.roi.x), last = tile.coverage(v - tile.roi.y, u_b - tile.roi.x);
  EXPECT_EQ(first, part_on_right ? 0.0f : 1.0f);
  EXPECT_EQ(last, part_on_right ? 1.0f : 0.0f);
  return u_a - 0.5 + sum;
}

TEST(CoverageRenderer, ZeroThicknessSilhouetteMatchesAnalyticProjection) {
  // Rotated 15 degrees: the part's x = -a and x = +a edges cross image rows steeply.
  FlatPartScene scene(0.0, 15.0, Eigen::Vector2d(3.0, -2.0));
  const PartOccluder occluder(scene.geometry, scene.truth.support_from_part);
  double worst = 0.0;
  for (const RigSide camera : {RigSide::kLeft, RigSide::kRight}) {
    const CoverageTile tile = RenderCoverage(scene.station.GetCamera(camera), scene.station.CamFromSupport(camera), occluder);
    ASSERT_FALSE(tile.roi.empty());
    for (int side = 0; side < 2; ++side) {
      const double x_edge = side == 0 ? -8.0 : 8.0;
      // Rows through the straight part of the edge (|y| < 4 mm of its 2 x 5 mm).
      for (double s : {-4.0, -2.0, 0.0, 1.5, 3.5}) {
        const Eigen::Vector3d p = scene.station.CamFromSupport(camera) * (scene.truth.support_from_part * Eigen::Vector3d(x_edge, s, 0));
        const int v = static_cast<int>(std::round(scene.station.GetCamera(camera).Project(p).y()));
        const double analytic = scene.ProjectedXAtRow(camera, {x_edge, 0.0}, {0.0, 1.0}, 0.0, v);
        // The left camera looks down with image x along support +x (rotation 15 deg
        // keeps that): the part lies to the right of its x = -a edge.
        const double measured = MeasuredCrossing(tile, v, analytic, side == 0);
        EXPECT_NEAR(measured, analytic, 0.01) << "camera " << int(camera) << " side " << side << " row " << v;
        worst = std::max(worst, std::abs(measured - analytic));
      }
    }
  }
  RecordProperty("worst_px", fmt::format("{:.3e}", worst));
  EXPECT_GT(worst, 0.0);  // the two computations are independent, not the same numbers
}

TEST(CoverageRenderer, SheetThicknessSilhouetteComesFromBottomOrTopEdge) {
  // A 0.3 mm sheet, unrotated, at the plane centre. The left camera sits at
  // x = -30 mm: it lies outside the part's x = -a side (outward normal -x), so that
  // side's silhouette is the sheet's bottom edge; on the x = +a side it is the top edge.
  const double t = 0.3;
  FlatPartScene scene(t, 0.0, Eigen::Vector2d(0.0, 0.0));
  const PartOccluder occluder(scene.geometry, scene.truth.support_from_part);
  const CoverageTile tile = RenderCoverage(scene.station.GetCamera(RigSide::kLeft), scene.station.CamFromSupport(RigSide::kLeft), occluder);
  for (double s : {-3.0, 0.0, 3.0}) {
    for (int side = 0; side < 2; ++side) {
      const double x_edge = side == 0 ? -8.0 : 8.0;
      const Eigen::Vector3d p = scene.station.CamFromSupport(RigSide::kLeft) * (scene.truth.support_from_part * Eigen::Vector3d(x_edge, s, 0));
      const int v = static_cast<int>(std::round(scene.station.GetCamera(RigSide::kLeft).Project(p).y()));
      const double bottom = scene.ProjectedXAtRow(RigSide::kLeft, {x_edge, 0.0}, {0.0, 1.0}, 0.0, v);
      const double top = scene.ProjectedXAtRow(RigSide::kLeft, {x_edge, 0.0}, {0.0, 1.0}, t, v);
      ASSERT_GT(std::abs(top - bottom), 0.5) << "edges must be distinguishable";
      const double measured = MeasuredCrossing(tile, v, 0.5 * (top + bottom), side == 0);
      const double expected = side == 0 ? bottom : top;
      EXPECT_NEAR(measured, expected, 0.01) << "side " << side << " row " << v << " top " << top << " bottom " << bottom;
    }
  }
}

}  // namespace
}  // namespace flatscan
