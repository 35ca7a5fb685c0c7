#include "flatscan/calibration/rectification.h"

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "flatscan/geometry/geometry_test_util.h"
#include "flatscan/simulation/station.h"

namespace flatscan {
namespace {

using testing::GridOverImage;

// The 'compact' preset with a wider, more distorted lens: the four raw image corners
// are at normalized radius 0.65, where cv::undistortPoints' 5 default iterations are
// far from converged.
StereoRig WideAngleRig() {
  SceneConfig scene = ScenePreset("compact");
  for (CameraSpec* c : {&scene.left_camera, &scene.right_camera}) {
    c->focal_length_mm = 6.0;
    c->distortion = {-0.35, 0.15, 0.0004, -0.0003, -0.03};
  }
  return BuildStation(scene).rig;
}

// cv::undistortPoints to the rectified image of one camera of `rig`.
Eigen::Vector2d OpenCvRawToRectified(const StereoRig& rig, RigSide side, const Eigen::Vector2d& raw,
                                     const cv::TermCriteria& criteria) {
  const Camera& camera = side == RigSide::kLeft ? rig.left : rig.right;
  const Rectification& r = rig.rectification;
  std::vector<cv::Point2d> in = {{raw.x(), raw.y()}}, out;
  cv::undistortPoints(in, out, camera.CameraMatrix(), camera.DistortionVector(),
                      side == RigSide::kLeft ? r.R1 : r.R2, side == RigSide::kLeft ? r.P1 : r.P2, criteria);
  return {out[0].x, out[0].y};
}

const cv::TermCriteria kStrictCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 200, 1e-14);
// What cv::undistortPoints does without a criteria argument in OpenCV 4.6.
const cv::TermCriteria kOpenCvDefaultCriteria(cv::TermCriteria::COUNT, 5, 0.01);

class RectificationPresets : public ::testing::TestWithParam<std::string> {};

TEST_P(RectificationPresets, RoundTripIsWithin1e4PixelEverywhere) {
  const StereoRig rig = BuildStation(ScenePreset(GetParam())).rig;
  for (RigSide side : {RigSide::kLeft, RigSide::kRight}) {
    const PointRectifier rectifier(rig, side);
    const std::vector<Eigen::Vector2d> raw = GridOverImage(rectifier.camera(), 40);
    const std::vector<Eigen::Vector2d> rectified = rectifier.RawToRectified(raw);
    const std::vector<Eigen::Vector2d> back = rectifier.RectifiedToRaw(rectified);
    ASSERT_EQ(back.size(), raw.size());
    double worst = 0;
    for (size_t i = 0; i < raw.size(); ++i) {
      ASSERT_TRUE(rectified[i].allFinite()) << raw[i].transpose();
      worst = std::max(worst, (back[i] - raw[i]).norm());
    }
    EXPECT_LT(worst, 1e-4) << GetParam() << " side " << int(side);
    // And the other way round, over the rectified images of the same points.
    const std::vector<Eigen::Vector2d> again = rectifier.RawToRectified(back);
    for (size_t i = 0; i < raw.size(); ++i) EXPECT_LT((again[i] - rectified[i]).norm(), 1e-4);
  }
}

TEST_P(RectificationPresets, AScenePointLandsOnTheSameRowInBothImages) {
  const Station station = BuildStation(ScenePreset(GetParam()));
  const StereoRig& rig = station.rig;
  const PointRectifier left(rig, RigSide::kLeft), right(rig, RigSide::kRight);
  Eigen::Matrix3d R1;
  Eigen::Matrix<double, 3, 4> P1, P2;
  cv::cv2eigen(rig.rectification.R1, R1);
  cv::cv2eigen(rig.rectification.P1, P1);
  cv::cv2eigen(rig.rectification.P2, P2);
  int checked = 0;
  for (double x = -1; x <= 1; x += 0.25)
    for (double y = -1; y <= 1; y += 0.25) {
      const Eigen::Vector3d p_support(x * station.common_half_size.x(), y * station.common_half_size.y(), 0.0);
      const Eigen::Vector3d p1 = station.cam1_from_support * p_support;
      const Eigen::Vector3d p2 = rig.cam2_from_cam1 * p1;
      const Eigen::Vector2d l = left.RawToRectified(rig.left.Project(p1));
      const Eigen::Vector2d r = right.RawToRectified(rig.right.Project(p2));
      EXPECT_NEAR(l.y(), r.y(), 1e-6) << x << " " << y;
      // P1 and P2 project points given in the rectified frame of camera 1, R1 X1: the
      // sparse mapping of the raw projections must land exactly there.
      Eigen::Vector4d xh;
      xh << R1 * p1, 1.0;
      const Eigen::Vector3d l_expected = P1 * xh, r_expected = P2 * xh;
      EXPECT_LT((l - l_expected.hnormalized()).norm(), 1e-6);
      EXPECT_LT((r - r_expected.hnormalized()).norm(), 1e-6);
      ++checked;
    }
  EXPECT_EQ(checked, 81);
}

TEST_P(RectificationPresets, AgreesWithStrictOpenCvUndistortPointsInside) {
  const StereoRig rig = BuildStation(ScenePreset(GetParam())).rig;
  for (RigSide side : {RigSide::kLeft, RigSide::kRight}) {
    const PointRectifier rectifier(rig, side);
    const Camera& camera = rectifier.camera();
    for (const Eigen::Vector2d& raw : GridOverImage(camera, 10)) {
      if (!camera.InImage(raw, 0.1 * camera.height)) continue;  // interior points
      const Eigen::Vector2d ours = rectifier.RawToRectified(raw);
      const Eigen::Vector2d opencv = OpenCvRawToRectified(rig, side, raw, kStrictCriteria);
      EXPECT_LT((ours - opencv).norm(), 1e-3) << raw.transpose();
    }
  }
}

TEST_P(RectificationPresets, RowSpacingMatchesTheFocalLengthRatioAtTheCentre) {
  const StereoRig rig = BuildStation(ScenePreset(GetParam())).rig;
  for (RigSide side : {RigSide::kLeft, RigSide::kRight}) {
    const PointRectifier rectifier(rig, side);
    const RowSpacing spacing = RectifiedRowSpacing(rig, side);
    // Near the centre distortion is negligible and the rectifying rotation is small, so
    // one rectified row is fy / f' raw pixels.
    const double expected = rectifier.camera().fy / rectifier.RectifiedCameraMatrix()(1, 1);
    EXPECT_NEAR(spacing.centre_px, expected, 0.02 * expected);
    EXPECT_LE(spacing.min_px, spacing.centre_px);
    EXPECT_GE(spacing.max_px, spacing.centre_px);
    EXPECT_GT(spacing.min_px, 0.5 * expected);
    EXPECT_LT(spacing.max_px, 2.0 * expected);
  }
}

INSTANTIATE_TEST_SUITE_P(Rectification, RectificationPresets, ::testing::Values("paper", "compact"));

TEST(Rectification, DefaultOpenCvIterationsAreNotEnoughNearTheCorner) {
  // Measured at the top-left raw corner, against our exact mapping:
  //   'compact' preset: 5 default iterations err by ~3e-6 px (converged enough);
  //   wide-angle variant: by ~0.4 px, while the strict criteria and our Newton
  //   undistortion agree to 1e-6 px and round-trip to 1e-4 px.
  const Eigen::Vector2d corner(-0.5, -0.5);
  const StereoRig compact = BuildStation(ScenePreset("compact")).rig;
  const PointRectifier compact_left(compact, RigSide::kLeft);
  const Eigen::Vector2d compact_exact = compact_left.RawToRectified(corner);
  const double compact_default_error =
      (OpenCvRawToRectified(compact, RigSide::kLeft, corner, kOpenCvDefaultCriteria) - compact_exact).norm();
  const double compact_strict_error =
      (OpenCvRawToRectified(compact, RigSide::kLeft, corner, kStrictCriteria) - compact_exact).norm();
  EXPECT_GT(compact_default_error, 10 * compact_strict_error);
  EXPECT_LT(compact_strict_error, 1e-6);

  const StereoRig wide = WideAngleRig();
  const PointRectifier wide_left(wide, RigSide::kLeft);
  const Eigen::Vector2d wide_exact = wide_left.RawToRectified(corner);
  ASSERT_TRUE(wide_exact.allFinite());
  EXPECT_LT((wide_left.RectifiedToRaw(wide_exact) - corner).norm(), 1e-4);
  const double wide_default_error =
      (OpenCvRawToRectified(wide, RigSide::kLeft, corner, kOpenCvDefaultCriteria) - wide_exact).norm();
  const double wide_strict_error =
      (OpenCvRawToRectified(wide, RigSide::kLeft, corner, kStrictCriteria) - wide_exact).norm();
  EXPECT_GT(wide_default_error, 0.1);
  EXPECT_LT(wide_strict_error, 1e-3);
  RecordProperty("compact_default_error_px", std::to_string(compact_default_error));
  RecordProperty("wide_default_error_px", std::to_string(wide_default_error));
  std::printf("top-left corner, cv::undistortPoints default 5 iterations: compact %.2e px, wide-angle %.3f px\n",
              compact_default_error, wide_default_error);
}

TEST(Rectification, WideAngleRoundTripIsExactOverTheWholeImage) {
  const StereoRig rig = WideAngleRig();
  for (RigSide side : {RigSide::kLeft, RigSide::kRight}) {
    const PointRectifier rectifier(rig, side);
    for (const Eigen::Vector2d& raw : GridOverImage(rectifier.camera(), 24)) {
      const Eigen::Vector2d rectified = rectifier.RawToRectified(raw);
      ASSERT_TRUE(rectified.allFinite()) << raw.transpose();
      EXPECT_LT((rectifier.RectifiedToRaw(rectified) - raw).norm(), 1e-4) << raw.transpose();
    }
  }
}

TEST(Rectification, PointsBeyondTheFoldOfTheLensModelAreNaN) {
  // A lens model whose radial distortion r (1 + k1 r^2) folds back at r = 1/sqrt(3 |k1|):
  // pixels beyond the largest distorted radius have no physical ray.
  StereoRig rig = BuildStation(ScenePreset("compact")).rig;
  rig.left.dist = {-0.5, 0, 0, 0, 0, 0, 0, 0};
  rig.ComputeRectification();
  const PointRectifier rectifier(rig, RigSide::kLeft);
  // Largest distorted radius: r = 1/sqrt(1.5) gives r_d = r (1 - 0.5 r^2) = 0.544.
  const double beyond = 0.6 * rig.left.fx;
  const Eigen::Vector2d outside(rig.left.cx + beyond, rig.left.cy);
  EXPECT_FALSE(rectifier.RawToRectified(outside).allFinite());
  const Eigen::Vector2d inside(rig.left.cx + 0.3 * rig.left.fx, rig.left.cy);
  EXPECT_TRUE(rectifier.RawToRectified(inside).allFinite());
}

}  // namespace
}  // namespace flatscan
