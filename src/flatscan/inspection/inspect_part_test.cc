#include "flatscan/inspection/inspect_part.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <tuple>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "flatscan/io/rig_file.h"
#include "flatscan/simulation/dataset.h"
#include "flatscan/simulation/simulation_test_util.h"
#include "flatscan/util/error.h"
#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {

using testing::RenderedPair;
using testing::RenderPair;
using testing::RenderRandomPart;

using testing::InputErrorOf;

constexpr uint64_t kDustSeed = 1;

// Accuracy with the true rig and plane on a fixed-seed subset (the full study with
// calibrated rig and plane is `flatscan evaluate`).
TEST(InspectPart, FlatnessWithinMicronsAndThicknessCorrectionMatters) {
  const Station st = BuildStation(ScenePreset("paper"));
  Random rng(11);
  std::vector<double> errors, uncorrected;
  for (int i = 0; i < 6; ++i) {
    const RenderedPair rp = RenderRandomPart(st, i, rng, 1100 + 2 * i);
    InspectionParams params;
    params.thickness_mm = rp.part.geometry.SideHeight();
    const InspectionResult res = InspectPart(st.rig, st.plane, rp.left, rp.right, params);
    const double truth = rp.part.shots[0].truth.flatness_mm;
    errors.push_back(std::abs(res.values.flatness_mm - truth));
    EXPECT_NEAR(res.values.minzone_mm, rp.part.shots[0].truth.minzone_mm, 0.015);
    params.thickness_correction = false;
    uncorrected.push_back(std::abs(InspectPart(st.rig, st.plane, rp.left, rp.right, params).values.flatness_mm - truth));
  }
  std::sort(errors.begin(), errors.end());
  std::sort(uncorrected.begin(), uncorrected.end());
  std::printf("|error| median %.2f um, max %.2f um; without the thickness correction median %.1f um\n",
              1000 * errors[errors.size() / 2], 1000 * errors.back(), 1000 * uncorrected[uncorrected.size() / 2]);
  EXPECT_LT(errors[errors.size() / 2], 0.0015);
  EXPECT_LT(errors.back(), 0.004);
  EXPECT_GT(uncorrected[uncorrected.size() / 2], 0.05);  // a fraction of the 0.1-0.3 mm thickness
}

// A 15 x 10 mm sheet of 0.3 mm with two holes and a strong warp, which rests tilted by
// about 0.019 rad on three contacts and whose faces lean up to 0.10 rad.
PartGeometry StronglyWarpedPart() {
  PartGeometry g;
  g.half_width = 7.523;
  g.half_height = 5.168;
  g.corner_radius = 0.875;
  g.thickness = 0.296;
  g.holes = {{Eigen::Vector2d(-1.83, 1.81), 0.69}, {Eigen::Vector2d(-4.34, -1.67), 0.79}};
  g.warp = {-0.1212, 0.1662, 0.1103, -0.0475, -0.0397, 0.0567, -0.0252};
  return g;
}

// A part resting tilted (here about 0.019 rad: a strong warp on three contacts) has
// its side faces tilted with it; taking them along the support normal biased the
// sides running near the epipolar rows by tens of micrometres (this part: -43 um).
// The faces are taken along the sheet normal estimated from a first pass.
TEST(InspectPart, TiltedPartSideFacesFollowTheSheet) {
  const Station st = BuildStation(ScenePreset("paper"));
  const PartGeometry g = StronglyWarpedPart();
  const PartTruth truth = RestAndPlacePart(g, 348.4, {0.0, 0.0});
  const Eigen::Vector3d part_z = truth.support_from_part.rotation.col(2);
  const double true_tilt = std::acos(part_z.z());
  ASSERT_GT(true_tilt, 0.012);
  const auto [left, right] = RenderPair(st, g, truth.support_from_part, 1761);
  InspectionParams params;
  params.thickness_mm = g.SideHeight();
  const InspectionResult res = InspectPart(st.rig, st.plane, left, right, params);
  EXPECT_NEAR(res.side_tilt_rad, true_tilt, 0.15 * true_tilt);
  params.side_faces = SideFaceModel::kSupportNormal;
  const InspectionResult along_support = InspectPart(st.rig, st.plane, left, right, params);
  std::printf("true tilt %.4f estimated %.4f; error %.1f um, faces along the support normal %.1f um\n", true_tilt,
              res.side_tilt_rad, 1000 * (res.values.flatness_mm - truth.flatness_mm),
              1000 * (along_support.values.flatness_mm - truth.flatness_mm));
  EXPECT_NEAR(res.values.flatness_mm, truth.flatness_mm, 0.010);
  EXPECT_GT(std::abs(along_support.values.flatness_mm - truth.flatness_mm),
            2 * std::abs(res.values.flatness_mm - truth.flatness_mm));
}

// The same part on the 12 mm-lens rig turned 32 degrees: its faces lean up to 0.10 rad,
// and a camera sees the other edge of some faces once they lean, so each point's
// dependence on its face (the gain) changes between the first pass (faces along the
// support normal) and the last. With the gains measured once: +6.2 um, centre tilt
// 0.0081 rad; measured again at every pass: -1.0 um, 0.0180 rad (true 0.0186 rad).
TEST(InspectPart, AStronglyWarpedPartsGainsFollowItsFaces) {
  const Station st = BuildStation(ScenePreset("compact"));
  const PartGeometry g = StronglyWarpedPart();
  const PartTruth truth = RestAndPlacePart(g, 32.0, {0.0, 0.0});
  const double true_tilt = std::acos(truth.support_from_part.rotation.col(2).z());
  const auto [left, right] = RenderPair(st, g, truth.support_from_part, 1761);
  InspectionParams params;
  params.thickness_mm = g.SideHeight();
  const InspectionResult res = InspectPart(st.rig, st.plane, left, right, params);
  EXPECT_NEAR(res.side_tilt_rad, true_tilt, 0.1 * true_tilt);
  EXPECT_GT(res.max_face_tilt_rad, 0.09);
  EXPECT_NEAR(res.values.flatness_mm, truth.flatness_mm, 0.0025);
}

// A cut sheet's side faces stay perpendicular to the local sheet (geometry/
// side_faces.h). On this strongly curved part (slopes up to about 0.08 rad at the rim,
// 0.3 mm sheet, rendered with faces along the local normal) the faces along the
// sheet's normal at the centre read it low by tens of micrometres (measured: -84 um),
// the local faces within two (measured: -0.15 um).
TEST(InspectPart, SideFacesFollowTheLocalSheet) {
  const Station st = BuildStation(ScenePreset("paper"));
  PartGeometry g;
  g.half_width = 7.0;
  g.half_height = 5.0;
  g.corner_radius = 0.8;
  g.thickness = 0.3;
  g.warp = {-0.18, 0.15, 0.12, 0.04, -0.03, 0.03, -0.02};
  ASSERT_EQ(g.side_faces, SideFaceModel::kLocalNormal);
  const PartTruth truth = RestAndPlacePart(g, 32.0, {0.5, -0.5});
  double true_max_tilt = 0;
  for (const Eigen::Vector2d& p : g.SampleOuterOutline(0.1))
    true_max_tilt = std::max(true_max_tilt, std::acos((truth.support_from_part.rotation * g.FaceDirection(p)).z()));
  ASSERT_GT(true_max_tilt, 0.05);
  const auto [left, right] = RenderPair(st, g, truth.support_from_part, 4101);
  InspectionParams params;
  params.thickness_mm = g.SideHeight();
  const InspectionResult local = InspectPart(st.rig, st.plane, left, right, params);
  params.side_faces = SideFaceModel::kCentreNormal;
  const InspectionResult centre = InspectPart(st.rig, st.plane, left, right, params);
  std::printf("true flatness %.4f mm, largest face tilt %.4f (estimated %.4f); error: local faces %.2f um, centre "
              "faces %.2f um\n",
              truth.flatness_mm, true_max_tilt, local.max_face_tilt_rad, 1000 * (local.values.flatness_mm - truth.flatness_mm),
              1000 * (centre.values.flatness_mm - truth.flatness_mm));
  EXPECT_NEAR(local.values.flatness_mm, truth.flatness_mm, 0.002);
  EXPECT_NEAR(local.max_face_tilt_rad, true_max_tilt, 0.1 * true_max_tilt);
  EXPECT_LT(centre.values.flatness_mm - truth.flatness_mm, -0.005);
}

// The compact rig (12 mm lenses, strong distortion, 40 mm baseline) on parts at
// rotations where the cameras see different edges at every corner, and two parts
// turned so that whole sides run along the epipolar rows (completed from the warp
// surface). Guards the exact silhouette triangulation, the dropping of points where
// a line of sight grazes a side face, and the completion not running away.
TEST(InspectPart, CompactRigCornersAndRowParallelSides) {
  const Station st = BuildStation(ScenePreset("compact"));
  Random rng(23);
  std::vector<double> errors;
  for (int i = 0; i < 8; ++i) {
    const RenderedPair rp = RenderRandomPart(st, i, rng, 2300 + 2 * i);
    InspectionParams params;
    params.thickness_mm = rp.part.geometry.SideHeight();
    const InspectionResult res = InspectPart(st.rig, st.plane, rp.left, rp.right, params);
    errors.push_back(std::abs(res.values.flatness_mm - rp.part.shots[0].truth.flatness_mm));
    std::printf("part %d rotation %.1f coverage %.3f error %.1f um\n", i, rp.part.shots[0].rotation_deg, res.coverage,
                1000 * errors.back());
  }
  std::sort(errors.begin(), errors.end());
  // Measured: median 1.3 um; the largest, 7.7 um, on the part turned 87.5 degrees
  // (coverage 0.64: its long sides along the rows are completed from the warp).
  EXPECT_LT(errors[errors.size() / 2], 0.0025);
  EXPECT_LT(errors.back(), 0.012);
}

// Coverage against the part's rotation to the camera baseline (docs/design.md section 6.6: a
// side along the epipolar rows gives no depth). Turned 5 or 30 degrees, the whole
// outline is measured; turned 1 degree, the two sides along the rows are not, and
// are completed from the warp surface (reported by coverage and `completed`).
TEST(InspectPart, CoverageAgainstRotationToTheBaseline) {
  const Station st = BuildStation(ScenePreset("paper"));
  PartGeometry g;
  g.half_width = 8.0;
  g.half_height = 6.0;
  g.corner_radius = 0.8;
  g.thickness = 0.2;
  g.warp = {0.05, -0.04, 0.06, 0.01, 0.0, -0.01, 0.0};
  InspectionParams params;
  params.thickness_mm = g.SideHeight();
  for (const double rotation : {1.0, 5.0, 30.0}) {
    const PartTruth truth = RestAndPlacePart(g, rotation, {1.0, -0.5});
    const auto [left, right] = RenderPair(st, g, truth.support_from_part, 1901);
    const InspectionResult res = InspectPart(st.rig, st.plane, left, right, params);
    std::printf("rotation %.0f: coverage %.3f, completed %d, error %.2f um\n", rotation, res.coverage, res.completed,
                1000 * (res.values.flatness_mm - truth.flatness_mm));
    if (rotation < 2) {
      EXPECT_LT(res.coverage, 0.6);
      EXPECT_GT(res.completed, 500);
      EXPECT_NEAR(res.values.flatness_mm, truth.flatness_mm, 0.010);
    } else {
      EXPECT_GT(res.coverage, 0.93);
      EXPECT_NEAR(res.values.flatness_mm, truth.flatness_mm, 0.002);
    }
  }
}

TEST(InspectPart, UnmeasurablePairsSayWhy) {
  const Station st = BuildStation(ScenePreset("paper"));
  Random rng(5);
  const RenderedPair rp = RenderRandomPart(st, 0, rng, 77);
  InspectionParams params;
  params.thickness_mm = rp.part.geometry.SideHeight();
  auto inspect = [&](const cv::Mat1b& l, const cv::Mat1b& r) {
    return InputErrorOf([&] { InspectPart(st.rig, st.plane, l, r, params, "L.png", "R.png"); });
  };
  const cv::Mat1b empty = RenderMarkerImage(st, RigSide::kLeft, 3);  // backlight and markers, no part
  cv::Mat1b backlight(rp.left.size(), uint8_t(215));
  EXPECT_EQ(inspect(backlight, rp.right), "L.png: no part found (expected a dark part on the bright backlight, fully in view)");
  EXPECT_EQ(inspect(rp.right, rp.left),
            "L.png and R.png: the part's outline spans different rows in the two rectified views (23 px apart): the "
            "images do not fit the rig: check that left and right are not swapped and that the rig file belongs to "
            "these cameras");
  cv::Mat1b dark = rp.left * 0.2;
  EXPECT_EQ(inspect(dark, rp.right).rfind("L.png: under-exposed", 0), 0u);
  cv::Mat1b bright = rp.left * 3.0;
  EXPECT_EQ(inspect(bright, rp.right).rfind("L.png: over-exposed", 0), 0u);
  cv::Mat1b small;
  cv::resize(rp.left, small, cv::Size(1296, 972));
  EXPECT_EQ(inspect(small, rp.right),
            "L.png: image is 1296x972 but the rig was calibrated for 2592x1944: use the images of the calibrated cameras");
  // Two small parts side by side.
  PartGeometry small_part;
  small_part.half_width = 4.0;
  small_part.half_height = 3.0;
  cv::Mat1b two = cv::min(
      RenderPartImage(st, RigSide::kLeft, small_part, RestAndPlacePart(small_part, 10.0, {-9.0, 0.0}).support_from_part, 81, false),
      RenderPartImage(st, RigSide::kLeft, small_part, RestAndPlacePart(small_part, 30.0, {9.0, 0.0}).support_from_part, 82, false));
  EXPECT_EQ(inspect(two, rp.right), "L.png: 2 parts found: inspect one part at a time");
  // A part cut by the image border: shift the image content.
  cv::Mat1b shifted(rp.left.size(), uint8_t(215));
  const Eigen::Vector3d centre = st.CamFromSupport(RigSide::kLeft) * rp.part.shots[0].truth.support_from_part.translation;
  const Eigen::Vector2d c = st.GetCamera(RigSide::kLeft).Project(centre);
  const int dx = static_cast<int>(c.x());  // moves the part's centre to the left border
  rp.left(cv::Rect(dx, 0, rp.left.cols - dx, rp.left.rows)).copyTo(shifted(cv::Rect(0, 0, rp.left.cols - dx, rp.left.rows)));
  EXPECT_EQ(inspect(shifted, rp.right), "L.png: the part touches the image border: place it fully inside both cameras' views");
}


// One simulated part of a preset's station, rendered with image defects and inspected
// with the true rig and plane (the images are what is tested).
struct PartWithDefects {
  Station st;
  SimulatedPart part;
  Rigid3d pose;
  InspectionParams params;
  PartWithDefects(const std::string& preset, uint64_t part_seed) : st(BuildStation(ScenePreset(preset))) {
    Random rng(part_seed);
    part = SampleSimulatedPart(st, 0, rng);
    pose = part.shots[0].truth.support_from_part;
    params.thickness_mm = part.geometry.SideHeight();
  }
  double TrueFlatness() const { return part.shots[0].truth.flatness_mm; }
  // Left image with `noise_seed`, right with noise_seed + 1, named L.png and R.png.
  InspectionResult Inspect(const ImageDefects& defects, uint64_t noise_seed) const {
    const cv::Mat1b left = RenderPartImage(st, RigSide::kLeft, part.geometry, pose, noise_seed, false, defects);
    const cv::Mat1b right = RenderPartImage(st, RigSide::kRight, part.geometry, pose, noise_seed + 1, false, defects);
    return InspectPart(st.rig, st.plane, left, right, params, "L.png", "R.png");
  }
  std::string ErrorOf(const ImageDefects& defects, uint64_t noise_seed) const {
    return InputErrorOf([&] { Inspect(defects, noise_seed); });
  }
};

// Dust on the backlight touching the part's edge (simulation/image_defects.h): the
// outline cannot be followed through the speck's blurred neck, and the part is not
// measured with that reason (not "no part found"). Specks clear of the edge change
// nothing that matters.
TEST(InspectPart, DustTouchingTheOutlineIsNotMeasuredWithTheReason) {
  const PartWithDefects p("paper", 5);
  ImageEffectsSpec dust;
  dust.dust_specks = {6, 6};
  dust.dust_diameter_um = {150, 200};
  dust.dust_touching_fraction = 1.0;
  const std::string error = p.ErrorOf(SampleImageDefects(dust, p.part.geometry, p.pose, kDustSeed), 31);
  EXPECT_NE(error.find("the part's outline is interrupted near ("), std::string::npos) << error;
  EXPECT_NE(error.find("a dark speck (dust on the backlight or the lens) touching the part's edge?"), std::string::npos);
  dust.dust_touching_fraction = 0.0;  // the same number of specks, none touching
  const InspectionResult r = p.Inspect(SampleImageDefects(dust, p.part.geometry, p.pose, kDustSeed), 31);
  EXPECT_NEAR(r.values.flatness_mm, p.TrueFlatness(), 0.002);
}

// Defocus that varies across the part (simulation/image_defects.h, DefocusSigma): a lens
// at f/4 focused 2 mm off the plane widens the edges unevenly (1.4-1.5 px against 1.0 in
// focus) and the part is measured as well as in focus; at f/2.8 and 4 mm the image is out
// of focus and the part is not measured with that reason (not taken for dust on an
// interrupted outline).
TEST(InspectPart, DefocusIsMeasuredWithinItsDepthOfFieldAndSaidOutOfFocusBeyond) {
  const PartWithDefects p("paper", 5);
  ImageDefects defocus;
  defocus.f_number = 4.0;
  defocus.focus_error_mm = {2.0, -2.0};
  const InspectionResult r = p.Inspect(defocus, 51);
  EXPECT_GT(r.blur_left_px, 1.2);
  EXPECT_NEAR(r.values.flatness_mm, p.TrueFlatness(), 0.003);
  std::printf("f/4, focus +-2 mm: blur %.2f / %.2f px, error %+.2f um\n", r.blur_left_px, r.blur_right_px,
              1000 * (r.values.flatness_mm - p.TrueFlatness()));
  defocus.f_number = 2.8;
  defocus.focus_error_mm = {4.0, -4.0};
  const std::string error = p.ErrorOf(defocus, 51);
  EXPECT_EQ(error.rfind("L.png: out of focus (the edges' blur sigma is ", 0), 0u) << error;
  EXPECT_NE(error.find(" px; expected at most 2.00 px): focus the lens on the support plane, or close its aperture"),
            std::string::npos) << error;
}

// A bright halo around the edge (light reflected by bright metal edges, simulation/
// image_defects.h) biases the edge fit (it pulls the blur estimate from 0.80 to 0.27 px):
// the part is not measured with that reason. A gain of 0.1, the weakest of the realistic
// range, is found too.
TEST(InspectPart, BrightHaloAroundTheEdgeIsNotMeasuredWithTheReason) {
  const PartWithDefects p("compact", 3);
  for (double gain : {0.1, 0.4}) {
    ImageDefects halo;
    halo.halo_gain = gain;
    const std::string error = p.ErrorOf(halo, 41);
    EXPECT_EQ(error.rfind("L.png: a bright halo around the part's edge (the backlight ", 0), 0u) << error;
    EXPECT_NE(error.find("% of the edge's step brighter 2 px outside it than 8 px out; expected at most 1%)"),
              std::string::npos) << error;
  }
}

}  // namespace
}  // namespace flatscan
