#include "flatscan/boundary/edge_refinement.h"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "flatscan/util/random.h"

namespace flatscan {
namespace {

// Pixel-area integral of a Gaussian-blurred step across the line n . p = c (dark 20 on
// the n < c side, bright 220 beyond): each pixel averaged over 16 x 16 samples of
// b + h Phi(d / s), then rounded to 8 bits.
cv::Mat1b BlurredStraightEdge(int size, const Eigen::Vector2d& n, double c, double s) {
  cv::Mat1b image(size, size);
  constexpr int kSub = 16;
  for (int v = 0; v < size; ++v)
    for (int u = 0; u < size; ++u) {
      double sum = 0;
      for (int j = 0; j < kSub; ++j)
        for (int i = 0; i < kSub; ++i) {
          const Eigen::Vector2d p(u - 0.5 + (i + 0.5) / kSub, v - 0.5 + (j + 0.5) / kSub);
          sum += 0.5 * std::erfc(-(n.dot(p) - c) / (s * std::sqrt(2.0)));
        }
      image(v, u) = static_cast<uchar>(std::lround(20 + 200 * sum / (kSub * kSub)));
    }
  return image;
}

TEST(EdgeRefinement, ClosestProfileAxisIsWithin22Point5DegreesOfTheNormal) {
  const auto axis = [](double x, double y) {
    const ProfileAxis a = ClosestProfileAxis({x, y});
    return std::pair<int, int>(a.du, a.dv);
  };
  EXPECT_EQ(axis(1, 0.3), std::make_pair(1, 0));    // 16.7 degrees from the row
  EXPECT_EQ(axis(1, 0.5), std::make_pair(1, 1));    // 26.6 degrees: the diagonal
  EXPECT_EQ(axis(0.2, -1), std::make_pair(0, -1));
  EXPECT_EQ(axis(-1, -0.9), std::make_pair(-1, -1));
  EXPECT_EQ(axis(-3, 0.1), std::make_pair(-1, 0));  // any length
  EXPECT_DOUBLE_EQ((ProfileAxis{1, 1}.Length()), std::sqrt(2.0));
}

// The differences along a grid axis of a blurred straight step are symmetric about the
// step's crossing with that axis, whatever the step's angle: the centroid and the
// likelihood fit find the crossing.
TEST(EdgeRefinement, ProfileCrossingOfABlurredStraightEdgeAtAnyAngle) {
  const double s = 1.0, x0 = 20.3;
  for (const double angle_deg : {0.0, 10.0, 20.0}) {
    const double a = angle_deg * M_PI / 180;
    const Eigen::Vector2d n(std::cos(a), std::sin(a));
    const cv::Mat1b image = BlurredStraightEdge(41, n, n.dot(Eigen::Vector2d(x0, 20)), s);
    const ProfileAxis axis = ClosestProfileAxis(n);
    ASSERT_EQ(axis.du, 1);
    ASSERT_EQ(axis.dv, 0);
    const double truth = x0 - 20;  // the edge crosses row 20 at x0, whatever the angle
    const ProfileCrossing centroid = MeasureProfileCrossing(image, 20, 20, axis, 2.0, 0.0, true);
    ASSERT_TRUE(centroid.valid);
    EXPECT_NEAR(centroid.position, truth, 0.02) << angle_deg;
    EXPECT_NEAR(centroid.step, 200, 1.0);
    // Along the row the profile's sigma is s / cos(angle).
    EXPECT_NEAR(centroid.second_moment, s * s / (n.x() * n.x()), 0.15 * s * s / (n.x() * n.x())) << angle_deg;
    const double profile_sigma = std::sqrt(s * s + 1.0 / 12.0) / n.x();
    const ProfileCrossing fit = MeasureProfileCrossing(image, 20, 20, axis, 2.0, profile_sigma);
    ASSERT_TRUE(fit.valid);
    EXPECT_NEAR(fit.position, truth, 0.01) << angle_deg;
  }
}

TEST(EdgeRefinement, NoCrossingNearTheBorderOrOnAFlatImage) {
  const cv::Mat1b image = BlurredStraightEdge(41, {1, 0}, 20.3, 1.0);
  EXPECT_FALSE(MeasureProfileCrossing(image, 3, 20, {1, 0}, 2.0).valid);   // the window leaves the image
  EXPECT_FALSE(MeasureProfileCrossing(cv::Mat1b(41, 41, uchar(128)), 20, 20, {1, 0}, 2.0).valid);
  EXPECT_FALSE(MeasureProfileCrossing(image, 20, 20, {-1, 0}, 2.0).valid);  // against the step: negative
}

// A blurred dark disc's 50% contour lies inside the true circle by c s^2 (c half the
// curvature): the chain smoothing's circle fit (exact on a circle) gives the contour's
// curvature and moves the points out by c s^2, back onto the true circle to first
// order in s^2 / R^2.
TEST(EdgeRefinement, ChainSmoothingRestoresABlurredCircle) {
  const double radius = 30.0, blur_variance = 1.2;
  const double contour = radius - blur_variance / (2 * radius);
  const Eigen::Vector2d centre(50.2, 49.7);
  std::vector<ChainPoint> chain;
  const int n = 190;
  for (int k = 0; k < n; ++k) {
    const double t = 2 * M_PI * k / n;
    const Eigen::Vector2d radial(std::cos(t), std::sin(t));
    ChainPoint p;
    p.p = centre + contour * radial;
    p.normal = radial;  // dark inside: the normal points out
    chain.push_back(p);
  }
  SmoothAndCorrectChain(chain, /*closed=*/true, blur_variance);
  for (const ChainPoint& p : chain) {
    // Up to the SIMD path's float arithmetic (about 1e-6 px).
    EXPECT_NEAR((p.p - centre).norm(), contour + blur_variance / (2 * contour), 1e-6);
    EXPECT_NEAR((p.p - centre).norm(), radius, 2e-5);
    EXPECT_NEAR(p.normal.dot((p.p - centre).normalized()), 1.0, 1e-9);
    EXPECT_NEAR(p.curvature, -1.0 / contour, 1e-7);  // bends toward the dark side
  }
}

TEST(EdgeRefinement, ChainSmoothingAveragesNoiseAlongAStraightEdge) {
  Random rng(2);
  std::vector<ChainPoint> chain;
  double before = 0, after = 0;
  for (int k = 0; k < 200; ++k) {
    ChainPoint p;
    p.p = Eigen::Vector2d(k * 0.7, 10.0 + 0.05 * rng.Normal());
    p.normal = Eigen::Vector2d(0, 1);
    before += (p.p.y() - 10.0) * (p.p.y() - 10.0);
    chain.push_back(p);
  }
  SmoothAndCorrectChain(chain, /*closed=*/false, 1.0);
  for (const ChainPoint& p : chain) after += (p.p.y() - 10.0) * (p.p.y() - 10.0);
  EXPECT_LT(after, before / 3);  // 13-point fits: the noise's variance falls several times
}

TEST(EdgeRefinement, BlurVarianceIsTheMedianOfTheProfilesProjectedOntoTheNormal) {
  std::vector<ProfileCrossing> profiles(5);
  const std::vector<double> second_moments = {1.0, 1.4, 0.9, 9.0, 1.1};
  for (size_t i = 0; i < profiles.size(); ++i) {
    profiles[i].valid = true;
    profiles[i].second_moment = second_moments[i];
  }
  profiles[3].valid = false;  // left out
  const std::vector<double> components = {1.0, 0.9, 1.0, 1.0, 1.0};
  // Values 1.0, 1.134, 0.9, 1.1: the median (upper of the middle two) is 1.1.
  EXPECT_NEAR(EstimateBlurVariance(profiles, components), 1.1, 1e-12);
  EXPECT_NEAR(EstimateBlurVariance({}, {}), 1.0 + 1.0 / 12.0, 1e-12);  // nothing measured: blur 1 px
  profiles = {profiles[0]};
  profiles[0].second_moment = 0.01;
  EXPECT_NEAR(EstimateBlurVariance(profiles, {1.0}), 1.0 / 12.0, 1e-12);  // at least the pixel's box
}

}  // namespace
}  // namespace flatscan
