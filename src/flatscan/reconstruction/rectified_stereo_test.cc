#include "flatscan/reconstruction/rectified_stereo.h"

#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "flatscan/simulation/station.h"

namespace flatscan {
namespace {

// A rounded corner of a tilted, sloped rim seen by the paper rig: wherever the two
// cameras see different edges (bottom for one, top for the other), the bottom point
// must come out exactly, with no straight-tangent or level-rim approximation.
TEST(TriangulateBottomPoint, ExactOnASlopedCornerWhereTheCamerasSeeDifferentEdges) {
  const Station st = BuildStation(ScenePreset("paper"));
  const StereoRectification rectification(st.rig);
  const RectifiedStereo& s = rectification.stereo();
  const Eigen::Vector3d up = s.rect1_from_cam1 * st.plane.normal;
  const Eigen::Vector3d e1 = up.unitOrthogonal(), e2 = up.cross(e1);
  const Eigen::Vector3d centre = s.rect1_from_cam1 * st.plane.point;
  const double radius = 0.4, thickness = 0.25, slope = 0.04;
  // Rim: a circle of radius 0.4 mm rising along e1 (a sloped corner).
  auto rim = [&](double angle) {
    const Eigen::Vector3d p = centre + radius * (std::cos(angle) * e1 + std::sin(angle) * e2);
    return Eigen::Vector3d(p + slope * (p - centre).dot(e1) * up);
  };
  auto project_left = [&](const Eigen::Vector3d& x) { return Eigen::Vector2d(s.f * x.x() / x.z() + s.cx1, s.f * x.y() / x.z() + s.cy); };
  auto project_right = [&](const Eigen::Vector3d& x) {
    return Eigen::Vector2d(s.f * (x.x() + s.tx) / x.z() + s.cx2, s.f * x.y() / x.z() + s.cy);
  };
  int tested = 0;
  for (double angle = 0.05; angle < 2 * M_PI; angle += 0.1) {
    const Eigen::Vector3d bottom = rim(angle);
    const Eigen::Vector3d outward = (std::cos(angle) * e1 + std::sin(angle) * e2);
    const int left_edge = (Eigen::Vector3d::Zero() - bottom).dot(outward) > 0 ? 0 : 1;
    const int right_edge = (s.RightCentre() - bottom).dot(outward) > 0 ? 0 : 1;
    if (left_edge == right_edge) continue;
    // Points where a camera's line of sight grazes the face are dropped by the
    // inspection (the silhouette runs along the face's generator there).
    auto grazing = [&](const Eigen::Vector3d& c) { return std::abs((c - bottom).normalized().dot(outward)) < 0.02; };
    if (grazing(Eigen::Vector3d::Zero()) || grazing(s.RightCentre())) continue;
    // Move along the rim until the left-seen edge point lies on an integer row.
    double a = angle;
    for (int it = 0; it < 30; ++it) {
      const double v = project_left(rim(a) + left_edge * thickness * up).y();
      const double dv = (project_left(rim(a + 1e-6) + left_edge * thickness * up).y() - v) / 1e-6;
      a -= (v - std::round(v)) / dv;
    }
    const Eigen::Vector3d truth = rim(a);
    const Eigen::Vector2d left = project_left(truth + left_edge * thickness * up);
    // The right silhouette: the right-seen edge, densely, and its crossing with the row.
    std::vector<Eigen::Vector2d> silhouette;
    double u_right = std::nan("");
    for (double b = a - 0.6; b <= a + 0.6; b += 0.005) {
      silhouette.push_back(project_right(rim(b) + right_edge * thickness * up));
      const size_t k = silhouette.size();
      if (k > 1 && (silhouette[k - 2].y() - left.y()) * (silhouette[k - 1].y() - left.y()) <= 0) {
        const double f = (left.y() - silhouette[k - 2].y()) / (silhouette[k - 1].y() - silhouette[k - 2].y());
        if (std::isnan(u_right) || std::abs(b - a) < 0.3) u_right = silhouette[k - 2].x() + f * (silhouette[k - 1].x() - silhouette[k - 2].x());
      }
    }
    ASSERT_FALSE(std::isnan(u_right));
    const Eigen::Vector3d out_world = std::cos(a) * e1 + std::sin(a) * e2;
    // The image normal: the outward direction projected into the left image.
    const Eigen::Vector3d seen = truth + left_edge * thickness * up;
    const Eigen::Vector2d normal_left = (project_left(seen + 0.01 * out_world) - left).normalized();
    const BottomPoint bp = TriangulateBottomPoint(s, left.x(), std::round(left.y()), normal_left, silhouette, u_right, up, thickness);
    ASSERT_TRUE(bp.valid);
    EXPECT_EQ(EdgeRise(bp.left_edge), left_edge);
    EXPECT_EQ(EdgeRise(bp.right_edge), right_edge);
    // Exact up to the polyline's chords (5e-3 rad steps) and the tangent's level lift.
    EXPECT_LT((bp.rect1 - truth).norm(), 2e-4) << "angle " << a;
    ++tested;
  }
  EXPECT_GT(tested, 10);
}

// The rectified geometry (RectifiedStereo) is the one the point mappings use: a scene
// point's two rectified images triangulate back to it, and its disparity is the one
// Disparity() predicts.
class TriangulateRowPresets : public ::testing::TestWithParam<std::string> {};

TEST_P(TriangulateRowPresets, RecoversWhatTheRectifiedCamerasSee) {
  const Station station = BuildStation(ScenePreset(GetParam()));
  const StereoRectification rectification(station.rig);
  const RectifiedStereo& s = rectification.stereo();
  EXPECT_EQ(&rectification.side(RigSide::kLeft), &rectification.left());
  EXPECT_EQ(&rectification.side(RigSide::kRight), &rectification.right());
  int checked = 0;
  for (double x = -1; x <= 1; x += 0.5)
    for (double y = -1; y <= 1; y += 0.5)
      for (double z : {0.0, 2.0}) {
        const Eigen::Vector3d p1 = station.cam1_from_support *
                                   Eigen::Vector3d(x * station.common_half_size.x(), y * station.common_half_size.y(), z);
        const Eigen::Vector2d l = rectification.left().RawToRectified(station.rig.left.Project(p1));
        const Eigen::Vector2d r =
            rectification.right().RawToRectified(station.rig.right.Project(station.rig.cam2_from_cam1 * p1));
        const Eigen::Vector3d p_rect1 = s.rect1_from_cam1 * p1;
        EXPECT_NEAR(l.x() - r.x(), s.Disparity(p_rect1), 1e-6);
        EXPECT_LT((TriangulateRow(s, l.x(), r.x(), l.y()) - p_rect1).norm(), 1e-6);
        ++checked;
      }
  EXPECT_EQ(checked, 50);
}

INSTANTIATE_TEST_SUITE_P(RectifiedStereo, TriangulateRowPresets, ::testing::Values("paper", "compact"));

}  // namespace
}  // namespace flatscan
