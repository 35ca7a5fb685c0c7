#include "flatscan/simulation/dataset.h"

#include <cmath>
#include <cstdio>
#include <vector>

#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>

#include "flatscan/boundary/boundary.h"
#include "flatscan/simulation/station.h"
#include "flatscan/util/error.h"

namespace flatscan {
namespace {

// RMS distance (px) of the outline's points to a straight line fitted to each of the
// four sides of a flat rectangular part (points whose normal lies within 1 degree of
// their side's: the corners' arcs left out).
double StraightSideRms(const cv::Mat1b& image) {
  const BoundaryResult boundary = DetectBoundary(image);
  // The sides' common direction modulo 90 degrees: the mean of the normals' angle times 4.
  Eigen::Vector2d sum4 = Eigen::Vector2d::Zero();
  for (const EdgePoint& p : boundary.points) {
    const double angle = std::atan2(p.ny, p.nx);
    sum4 += Eigen::Vector2d(std::cos(4 * angle), std::sin(4 * angle));
  }
  const double first_angle = std::atan2(sum4.y(), sum4.x()) / 4;
  std::vector<std::vector<Eigen::Vector2d>> sides(4);
  for (const EdgePoint& p : boundary.points) {
    const double turns = (std::atan2(p.ny, p.nx) - first_angle) / (M_PI / 2);
    const long side = std::lround(turns);
    if (std::abs(turns - side) > 1.0 / 90) continue;
    sides[((side % 4) + 4) % 4].emplace_back(p.x, p.y);
  }
  double sum_squares = 0;
  size_t count = 0;
  for (const std::vector<Eigen::Vector2d>& side : sides) {
    if (side.size() < 50) return NAN;
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (const Eigen::Vector2d& q : side) mean += q;
    mean /= static_cast<double>(side.size());
    Eigen::Matrix2d scatter = Eigen::Matrix2d::Zero();
    for (const Eigen::Vector2d& q : side) scatter += (q - mean) * (q - mean).transpose();
    const Eigen::Vector2d normal = Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(scatter).eigenvectors().col(0);
    for (const Eigen::Vector2d& q : side) sum_squares += std::pow(normal.dot(q - mean), 2);
    count += side.size();
  }
  return std::sqrt(sum_squares / static_cast<double>(count));
}

// A flat rectangle on a distortion-free rig without noise images its sides as straight
// lines. The blur sampled at whole pixels (blur_subpixels 1) moves the fitted edge with
// its pixel phase: along a side 3 degrees off the pixel columns the phase runs through a
// cycle every 19 px, longer than the boundary's smoothing along the chain, and the side
// ripples (measured: 0.019 / 0.017 / 0.010 / 0.005 / 0.002 px RMS at 2 / 4 / 6 / 10 /
// 20 degrees). The blur on 3 x 3 sub-pixels keeps the profile's shape at every phase:
// 0.0017-0.0019 px at every angle (docs/simulator.md).
TEST(Dataset, TheBlurOnSubpixelsKeepsAStraightEdgeStraight) {
  SceneConfig scene = ScenePreset("paper");
  scene.left_camera.distortion.assign(5, 0.0);
  scene.right_camera.distortion.assign(5, 0.0);
  scene.optics.noise_sigma_grey = 0;
  scene.optics.blur_sigma_px = 0.7;
  PartGeometry g;
  g.half_width = 8;
  g.half_height = 5;
  g.corner_radius = 0.5;
  g.thickness = 0.2;
  const PartTruth truth = RestAndPlacePart(g, 3.0, {0.0, 0.0});
  double rms[2];
  for (int i = 0; i < 2; ++i) {
    scene.optics.blur_subpixels = i == 0 ? 1 : 3;
    const Station st = BuildStation(scene);
    rms[i] = StraightSideRms(RenderPartImage(st, RigSide::kLeft, g, truth.support_from_part, 1, false));
  }
  std::printf("straight sides: RMS %.4f px sampled blur, %.4f px on 3 x 3 sub-pixels\n", rms[0], rms[1]);
  EXPECT_GT(rms[0], 0.012);  // measured 0.0182
  EXPECT_LT(rms[1], 0.004);  // 0.0018
}

TEST(Dataset, TheBlurOnSubpixelsRefusesTheVaryingDefocusBlur) {
  SceneConfig scene = ScenePreset("paper");
  scene.optics.blur_subpixels = 2;
  const Station st = BuildStation(scene);
  PartGeometry g;
  ImageDefects defects;
  defects.f_number = 4;
  try {
    RenderPartImage(st, RigSide::kLeft, g, RestAndPlacePart(g, 20.0, {0.0, 0.0}).support_from_part, 1, false, defects);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "scene: optics.blur_subpixels 2 with image_effects.f_number: the varying blur is rendered "
                           "on whole pixels only (expected blur_subpixels 1)");
  }
}

// The waviness is drawn from its own seed: the same parts, in the same places, with
// and without it; only the wave and the truth that follows it differ.
TEST(Dataset, WavinessLeavesThePartsAndTheirPlacementsAsTheyWere) {
  const Station smooth = BuildStation(ScenePreset("paper"));
  Station wavy = smooth;
  wavy.scene.part.waviness_um = {5, 5};
  Random a(3), b(3);
  for (int i = 0; i < 3; ++i) {
    const SimulatedPart p = SampleSimulatedPart(smooth, i, a), q = SampleSimulatedPart(wavy, i, b);
    EXPECT_EQ(p.geometry.warp.wave_mm, 0.0);
    EXPECT_EQ(q.geometry.warp.wave_mm, 0.005);
    EXPECT_EQ(p.geometry.warp.bend_x, q.geometry.warp.bend_x);
    EXPECT_EQ(p.geometry.half_width, q.geometry.half_width);
    ASSERT_EQ(p.shots.size(), q.shots.size());
    EXPECT_EQ(p.shots[0].rotation_deg, q.shots[0].rotation_deg);
    EXPECT_EQ(p.shots[0].position, q.shots[0].position);
    EXPECT_NE(p.shots[0].truth.flatness_mm, q.shots[0].truth.flatness_mm);
  }
}

}  // namespace
}  // namespace flatscan
