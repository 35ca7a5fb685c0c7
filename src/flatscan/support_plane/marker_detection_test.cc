#include "flatscan/support_plane/marker_detection.h"

#include <cmath>
#include <functional>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "flatscan/simulation/dataset.h"
#include "flatscan/simulation/station.h"

namespace flatscan {
namespace {

// The paper's station with the plane tilted 10 degrees, and its left marker image
// (rendered once: ~0.3 s).
struct TiltedStation {
  Station station;
  cv::Mat1b left;
  TiltedStation() {
    SceneConfig scene = ScenePreset("paper");
    scene.plane.tilt_deg = 10.0;
    scene.plane.tilt_azimuth_deg = 30.0;
    station = BuildStation(scene);
    left = RenderMarkerImage(station, RigSide::kLeft, 17);
  }
  // True image of marker k's centre in camera `camera` (raw pixels).
  Eigen::Vector2d TrueCentre(RigSide camera, int k) const {
    const Eigen::Vector2d& m = station.markers[k];
    return station.GetCamera(camera).Project(station.CamFromSupport(camera) * Eigen::Vector3d(m.x(), m.y(), 0));
  }
};

const TiltedStation& Tilted() {
  static const TiltedStation s;
  return s;
}

// Paints shapes of grey level `grey` into `image`: a coverage mask drawn anti-aliased,
// blurred like the lens (sigma 1 px), then blended.
void Paint(cv::Mat1b& image, double grey, const std::function<void(cv::Mat1b&)>& draw) {
  cv::Mat1b mask = cv::Mat1b::zeros(image.size());
  draw(mask);
  const cv::Rect box = (cv::boundingRect(mask) + cv::Size(10, 10) - cv::Point(5, 5)) &
                       cv::Rect(0, 0, image.cols, image.rows);
  cv::Mat1f coverage;
  mask(box).convertTo(coverage, CV_32F, 1.0 / 255.0);
  cv::GaussianBlur(coverage, coverage, cv::Size(0, 0), 1.0);
  for (int v = 0; v < box.height; ++v)
    for (int u = 0; u < box.width; ++u) {
      const float c = coverage(v, u);
      uint8_t& px = image(box.y + v, box.x + u);
      if (c > 0) px = cv::saturate_cast<uint8_t>(px * (1 - c) + grey * c);
    }
}

constexpr int kShift = 4, kScale = 1 << kShift;  // sub-pixel drawing
cv::Point At(double u, double v) { return {int(std::lround(u * kScale)), int(std::lround(v * kScale))}; }

TEST(MarkerDetection, FindsTheFourRingsWithUnbiasedCentres) {
  const TiltedStation& t = Tilted();
  const MarkerDetection d = DetectRingMarkers(t.left, t.station.rig.left);
  ASSERT_EQ(d.markers.size(), 4u);
  // Station markers are (-x,-y), (x,-y), (-x,y), (x,y) on the support plane; the
  // detection order is by angle in the image (top-left first, clockwise on screen).
  std::vector<int> truth_index;
  for (const RingMarker& m : d.markers) {
    int best = 0;
    for (int k = 1; k < 4; ++k)
      if ((t.TrueCentre(RigSide::kLeft, k) - m.centre_px).norm() < (t.TrueCentre(RigSide::kLeft, best) - m.centre_px).norm()) best = k;
    truth_index.push_back(best);
  }
  for (int i = 0; i < 4; ++i) {
    const RingMarker& m = d.markers[i];
    const Eigen::Vector2d truth = t.TrueCentre(RigSide::kLeft, truth_index[i]);
    const double corrected = (m.centre_px - truth).norm(), naive = (m.naive_centre_px - truth).norm();
    std::printf("marker %d at (%.1f, %.1f): corrected centre error %.4f px, naive %.4f px, fit rms %.3f / %.3f px, "
                "radius ratio %.3f\n",
                i, m.centre_px.x(), m.centre_px.y(), corrected, naive, m.outer.rms_px, m.inner.rms_px, m.radius_ratio);
    EXPECT_LT(corrected, 0.02) << i;
    EXPECT_GT(naive, 0.1) << i;  // the perspective bias the correction removes
    EXPECT_NEAR(m.radius_ratio, 0.4, 0.01);
    EXPECT_LT(m.outer.rms_px, 0.1);
  }
  // Ordered by angle around the centroid: top-left, top-right, bottom-right, bottom-left.
  EXPECT_LT(d.markers[0].centre_px.x(), d.markers[1].centre_px.x());
  EXPECT_LT(d.markers[1].centre_px.y(), d.markers[2].centre_px.y());
  EXPECT_GT(d.markers[2].centre_px.x(), d.markers[3].centre_px.x());
  EXPECT_GT(d.markers[3].centre_px.y(), d.markers[0].centre_px.y());
}

TEST(MarkerDetection, IgnoresDustBlobsAndAMarkerCutByTheBorder) {
  const TiltedStation& t = Tilted();
  const MarkerDetection clean = DetectRingMarkers(t.left, t.station.rig.left);
  ASSERT_EQ(clean.markers.size(), 4u);
  cv::Mat1b image = t.left.clone();
  const int mid = image.rows / 2;
  Paint(image, 15.0, [&](cv::Mat1b& mask) {
    // A ring marker cut by the left border (outer radius 140 px, inner 56 px).
    cv::circle(mask, At(60, mid), 98 * kScale, 255, 84, cv::LINE_AA, kShift);
    // Dust: small spots, a dark disc without a hole, an elongated blob, a square, and
    // a disc that gets an off-centre hole below.
    cv::circle(mask, At(1290.3, mid - 40.6), 4 * kScale, 255, cv::FILLED, cv::LINE_AA, kShift);
    cv::circle(mask, At(1250.0, mid + 60.0), 2 * kScale, 255, cv::FILLED, cv::LINE_AA, kShift);
    cv::circle(mask, At(900.0, mid), 40 * kScale, 255, cv::FILLED, cv::LINE_AA, kShift);
    cv::ellipse(mask, cv::RotatedRect(cv::Point2f(1600, mid), cv::Size2f(90, 20), 30), 255, cv::FILLED, cv::LINE_AA);
    cv::rectangle(mask, cv::Rect(1900, mid - 50, 100, 100), 255, cv::FILLED, cv::LINE_AA);
    cv::circle(mask, At(2200.0, mid), 70 * kScale, 255, cv::FILLED, cv::LINE_AA, kShift);
  });
  // Dust specks touching the outer edge of one marker and the inner edge of another.
  const RingMarker& m0 = clean.markers[0];
  const RingMarker& m2 = clean.markers[2];
  Paint(image, 15.0, [&](cv::Mat1b& mask) {
    const Eigen::Vector2d out = m0.centre_px + Eigen::Vector2d(0.6, 0.8) * (m0.outer.ellipse.a + 3);
    cv::circle(mask, At(out.x(), out.y()), 6 * kScale, 255, cv::FILLED, cv::LINE_AA, kShift);
    const Eigen::Vector2d in = m2.centre_px + Eigen::Vector2d(-0.8, 0.6) * (m2.inner.ellipse.b - 3);
    cv::circle(mask, At(in.x(), in.y()), 5 * kScale, 255, cv::FILLED, cv::LINE_AA, kShift);
  });
  Paint(image, 215.0, [&](cv::Mat1b& mask) {
    cv::circle(mask, At(2225.0, mid), 25 * kScale, 255, cv::FILLED, cv::LINE_AA, kShift);
  });

  const MarkerDetection d = DetectRingMarkers(image, t.station.rig.left);
  for (const RejectedContour& r : d.rejected)
    std::printf("rejected contour %d at (%.0f, %.0f): %s\n", r.contour, r.centroid_px.x(), r.centroid_px.y(),
                r.reason.c_str());
  ASSERT_EQ(d.markers.size(), 4u);
  // The same markers; only the global blur estimate moves by the added edges, and the
  // dusty edges lose a few points.
  for (int i = 0; i < 4; ++i) {
    const RingMarker& m = d.markers[i];
    std::printf("marker %d: centre moved %.4f px; outliers %d outer, %d inner\n", i,
                (m.centre_px - clean.markers[i].centre_px).norm(), m.outer.outliers, m.inner.outliers);
    EXPECT_NEAR((m.centre_px - clean.markers[i].centre_px).norm(), 0.0, 3e-3);
  }
  EXPECT_GT(d.markers[0].outer.outliers, 5);
  EXPECT_GT(d.markers[2].inner.outliers, 5);
  EXPECT_GE(d.rejected.size(), 6u);
}

TEST(MarkerDetection, NothingInAPlainBacklight) {
  cv::Mat1b image(600, 800, uint8_t(210));
  Camera camera;
  camera.width = 800;
  camera.height = 600;
  camera.fx = camera.fy = 1000;
  camera.cx = 399.5;
  camera.cy = 299.5;
  const MarkerDetection d = DetectRingMarkers(image, camera);
  EXPECT_TRUE(d.markers.empty());
}

}  // namespace
}  // namespace flatscan
