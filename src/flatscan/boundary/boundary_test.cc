#include "flatscan/boundary/boundary.h"

#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "flatscan/boundary/canny.h"
#include "flatscan/boundary/edge_refinement.h"
#include "flatscan/boundary/zernike.h"
#include "flatscan/simulation/coverage_renderer.h"
#include "flatscan/simulation/image_formation.h"
#include "flatscan/util/error.h"
#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {

// Exact-coverage image of a 2D shape (signed distance in px, negative = dark), with
// image point (x, y) = plane point (x, y): a distortion-free camera looking at a
// plane at distance f with focal length f, principal point at the origin.
cv::Mat1b RenderShape(int width, int height, const PlanarOccluder::Sdf2d& sdf, double blur, double noise,
                      uint64_t seed, std::vector<Eigen::Vector2d> outline) {
  Camera cam;
  cam.width = width;
  cam.height = height;
  cam.fx = cam.fy = 1000.0;
  cam.cx = cam.cy = 0.0;
  Rigid3d cam_from_plane;
  cam_from_plane.translation = Eigen::Vector3d(0, 0, 1000.0);
  // The "support" frame is the plane frame here; the occluder lies in it at z = 0.
  const PlanarOccluder occluder(Rigid3d(), sdf, std::move(outline));
  const CoverageTile tile = RenderCoverage(cam, cam_from_plane, occluder);
  cv::Mat1f radiance(height, width, 220.0f);
  BlendCoverage(radiance, tile, 20.0);
  BlurRegions(radiance, blur, {});
  return QuantizeWithNoise(radiance, noise, seed);
}

// A dark disc of `radius` px about `c` on a size x size image, noise 2 grey.
cv::Mat1b RenderDisc(int size, const Eigen::Vector2d& c, double radius, double blur, uint64_t seed) {
  return RenderShape(size, size, [=](const Eigen::Vector2d& p) { return (p - c).norm() - radius; }, blur, 2.0, seed,
                     {c + Eigen::Vector2d(-radius, -radius), c + Eigen::Vector2d(radius, radius)});
}

struct ErrorStats {
  double rms = 0, max = 0, bias = 0;
  int n = 0;
};

ErrorStats DiscErrors(const BoundaryResult& r, Eigen::Vector2d c, double radius) {
  ErrorStats s;
  for (const EdgePoint& p : r.points) {
    const double e = (Eigen::Vector2d(p.x, p.y) - c).norm() - radius;
    s.rms += e * e;
    s.bias += e;
    s.max = std::max(s.max, std::abs(e));
    ++s.n;
  }
  s.rms = std::sqrt(s.rms / std::max(s.n, 1));
  s.bias /= std::max(s.n, 1);
  return s;
}

TEST(Boundary, ZernikeIsExactOnAnIdealStep) {
  // A sharp vertical step between pixel columns: no blur, no noise. Coverage makes
  // the edge at x = 20.3 (pixel 20 is 80% dark).
  for (double edge : {19.8, 20.0, 20.3}) {
    const cv::Mat1b img = RenderShape(40, 40, [edge](const Eigen::Vector2d& p) { return p.x() - edge; }, 0.0, 0.0, 1,
                                      {{-1, -1}, {41, -1}, {41, 41}, {-1, 41}});
    const ZernikeEdge z = ZernikeEdgeAt(img, 20, 20);
    ASSERT_TRUE(z.valid);
    EXPECT_NEAR(z.nx, 1.0, 1e-6);
    EXPECT_NEAR(20 + z.offset_px, edge, 0.03);  // 8-bit rounding of the covered pixel
    EXPECT_NEAR(z.step, 200.0, 8.0);  // the discrete disc masks lose ~3% of the step
  }
}

TEST(Boundary, BlurModelOnABlurredNoisyDisc) {
  const Eigen::Vector2d c(40.3, 38.7);
  for (double radius : {5.0, 12.5, 30.0}) {
    const cv::Mat1b img = RenderDisc(96, c, radius, 1.0, 7);
    const BoundaryResult r = DetectBoundary(img);
    ASSERT_EQ(r.contours.size(), 1u) << radius;
    EXPECT_TRUE(r.contours[0].closed);
    const ErrorStats s = DiscErrors(r, c, radius);
    EXPECT_GT(s.n, 5 * radius);
    EXPECT_LT(s.rms, 0.03) << radius;
    EXPECT_LT(std::abs(s.bias), 0.03) << radius;
    EXPECT_NEAR(r.blur_sigma_px, 1.0, 0.25);
    for (const EdgePoint& p : r.points) {  // normals point outward (dark disc, bright field)
      const Eigen::Vector2d radial = (Eigen::Vector2d(p.x, p.y) - c).normalized();
      EXPECT_GT(radial.dot(Eigen::Vector2d(p.nx, p.ny)), 0.99);
    }
    // The paper's operator alone is biased under blur; the model removes that.
    BoundaryOptions zernike;
    zernike.method = EdgeMethod::kZernike;
    EXPECT_GT(DiscErrors(DetectBoundary(img, zernike), c, radius).rms, 1.5 * s.rms);
  }
}

// Under a broad blur (2.5 px) Canny's edge grows spurs, and the chains walked from its
// pixels end at them: the pieces are joined (chain_linking.h), so a disc is one closed
// contour. (Measured, 4 seeds: unjoined 1, 1, 2 and 3 pieces at 2.5 px; 6-14 at 3 px,
// where joined leaves 1-2.)
TEST(Boundary, ABroadlyBlurredDiscIsOneClosedContour) {
  const Eigen::Vector2d c(150.3, 148.7);
  const double radius = 120.0;
  int pieces_before = 0;
  for (uint64_t seed : {3, 4, 5, 6}) {
    const cv::Mat1b img = RenderDisc(300, c, radius, 2.5, seed);
    const BoundaryResult r = DetectBoundary(img);
    ASSERT_EQ(r.contours.size(), 1u) << seed;
    EXPECT_TRUE(r.contours[0].closed);
    const ErrorStats s = DiscErrors(r, c, radius);
    EXPECT_GT(s.n, 5 * radius);
    EXPECT_LT(s.rms, 0.05) << seed;
    BoundaryOptions zernike;  // the reference rows are not joined: the pieces as walked
    zernike.method = EdgeMethod::kZernike;
    pieces_before += static_cast<int>(DetectBoundary(img, zernike).contours.size());
  }
  EXPECT_GT(pieces_before, 4);  // the test shows a case that needs the joining
}

TEST(Boundary, CrossRowsInterpolatesTheChainAtEveryRow) {
  const Eigen::Vector2d c(40.0, 40.0);
  const cv::Mat1b img = RenderShape(
      80, 80, [&](const Eigen::Vector2d& p) { return (p - c).norm() - 20.0; }, 1.0, 0.0, 1, {{19, 19}, {61, 61}});
  const BoundaryResult r = DetectBoundary(img);
  const std::vector<RowCrossing> rows = CrossRows(r);
  // Rows 21..59 cross the circle twice (rows 20 and 60 graze it).
  int count = 0;
  for (const RowCrossing& rc : rows) {
    if (rc.row < 22 || rc.row > 58) continue;
    ++count;
    const double dy = rc.row - c.y();
    const double expected = c.x() + (rc.x > c.x() ? 1 : -1) * std::sqrt(400.0 - dy * dy);
    EXPECT_NEAR(rc.x, expected, 0.05) << rc.row;
    EXPECT_GT((rc.x - c.x()) * rc.nx, 0.0);  // outward normal
  }
  EXPECT_EQ(count, 2 * (58 - 22 + 1));
  // Through a map (here a shift by (5, 0.5)) the crossings are those of the mapped circle.
  const std::vector<RowCrossing> shifted =
      CrossRows(r, [](const Eigen::Vector2d& p) { return Eigen::Vector2d(p + Eigen::Vector2d(5, 0.5)); });
  int shifted_count = 0;
  for (const RowCrossing& rc : shifted) {
    if (rc.row < 23 || rc.row > 58) continue;
    ++shifted_count;
    const double dy = rc.row - (c.y() + 0.5);
    EXPECT_NEAR(rc.x, c.x() + 5 + (rc.x > c.x() + 5 ? 1 : -1) * std::sqrt(400.0 - dy * dy), 0.05) << rc.row;
  }
  EXPECT_EQ(shifted_count, 2 * (58 - 23 + 1));
}

// Before: a map that stretched the rows without bound (a rig with its baseline along z)
// added one crossing per row between two chain points: 16.8 GB, and a cast of huge or
// NaN y to int.
TEST(Boundary, CrossRowsStaysBoundedUnderADegenerateMap) {
  const Eigen::Vector2d c(40.0, 40.0);
  const cv::Mat1b img = RenderShape(
      80, 80, [&](const Eigen::Vector2d& p) { return (p - c).norm() - 20.0; }, 1.0, 0.0, 1, {{19, 19}, {61, 61}});
  const BoundaryResult r = DetectBoundary(img);
  const size_t points = r.points.size();
  for (const double stretch : {1e3, 1e9, 1e300}) {
    const std::vector<RowCrossing> rows =
        CrossRows(r, [&](const Eigen::Vector2d& p) { return Eigen::Vector2d(p.x(), stretch * (p.y() - 40)); });
    EXPECT_LE(rows.size(), 2 * points) << stretch;  // a few segments at most, never one per row
  }
  const std::vector<RowCrossing> nan_rows =
      CrossRows(r, [](const Eigen::Vector2d& p) { return Eigen::Vector2d(p.x(), std::nan("")); });
  EXPECT_TRUE(nan_rows.empty());
}

TEST(Boundary, FusedCannyGivesCvCannysEdgeSet) {
  // Random blurred shapes and noise, with a constant 3 px frame so that cv::Canny's
  // border handling plays no part.
  cv::RNG rng(5);
  for (int trial = 0; trial < 4; ++trial) {
    cv::Mat1b img(157 + trial, 203 + 3 * trial, uint8_t(120));
    for (int i = 0; i < 40; ++i)
      cv::circle(img, cv::Point(rng.uniform(0, img.cols), rng.uniform(0, img.rows)), rng.uniform(2, 30),
                 rng.uniform(0, 256), i % 2 ? cv::FILLED : 2, cv::LINE_AA);
    cv::GaussianBlur(img, img, cv::Size(5, 5), 0.8 + 0.2 * trial);
    cv::Mat1s noise(img.size());
    rng.fill(noise, cv::RNG::NORMAL, 0, 2 + trial);
    cv::add(img, noise, img, cv::noArray(), CV_8U);
    img.rowRange(0, 3).setTo(120), img.rowRange(img.rows - 3, img.rows).setTo(120);
    img.colRange(0, 3).setTo(120), img.colRange(img.cols - 3, img.cols).setTo(120);
    for (const auto& [low, high] : {std::pair{40.0, 100.0}, std::pair{10.0, 30.0}, std::pair{70.5, 70.5}}) {
      cv::Mat1b expected;
      cv::Canny(img, expected, low, high, 3, true);
      cv::Mat1b map(img.rows + 2, img.cols + 2, uint8_t(7));
      std::vector<uint8_t*> stack;
      const cv::Rect rect(1, 1, img.cols - 2, img.rows - 2);
      CannyInto(img, rect, CannyThresholds::FromL2(low, high), map.ptr<uint8_t>(2) + 2, map.step1(), stack);
      int differences = 0, edges = 0;
      for (int v = 0; v < img.rows; ++v)
        for (int u = 0; u < img.cols; ++u) {
          const bool ours = rect.contains({u, v}) && map(v + 1, u + 1) == kCannyEdge;
          differences += ours != (expected(v, u) != 0);
          edges += ours;
        }
      EXPECT_EQ(differences, 0) << trial << " " << low;
      EXPECT_GT(edges, 300) << trial << " " << low;
      // The frame is set, the rest of the map is untouched.
      EXPECT_EQ(map(1, 5), kCannyNone);
      EXPECT_EQ(map(0, 5), 7);
    }
  }
}

TEST(Boundary, BatchedProfileCrossingsMatchOneAtATime) {
  // Blurred noisy edges in every direction, profiles along every axis, with the blur
  // given wrong by up to 40%; also pixels too near the border (invalid).
  const Eigen::Vector2d c(60.2, 59.6);
  const cv::Mat1b img = RenderShape(
      120, 120, [&](const Eigen::Vector2d& p) { return (p - c).norm() - 30.0; }, 1.2, 3.0, 9,
      {c + Eigen::Vector2d(-30, -30), c + Eigen::Vector2d(30, 30)});
  std::vector<ProfileRequest> requests;
  cv::RNG rng(2);
  for (int i = 0; i < 400; ++i) {
    const double a = 2 * M_PI * i / 400;
    const Eigen::Vector2d n(std::cos(a), std::sin(a));
    const Eigen::Vector2d p = c + (30 + rng.uniform(-1.0, 1.0)) * n;
    ProfileRequest q;
    q.u = static_cast<int>(std::lround(p.x()));
    q.v = static_cast<int>(std::lround(p.y()));
    q.axis = ClosestProfileAxis(n);
    q.profile_sigma = static_cast<float>(rng.uniform(0.8, 1.7));
    requests.push_back(q);
  }
  requests.push_back({3, 50, ProfileAxis{1, 0}, 1.0f});
  requests.push_back({50, 116, ProfileAxis{0, 1}, 1.0f});
  std::vector<ProfileCrossing> batched;
  MeasureProfileCrossings(img, requests, 1.3, batched);
  ASSERT_EQ(batched.size(), requests.size());
  int valid = 0;
  for (size_t i = 0; i < requests.size(); ++i) {
    const ProfileRequest& q = requests[i];
    const ProfileCrossing one = MeasureProfileCrossing(img, q.u, q.v, q.axis, 1.3, q.profile_sigma);
    ASSERT_EQ(batched[i].valid, one.valid) << i;
    if (!one.valid) continue;
    ++valid;
    EXPECT_NEAR(batched[i].position, one.position, 2e-4) << i;
    EXPECT_NEAR(batched[i].step, one.step, 1e-3) << i;
  }
  EXPECT_GT(valid, 300);
  EXPECT_FALSE(batched[400].valid);
  EXPECT_FALSE(batched[401].valid);
}

TEST(Boundary, BadImagesAreRejectedWithAMessage) {
  auto message = [](const cv::Mat& m) { return testing::InputErrorOf([&] { DetectBoundary(m); }); };
  EXPECT_EQ(message(cv::Mat()), "image is empty (expected an 8-bit grey image)");
  EXPECT_EQ(message(cv::Mat3b(50, 50)), "image must be 8-bit single-channel grey, got 3 channel(s) of depth 0");
  EXPECT_EQ(message(cv::Mat1b(10, 50, uint8_t(0))), "image is 50x10 px, smaller than the edge operator's 13x13 window");
  // No edge at all: an empty result, not an error.
  EXPECT_TRUE(DetectBoundary(cv::Mat1b(64, 64, uint8_t(200))).points.empty());
}

}  // namespace
}  // namespace flatscan
