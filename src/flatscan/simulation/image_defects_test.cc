#include "flatscan/simulation/image_defects.h"

#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "flatscan/simulation/dataset.h"
#include "flatscan/simulation/image_formation.h"
#include "flatscan/simulation/station.h"

namespace flatscan {
namespace {

struct PlacedPart {
  Station station = BuildStation(ScenePreset("compact"));
  PartGeometry geometry;
  Rigid3d pose;
  PlacedPart() {
    Random rng(5);
    geometry = SamplePartGeometry(station.scene.part, rng);
    pose = RestAndPlacePart(geometry, 30.0, {0.0, 0.0}).support_from_part;
  }
  cv::Mat1b Render(RigSide side, const ImageDefects& d) const {
    return RenderPartImage(station, side, geometry, pose, 7, false, d);
  }
};

// Centroid of the dark (part) pixels, px.
cv::Point2d DarkCentroid(const cv::Mat1b& image) {
  const cv::Moments m = cv::moments(image < 120, true);
  return {m.m10 / m.m00, m.m01 / m.m00};
}

TEST(ImageDefects, AnIdealSpecDrawsNoDefect) {
  PlacedPart p;
  const ImageDefects d = SampleImageDefects(ImageEffectsSpec{}, p.geometry, p.pose, 3);
  EXPECT_FALSE(d.Any());
  // ... and renders exactly the image without defects.
  EXPECT_EQ(cv::norm(p.Render(RigSide::kLeft, d), p.Render(RigSide::kLeft, ImageDefects{}), cv::NORM_INF), 0.0);
}

TEST(ImageDefects, DrawsEachEffectWithinItsRangeAndTheSameForOneSeed) {
  PlacedPart p;
  ImageEffectsSpec spec;
  spec.backlight_gradient = {0.1, 0.2};
  spec.exposure_drift = {-0.1, 0.1};
  spec.dust_specks = {4, 4};
  spec.dust_diameter_um = {20, 200};
  spec.dust_touching_fraction = 0.5;
  spec.halo_gain = {0.3, 0.3};
  spec.shot_noise = 0.04;
  spec.motion_um = {1.0, 2.0};
  spec.f_number = {2.8, 8.0};
  spec.focus_error_mm = {-3.0, 3.0};
  const ImageDefects d = SampleImageDefects(spec, p.geometry, p.pose, 11);
  EXPECT_GE(d.f_number, 2.8);
  EXPECT_LE(d.f_number, 8.0);
  for (double e : d.focus_error_mm) EXPECT_LE(std::abs(e), 3.0);
  EXPECT_NE(d.focus_error_mm[0], d.focus_error_mm[1]);  // each camera focused on its own
  for (const Eigen::Vector2d& g : d.gradient) {
    EXPECT_GE(g.norm(), 0.1);
    EXPECT_LE(g.norm(), 0.2);
  }
  EXPECT_NEAR(d.right_exposure, 1.0, 0.1);
  EXPECT_EQ(d.halo_gain, 0.3);
  EXPECT_EQ(d.shot_noise, 0.04);
  EXPECT_GE(d.right_motion_mm.norm(), 1e-3);
  EXPECT_LE(d.right_motion_mm.norm(), 2e-3);
  ASSERT_EQ(d.specks.size(), 4u);
  const Rigid3d part_from_support = p.pose.Inverse();
  for (const DustSpeck& s : d.specks) {
    EXPECT_GE(s.radius_mm, 0.010);
    EXPECT_LE(s.radius_mm, 0.100);
    // Touching specks overlap the outline (centre 0.8 radius outside it, on the part's
    // footprint as seen from above).
    const Eigen::Vector3d local = part_from_support * Eigen::Vector3d(s.centre_mm.x(), s.centre_mm.y(), 0);
    if (s.touching) {
      EXPECT_NEAR(p.geometry.OuterSdf(local.head<2>()), 0.8 * s.radius_mm, 0.3 * s.radius_mm);
    }
  }
  EXPECT_EQ(std::count_if(d.specks.begin(), d.specks.end(), [](const DustSpeck& s) { return s.touching; }), 2);
  const ImageDefects again = SampleImageDefects(spec, p.geometry, p.pose, 11);
  EXPECT_EQ(again.specks[3].centre_mm, d.specks[3].centre_mm);
  EXPECT_EQ(again.right_motion_mm, d.right_motion_mm);
}

TEST(ImageDefects, IlluminationHasTheGradientAtTheCornersAndTheExposureOnTheRightOnly) {
  ImageDefects d;
  d.gradient = {Eigen::Vector2d(0.2, 0.0), Eigen::Vector2d(0.0, -0.1)};
  d.right_exposure = 1.05;
  const cv::Mat1f left = IlluminationImage(101, 51, 0.0, d, 0), right = IlluminationImage(101, 51, 0.0, d, 1);
  const double rx = 50.0 / std::hypot(50.0, 25.0), ry = 25.0 / std::hypot(50.0, 25.0);
  EXPECT_NEAR(left(25, 100), 1.0 + 0.2 * rx, 1e-6);
  EXPECT_NEAR(left(25, 0), 1.0 - 0.2 * rx, 1e-6);
  EXPECT_NEAR(left(25, 50), 1.0, 1e-6);
  EXPECT_NEAR(right(0, 50), 1.05 * (1.0 + 0.1 * ry), 1e-6);
  EXPECT_NEAR(right(50, 50), 1.05 * (1.0 - 0.1 * ry), 1e-6);
  // With vignetting: 1 - v r^2 at a corner (r = 1).
  EXPECT_NEAR(IlluminationImage(101, 51, 0.2, ImageDefects{}, 0)(0, 0), 0.8, 1e-6);
}

TEST(ImageDefects, HaloBrightensTheBacklightOutsideTheSilhouetteOnly) {
  cv::Mat1f radiance(40, 40, 200.0f);
  CoverageTile part;
  part.roi = cv::Rect(10, 10, 20, 20);
  part.coverage = cv::Mat1f(20, 20, 0.0f);
  part.coverage(cv::Rect(0, 0, 10, 20)).setTo(1.0f);  // covered: columns 10..19
  cv::Mat1f expected = radiance.clone();
  const cv::Rect changed = AddHalo(radiance, part, 200.0, 0.3, 2.0);
  EXPECT_TRUE((changed & cv::Rect(10, 10, 20, 20)) == cv::Rect(10, 10, 20, 20));
  EXPECT_FLOAT_EQ(radiance(20, 15), 200.0f);                                   // covered: unchanged
  EXPECT_NEAR(radiance(20, 20), 200 + 0.3 * 200 * std::exp(-0.5 / 2), 1e-3);    // first pixel outside
  EXPECT_NEAR(radiance(20, 23), 200 + 0.3 * 200 * std::exp(-3.5 / 2), 1e-3);
  EXPECT_LT(radiance(20, 29) - 200, radiance(20, 23) - 200);
}

TEST(ImageDefects, ShotNoiseVarianceGrowsWithTheSignal) {
  cv::Mat1f flat(400, 400, 200.0f);
  cv::Scalar mean, sd;
  cv::meanStdDev(QuantizeWithNoise(flat, 2.0, 9, 0.04), mean, sd);
  EXPECT_NEAR(sd[0], std::sqrt(4.0 + 0.04 * 200 + 1.0 / 12), 0.05);  // + rounding's 1/12
  cv::meanStdDev(QuantizeWithNoise(flat, 2.0, 9), mean, sd);
  EXPECT_NEAR(sd[0], std::sqrt(4.0 + 1.0 / 12), 0.05);
}

TEST(ImageDefects, MotionMovesThePartInTheRightImageOnly) {
  PlacedPart p;
  ImageDefects d;
  d.right_motion_mm = Eigen::Vector3d(0.2, 0.0, 0.0);  // 0.2 mm along the support's x
  const cv::Point2d left_shift = DarkCentroid(p.Render(RigSide::kLeft, d)) - DarkCentroid(p.Render(RigSide::kLeft, {}));
  const cv::Point2d right_shift = DarkCentroid(p.Render(RigSide::kRight, d)) - DarkCentroid(p.Render(RigSide::kRight, {}));
  EXPECT_LT(std::hypot(left_shift.x, left_shift.y), 1e-9);
  // The compact rig sees about 0.043 mm per pixel at the working distance: 0.2 mm is
  // about 4.6 px, along x (the rig's baseline is along the support's x).
  EXPECT_NEAR(std::hypot(right_shift.x, right_shift.y), 0.2 / 0.043, 0.5);
  EXPECT_GT(std::abs(right_shift.x), 5 * std::abs(right_shift.y));
}

TEST(ImageDefects, DustSpecksAreDarkDiscsWhereTheyLie) {
  PlacedPart p;
  ImageDefects d;
  d.specks.push_back({Eigen::Vector2d(12.0, 3.0), 0.1, false});  // a 200 um speck away from the part
  const cv::Mat1b with = p.Render(RigSide::kLeft, d), without = p.Render(RigSide::kLeft, {});
  const Eigen::Vector3d cam = p.station.cam1_from_support * Eigen::Vector3d(12.0, 3.0, 0.0);
  const Eigen::Vector2d px = p.station.rig.left.Project(cam);
  const int u = static_cast<int>(std::lround(px.x())), v = static_cast<int>(std::lround(px.y()));
  EXPECT_LT(with(v, u), 0.5 * without(v, u)) << "speck at " << px.transpose();
  cv::Mat1b differs = with != without;
  EXPECT_LT(cv::countNonZero(differs), 100);  // a disc of about 4.6 px diameter, blurred
  EXPECT_GT(cv::countNonZero(differs), 10);
}

// The support plane's depth at camera 1's principal point, by the plane's equation
// (the principal point's ray is (0, 0, 1) whatever the distortion).
double DepthAtPrincipalPoint(const Station& st) {
  const Eigen::Vector3d n = st.cam1_from_support.rotation * Eigen::Vector3d::UnitZ();
  return n.dot(st.cam1_from_support.translation) / n.z();
}

TEST(ImageDefects, DefocusFollowsTheThinLensAndGrowsAwayFromTheFocusedDepth) {
  const Station st = BuildStation(ScenePreset("compact"));
  const Camera& cam = st.rig.left;
  const CameraSpec& lens = st.scene.left_camera;
  const cv::Rect centre(static_cast<int>(cam.cx), static_cast<int>(cam.cy), 1, 1);
  const auto sigma_at = [&](double n, double focus_error, const cv::Rect& r) {
    return DefocusSigma(cam, st.cam1_from_support, lens, 0.8, n, focus_error, r);
  };
  // No aperture given: the lens blur alone.
  EXPECT_FLOAT_EQ(sigma_at(0.0, 3.0, centre)(0, 0), 0.8f);
  // Focused on the plane at the centre: the lens blur alone there.
  EXPECT_NEAR(sigma_at(2.8, 0.0, centre)(0, 0), 0.8, 1e-4);
  // Focused 3 mm beyond it: c = (f/N) f e / (z (z + e - f)), sigma = hypot(0.8, c / 4).
  const double z = DepthAtPrincipalPoint(st), f = 12.0, pitch = 3.45e-3;
  const double c_px = (f / 2.8) * f * 3.0 / (z * (z + 3.0 - f)) / pitch;
  EXPECT_NEAR(sigma_at(2.8, 3.0, centre)(0, 0), std::hypot(0.8, c_px / 4), 2e-3);
  EXPECT_NEAR(c_px, 2.1, 0.1);  // the blur circle of f/2.8 focused 3 mm beyond 151 mm
  // The defocus part of the variance goes as 1/N^2.
  const cv::Rect corner(0, 0, 1, 1);
  const double v4 = std::pow(sigma_at(4.0, 0.0, corner)(0, 0), 2) - 0.64;
  const double v8 = std::pow(sigma_at(8.0, 0.0, corner)(0, 0), 2) - 0.64;
  EXPECT_GT(v8, 0.0);
  EXPECT_NEAR(v4 / v8, 4.0, 1e-3);
  // The blur varies across the image with the plane's depth (the camera looks at it
  // at an angle): within one part's width (400 px) it changes by a few hundredths of a
  // pixel when focused at its centre.
  const cv::Mat1f across = sigma_at(2.8, 0.0, cv::Rect(static_cast<int>(cam.cx) - 200, static_cast<int>(cam.cy), 401, 1));
  double lo = 0, hi = 0;
  cv::minMaxLoc(across, &lo, &hi);
  EXPECT_GT(hi - lo, 0.02) << hi - lo;  // measured 0.039 px
}

TEST(ImageDefects, DefocusWidensTheEdgesButDoesNotMoveThePart) {
  PlacedPart p;
  ImageDefects d;
  d.f_number = 2.8;
  d.focus_error_mm = {5.0, -5.0};
  for (RigSide side : {RigSide::kLeft, RigSide::kRight}) {
    const cv::Mat1b with = p.Render(side, d), without = p.Render(side, {});
    EXPECT_GT(cv::norm(with, without, cv::NORM_L1), 1000.0);
    const cv::Point2d shift = DarkCentroid(with) - DarkCentroid(without);
    EXPECT_LT(std::hypot(shift.x, shift.y), 0.05);
  }
}

}  // namespace
}  // namespace flatscan
