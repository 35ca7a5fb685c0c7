#include "flatscan/support_plane/plane_calibration.h"

#include <chrono>
#include <cmath>
#include <fstream>
#include <map>
#include <string>
#include <tuple>

#include <Eigen/Geometry>
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "flatscan/io/rig_file.h"
#include "flatscan/simulation/dataset.h"
#include "flatscan/simulation/station.h"
#include "flatscan/util/error.h"
#include "flatscan/util/sha256.h"
#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

// A rendered marker pair of the paper's station with the plane tilted (cached: each
// 2592 x 1944 render takes ~0.3 s).
struct MarkerPair {
  Station station;
  cv::Mat1b left, right;
  MarkerDetection left_detection, right_detection;
};

const MarkerPair& RenderedPair(double tilt_deg, double azimuth_deg, const std::string& preset = "paper") {
  static std::map<std::tuple<double, double, std::string>, MarkerPair> cache;
  const auto key = std::make_tuple(tilt_deg, azimuth_deg, preset);
  auto it = cache.find(key);
  if (it == cache.end()) {
    SceneConfig scene = ScenePreset(preset);
    scene.plane.tilt_deg = tilt_deg;
    scene.plane.tilt_azimuth_deg = azimuth_deg;
    MarkerPair p;
    p.station = BuildStation(scene);
    const uint64_t seed = 100 + static_cast<uint64_t>(tilt_deg * 10 + azimuth_deg);
    p.left = RenderMarkerImage(p.station, RigSide::kLeft, seed);
    p.right = RenderMarkerImage(p.station, RigSide::kRight, seed + 1);
    p.left_detection = DetectRingMarkers(p.left, p.station.rig.left);
    p.right_detection = DetectRingMarkers(p.right, p.station.rig.right);
    it = cache.emplace(key, std::move(p)).first;
  }
  return it->second;
}

struct PlaneErrors {
  double normal_deg = 0;
  double offset_um = 0;  // height error of the estimated plane at the support-frame origin
};

PlaneErrors ErrorsOf(const Station& station, const Eigen::Vector3d& normal, const Eigen::Vector3d& point) {
  PlaneErrors e;
  e.normal_deg = std::acos(std::clamp(normal.dot(station.plane.normal), -1.0, 1.0)) * kRadToDeg;
  // The support frame's origin (where parts are placed) lies on the true plane; its
  // height above the estimated plane is the offset error there.
  const Eigen::Vector3d origin = station.cam1_from_support.translation;
  e.offset_um = normal.dot(origin - point) * 1e3;
  return e;
}

// Marker centres of the true station as detections (no image): for the matching.
MarkerDetection SyntheticDetection(const Station& station, RigSide camera, const std::vector<int>& order) {
  MarkerDetection d;
  const Camera& cam = station.GetCamera(camera);
  for (int k : order) {
    const Eigen::Vector2d& m = station.markers[k];
    RingMarker r;
    r.centre_px = cam.Project(station.CamFromSupport(camera) * Eigen::Vector3d(m.x(), m.y(), 0));
    r.naive_centre_px = r.centre_px;
    r.centre_undistorted = cam.PixelToIdeal(r.centre_px);
    r.naive_centre_undistorted = r.centre_undistorted;
    d.markers.push_back(r);
  }
  return d;
}

TEST(PlaneCalibration, PlaneFitsAndTriangulationAreExact) {
  // Points on the plane n . x = d, seen from the origin (the cameras) on the -n side... the
  // normal must come out pointing toward the origin.
  const Eigen::Vector3d n = Eigen::Vector3d(0.1, -0.2, -1.0).normalized();
  const Eigen::Vector3d p0(1.0, 2.0, 200.0);
  const Eigen::Vector3d u = n.unitOrthogonal(), v = n.cross(u);
  std::vector<Eigen::Vector3d> points;
  for (const auto& [a, b] : {std::pair(-15.0, 10.0), {14.0, 11.0}, {13.0, -12.0}, {-16.0, -9.0}})
    points.push_back(p0 + a * u + b * v);
  Eigen::Vector3d r;
  for (const SupportPlaneFit& fit : {FitSupportPlaneTls(points), FitSupportPlanePaper(points, &r)}) {
    EXPECT_NEAR(fit.normal.dot(n), 1.0, 1e-14);
    EXPECT_LT(fit.normal.dot(fit.point), 0.0);  // toward the cameras at the origin
    EXPECT_LT(fit.MaxAbsMm(), 1e-12);
    EXPECT_NEAR(n.dot(fit.point - p0), 0.0, 1e-12);
  }
  // V r = 1: r . x = 1 on the plane.
  for (const Eigen::Vector3d& p : points) EXPECT_NEAR(r.dot(p), 1.0, 1e-12);
  // Off-plane points: the TLS residuals are the orthogonal distances and sum to zero.
  points[0] += 0.01 * n;
  const SupportPlaneFit tls = FitSupportPlaneTls(points);
  double sum = 0;
  for (double res : tls.residuals_mm) sum += res;
  EXPECT_NEAR(sum, 0.0, 1e-12);
  EXPECT_GT(tls.MaxAbsMm(), 0.002);  // the 0.01 mm offset is shared by the four points
  EXPECT_LT(tls.MaxAbsMm(), 0.005);

  // Triangulation and epipolar distance of exact projections.
  const Station station = BuildStation(ScenePreset("paper"));
  const StereoRig& rig = station.rig;
  for (const Eigen::Vector3d& x : {Eigen::Vector3d(-15, 10, 198), Eigen::Vector3d(12, -9, 205)}) {
    const Eigen::Vector3d x2 = rig.cam2_from_cam1 * x;
    const Eigen::Vector2d a = x.head<2>() / x.z(), b = x2.head<2>() / x2.z();
    EXPECT_NEAR((TriangulateNormalized(rig, a, b) - x).norm(), 0.0, 1e-9);
    EXPECT_NEAR(EpipolarDistancePx(rig, a, b), 0.0, 1e-9);
    // One pixel across the epipolar line in the right image.
    const Eigen::Matrix3d e = [&] {
      const Eigen::Vector3d t = rig.cam2_from_cam1.translation;
      Eigen::Matrix3d s;
      s << 0, -t.z(), t.y(), t.z(), 0, -t.x(), -t.y(), t.x(), 0;
      return Eigen::Matrix3d(s * rig.cam2_from_cam1.rotation);
    }();
    const Eigen::Vector3d line = e * Eigen::Vector3d(a.x(), a.y(), 1);
    const Eigen::Vector2d off = b + line.head<2>().normalized() / rig.right.fx;
    EXPECT_NEAR(EpipolarDistancePx(rig, a, off), 1.0, 0.05);
  }
}

TEST(PlaneCalibration, MatchesMarkersByEpipolarLinesAndOrder) {
  const Station station = BuildStation(ScenePreset("paper"));
  // Different detection orders in the two images, a missing marker, a stray one.
  const MarkerDetection left = SyntheticDetection(station, RigSide::kLeft, {0, 1, 3, 2});
  MarkerDetection right = SyntheticDetection(station, RigSide::kRight, {3, 2, 0, 1});
  PlaneCalibration cal = CalibratePlaneFromDetections(station.rig, left, right);
  ASSERT_EQ(cal.matched.size(), 4u);
  const std::vector<int> left_order = {0, 1, 3, 2}, right_order = {3, 2, 0, 1};
  for (const MatchedMarker& m : cal.matched) {
    EXPECT_EQ(left_order[m.left], right_order[m.right]);
    EXPECT_LT(m.epipolar_px, 1e-6);
    EXPECT_LT(m.reprojection_px, 1e-6);
  }
  EXPECT_TRUE(cal.warnings.empty());
  const PlaneErrors err = ErrorsOf(station, cal.plane.normal, cal.plane.point);
  EXPECT_LT(err.normal_deg, 1e-8);
  EXPECT_LT(std::abs(err.offset_um), 1e-6);

  // Drop marker 0 from the right image: three matches and a warning.
  right.markers.erase(right.markers.begin() + 2);
  cal = CalibratePlaneFromDetections(station.rig, left, right);
  EXPECT_EQ(cal.matched.size(), 3u);
  ASSERT_EQ(cal.warnings.size(), 1u);
  EXPECT_NE(cal.warnings[0].find("only 3 of 4 markers"), std::string::npos) << cal.warnings[0];
  // A stray marker in the left image, 40 px off any epipolar line, is not matched.
  MarkerDetection left_stray = left;
  RingMarker stray = left.markers[0];
  stray.centre_undistorted += Eigen::Vector2d(-30, 40);
  left_stray.markers.push_back(stray);
  cal = CalibratePlaneFromDetections(station.rig, left_stray, right);
  EXPECT_EQ(cal.matched.size(), 3u);
  for (const MatchedMarker& m : cal.matched) EXPECT_NE(m.left, 4);
  // Two markers are not enough.
  right.markers.erase(right.markers.begin());
  PlaneCalibrationOptions named;
  named.right_name = "R.png";
  try {
    CalibratePlaneFromDetections(station.rig, left, right, named);
    ADD_FAILURE() << "expected an InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("R.png: found 2 concentric-ring markers, expected 4"), std::string::npos)
        << e.what();
  }
}

// The figures: normal within 0.005 deg and plane offset at the part's centre
// within 1 um, plane tilted 0 to 15 deg; and what the two-conic correction removes.
// The compact preset (12 mm lens, k1 = -0.21) checks the undistortion before fitting.
TEST(PlaneCalibration, AccuracyOnSimulatedTiltedPlanes) {
  const std::tuple<double, double, std::string> cases[] = {
      {0.0, 0.0, "paper"}, {7.0, 120.0, "paper"}, {15.0, 250.0, "paper"}, {10.0, 45.0, "compact"}};
  std::printf("preset  tilt  azimuth | corrected: normal deg  offset um | naive: normal deg  offset um | "
              "max shift px\n");
  for (const auto& [tilt, azimuth, preset] : cases) {
    const auto start = std::chrono::steady_clock::now();
    const MarkerPair& p = RenderedPair(tilt, azimuth, preset);
    const double render_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    ASSERT_EQ(p.left_detection.markers.size(), 4u);
    ASSERT_EQ(p.right_detection.markers.size(), 4u);
    const PlaneCalibration cal = CalibratePlaneFromDetections(p.station.rig, p.left_detection, p.right_detection);
    PlaneCalibrationOptions naive_options;
    naive_options.centre_correction = false;
    const PlaneCalibration naive =
        CalibratePlaneFromDetections(p.station.rig, p.left_detection, p.right_detection, naive_options);
    ASSERT_EQ(cal.matched.size(), 4u);
    EXPECT_TRUE(cal.warnings.empty());
    const PlaneErrors e = ErrorsOf(p.station, cal.plane.normal, cal.plane.point);
    const PlaneErrors n = ErrorsOf(p.station, naive.plane.normal, naive.plane.point);
    const PlaneErrors paper = ErrorsOf(p.station, cal.paper.normal, cal.paper.point);
    double shift = 0;
    for (const MatchedMarker& m : cal.matched) shift = std::max({shift, m.left_shift_px, m.right_shift_px});
    std::printf("%-7s %4.0f  %7.0f | %20.5f  %9.3f | %16.5f  %9.3f | %.3f  (V r = 1: %.5f deg, %.3f um; "
                "TLS rms %.2f um; render+detect %.2f s)\n",
                preset.c_str(), tilt, azimuth, e.normal_deg, e.offset_um, n.normal_deg, n.offset_um, shift, paper.normal_deg,
                paper.offset_um, cal.tls.RmsMm() * 1e3, render_s);
    EXPECT_LT(e.normal_deg, 0.005) << tilt;
    EXPECT_LT(std::abs(e.offset_um), 1.0) << tilt;
    EXPECT_LT(paper.normal_deg, 0.005) << tilt;
    EXPECT_LT(cal.normals_angle_deg, 0.005) << tilt;
    // The markers' true positions.
    for (const MatchedMarker& m : cal.matched) {
      double best = 1e9;
      for (const Eigen::Vector3d& t : p.station.plane.markers) best = std::min(best, (t - m.position).norm());
      EXPECT_LT(best, 0.01) << tilt;
      EXPECT_LT(m.epipolar_px, 0.05) << tilt;
    }
  }
}

// Paints a rectangle of backlight over one marker (by its detected centre).
void HideMarker(cv::Mat1b& image, const RingMarker& m) {
  const int r = static_cast<int>(m.outer.ellipse.a + 12);
  const cv::Rect box = cv::Rect(int(m.centre_px.x()) - r, int(m.centre_px.y()) - r, 2 * r, 2 * r) &
                       cv::Rect(0, 0, image.cols, image.rows);
  image(box).setTo(212);
}

TEST(PlaneCalibration, ThreeMarkersWarnAndTwoFail) {
  const MarkerPair& p = RenderedPair(7.0, 120.0);
  cv::Mat1b right = p.right.clone();
  HideMarker(right, p.right_detection.markers[1]);
  PlaneCalibrationOptions options;
  options.right_name = "right.png";
  const PlaneCalibration cal = CalibratePlane(p.station.rig, p.left, right, options);
  EXPECT_EQ(cal.right.markers.size(), 3u);
  ASSERT_EQ(cal.matched.size(), 3u);
  ASSERT_EQ(cal.warnings.size(), 1u);
  EXPECT_NE(cal.warnings[0].find("only 3 of 4"), std::string::npos);
  const PlaneErrors e = ErrorsOf(p.station, cal.plane.normal, cal.plane.point);
  std::printf("3 markers: normal error %.5f deg, offset at the centre %.3f um\n", e.normal_deg, e.offset_um);
  EXPECT_LT(e.normal_deg, 0.01);
  EXPECT_LT(std::abs(e.offset_um), 2.0);

  HideMarker(right, p.right_detection.markers[3]);
  try {
    CalibratePlane(p.station.rig, p.left, right, options);
    ADD_FAILURE() << "expected an InputError";
  } catch (const InputError& err) {
    EXPECT_NE(std::string(err.what()).find("right.png: found 2 concentric-ring markers, expected 4"),
              std::string::npos)
        << err.what();
  }
  // A size that differs from the rig.
  options.left_name = "L.png";
  try {
    CalibratePlane(p.station.rig, p.left(cv::Rect(0, 0, 2000, 1500)), p.right, options);
    ADD_FAILURE() << "expected an InputError";
  } catch (const InputError& err) {
    EXPECT_NE(std::string(err.what()).find("L.png: image is 2000x1500 px but the rig is calibrated for 2592x1944"),
              std::string::npos)
        << err.what();
  }
}

// The command line: success, report, and bad input (exit 2, no plane file).
TEST(PlaneCalibration, CalibratePlaneCommand) {
  using testing::RunFlatscan;
  const MarkerPair& p = RenderedPair(10.0, 45.0, "compact");  // 1920 x 1200: half the render time
  const testing::ScratchDir dir("calibrate-plane");
  const auto path = [&](const char* name) { return (dir.path() / name).string(); };
  WriteRigFile(path("rig.yml"), p.station.rig);
  ASSERT_TRUE(cv::imwrite(path("L.png"), p.left, {cv::IMWRITE_PNG_COMPRESSION, 1}));
  ASSERT_TRUE(cv::imwrite(path("R.png"), p.right, {cv::IMWRITE_PNG_COMPRESSION, 1}));
  const std::string base = fmt::format("calibrate-plane --rig '{}' --left '{}' --right '{}'", path("rig.yml"),
                                       path("L.png"), path("R.png"));

  testing::CommandResult r = RunFlatscan(base + fmt::format(" -o '{}' --json '{}'", path("plane.yml"),
                                                            path("report.json")));
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const PlaneFile file = ReadPlaneFile(path("plane.yml"));
  EXPECT_EQ(file.rig_sha256, Sha256HexOfFile(path("rig.yml")));
  const SupportPlane& plane = file.plane;
  EXPECT_EQ(plane.markers.size(), 4u);
  EXPECT_LT(ErrorsOf(p.station, plane.normal, plane.point).normal_deg, 0.005);
  const nlohmann::json report = nlohmann::json::parse(testing::ReadFileBytes(path("report.json")));
  for (const char* key : {"normal", "point", "residuals_mm", "markers_found", "paper_fit", "tls_fit",
                          "normals_angle_deg", "markers"})
    EXPECT_TRUE(report.contains(key)) << key;
  EXPECT_EQ(report["rig_sha256"], file.rig_sha256);
  EXPECT_EQ(report["markers_found"]["left"], 4);
  EXPECT_EQ(report["markers_found"]["right"], 4);
  EXPECT_EQ(report["residuals_mm"].size(), 4u);
  EXPECT_EQ(report["centre_correction"], true);
  EXPECT_GT(report["markers"][0]["left"]["centre_shift_px"].get<double>(), 0.1);

  // Without the correction the plane is still written (to measure the bias).
  r = RunFlatscan(base + fmt::format(" -o '{}' --no-center-correction", path("plane_naive.yml")));
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(std::filesystem::exists(path("plane_naive.yml")));

  // Bad input: exit 2, a message naming the file, and no plane file.
  cv::imwrite(path("small.png"), p.left(cv::Rect(0, 0, 960, 600)));
  cv::imwrite(path("blank.png"), cv::Mat1b(1200, 1920, uint8_t(210)));
  cv::imwrite(path("colour.png"), cv::Mat3b(1200, 1920, cv::Vec3b(210, 210, 210)));
  std::filesystem::copy_file(path("rig.yml"), path("rig_no_T.yml"));
  {
    std::string text = testing::ReadFileBytes(path("rig.yml"));
    const size_t t = text.find("\nT: ");
    ASSERT_NE(t, std::string::npos);
    text.replace(t, 4, "\nX: ");
    std::ofstream(path("rig_no_T.yml"), std::ios::trunc) << text;
  }
  const struct {
    std::string args, message;
  } bad[] = {
      {fmt::format("--rig '{}' --left '{}' --right '{}'", path("rig.yml"), path("missing.png"), path("R.png")),
       "missing.png: no such file"},
      {fmt::format("--rig '{}' --left '{}' --right '{}'", path("rig.yml"), path("rig.yml"), path("R.png")),
       "rig.yml: cannot read image"},
      {fmt::format("--rig '{}' --left '{}' --right '{}'", path("rig.yml"), path("L.png"), path("small.png")),
       "small.png: image is 960x600 but the rig was calibrated for 1920x1200: use the images of the calibrated cameras"},
      {fmt::format("--rig '{}' --left '{}' --right '{}'", path("rig.yml"), path("blank.png"), path("R.png")),
       "blank.png: found 0 concentric-ring markers, expected 4"},
      {fmt::format("--rig '{}' --left '{}' --right '{}'", path("rig.yml"), path("colour.png"), path("R.png")),
       "colour.png: found 0 concentric-ring markers"},
      {fmt::format("--rig '{}' --left '{}' --right '{}'", path("rig_no_T.yml"), path("L.png"), path("R.png")),
       "missing key 'T'"},
      {fmt::format("--rig '{}' --left '{}' --right '{}'", path("nothing.yml"), path("L.png"), path("R.png")),
       "nothing.yml: cannot open rig file"},
  };
  for (const auto& b : bad) {
    std::filesystem::remove(path("out.yml"));
    r = RunFlatscan(fmt::format("calibrate-plane {} -o '{}' --json '{}'", b.args, path("out.yml"), path("out.json")));
    EXPECT_EQ(r.exit_code, 2) << b.args << "\n" << r.err;
    EXPECT_NE(r.err.find(b.message), std::string::npos) << b.message << "\n" << r.err;
    EXPECT_FALSE(std::filesystem::exists(path("out.yml"))) << b.args;
    EXPECT_FALSE(std::filesystem::exists(path("out.json"))) << b.args;
  }
  // Before: -o onto its own --rig replaced the rig; a --json into a missing folder failed
  // only after the plane file was written.
  const std::string rig_bytes = testing::ReadFileBytes(path("rig.yml"));
  r = RunFlatscan(base + fmt::format(" -o '{}'", path("rig.yml")));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find(fmt::format("--output '{}': is the input of --rig", path("rig.yml"))), std::string::npos) << r.err;
  EXPECT_EQ(testing::ReadFileBytes(path("rig.yml")), rig_bytes);
  r = RunFlatscan(base + fmt::format(" -o '{}' --json /missing/p.json", path("out.yml")));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--json '/missing/p.json': the folder '/missing' does not exist"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(path("out.yml")));
}

}  // namespace
}  // namespace flatscan
