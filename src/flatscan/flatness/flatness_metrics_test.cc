#include "flatscan/flatness/flatness_metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "flatscan/util/random.h"

namespace flatscan {
namespace {

double WidthAlong(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& n) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const Eigen::Vector3d& p : points) {
    lo = std::min(lo, n.dot(p));
    hi = std::max(hi, n.dot(p));
  }
  return hi - lo;
}

// Points of a (2k+1) x (2k+1) grid over [-half, half]^2 with z = f(x, y).
template <typename F>
std::vector<Eigen::Vector3d> Grid(int k, double half, F f) {
  std::vector<Eigen::Vector3d> points;
  for (int i = -k; i <= k; ++i) {
    for (int j = -k; j <= k; ++j) {
      const double x = half * i / k, y = half * j / k;
      points.emplace_back(x, y, f(x, y));
    }
  }
  return points;
}

// A rigid motion to move test sets away from the nice axis-aligned frame.
std::vector<Eigen::Vector3d> Move(const std::vector<Eigen::Vector3d>& points,
                                  const Eigen::Matrix3d& r, const Eigen::Vector3d& t) {
  std::vector<Eigen::Vector3d> out;
  for (const Eigen::Vector3d& p : points) out.push_back(r * p + t);
  return out;
}

Eigen::Matrix3d SomeRotation(double ax, double ay, double az) {
  return (Eigen::AngleAxisd(az, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(ay, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(ax, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

TEST(Flatness, ExactPlaneAnyTiltIsZero) {
  const auto base = Grid(10, 40.0, [](double, double) { return 0.0; });
  for (const Eigen::Vector3d& angles :
       {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0.1, -0.2, 0.3),
        Eigen::Vector3d(1.2, 0.4, -2.0), Eigen::Vector3d(M_PI / 2, 0, 0)}) {
    const Eigen::Matrix3d r = SomeRotation(angles.x(), angles.y(), angles.z());
    const auto points = Move(base, r, Eigen::Vector3d(12.0, -30.0, 480.0));
    EXPECT_LT(LeastSquaresPeakToValley(points), 1e-11);
    Eigen::Vector3d zone_normal;
    EXPECT_LT(MinimumZoneFlatness(points, &zone_normal), 1e-11);
    EXPECT_NEAR(std::abs(zone_normal.dot(r.col(2))), 1.0, 1e-12);
  }
}

TEST(Flatness, SaddleAnalytic) {
  // z = k x y on the grid over [-a, a]^2 (corners included). By symmetry the TLS plane
  // is z = 0 and the residual range is [-k a^2, k a^2]: PV = 2 k a^2. The minimum zone
  // is the same: tilting the normal to (alpha, beta, 1) raises the vertical width over
  // the four corners to 2 k a^2 + 2 a max(|alpha|, |beta|), whose perpendicular value
  // stays >= 2 k a^2 while sqrt(2) k a <= 1.
  const double k = 2e-4, a = 30.0;
  const double expected = 2.0 * k * a * a;
  const auto base = Grid(12, a, [k](double x, double y) { return k * x * y; });
  const Eigen::Matrix3d r = SomeRotation(0.3, -0.1, 0.7);
  const auto points = Move(base, r, Eigen::Vector3d(-5.0, 8.0, 300.0));
  EXPECT_NEAR(LeastSquaresPeakToValley(points), expected, 1e-12);
  Eigen::Vector3d zone_normal;
  EXPECT_NEAR(MinimumZoneFlatness(points, &zone_normal), expected, 1e-12);
  EXPECT_NEAR(std::abs(zone_normal.dot(r.col(2))), 1.0, 1e-12);
}

TEST(Flatness, TiltedPlaneWithOneBump) {
  // A grid on a tilted plane with one interior point raised by h along the normal: the
  // minimum zone is exactly h (the grid forces width >= h cos(phi) + r sin(phi) >= h
  // for a zone tilted by phi, r >> h being the bump's distance to the grid's edge).
  const double h = 0.037;
  auto base = Grid(8, 25.0, [](double, double) { return 0.0; });
  base[3 * 17 + 5].z() += h;  // (x, y) = (-15.6, -9.4): 9.4 mm from the edge
  const Eigen::Matrix3d r = SomeRotation(-0.05, 0.08, 1.0);
  const auto points = Move(base, r, Eigen::Vector3d(3.0, 2.0, 1.0));
  Eigen::Vector3d zone_normal;
  EXPECT_NEAR(MinimumZoneFlatness(points, &zone_normal), h, 1e-12);
  EXPECT_NEAR(std::abs(zone_normal.dot(r.col(2))), 1.0, 1e-12);
  // The TLS plane is pulled toward the bump, so its PV exceeds h slightly.
  const double pv = LeastSquaresPeakToValley(points);
  EXPECT_GE(pv, h - 1e-12);
  EXPECT_LT(pv, 1.1 * h);
}

// Exact minimum width of a point set: the optimal zone's normal is either a facet
// normal of the convex hull (three points) or the cross product of two hull edge
// directions (four points), so the minimum over all such candidate directions is it.
double BruteForceMinimumWidth(const std::vector<Eigen::Vector3d>& points) {
  const int n = static_cast<int>(points.size());
  double best = std::numeric_limits<double>::infinity();
  auto consider = [&](const Eigen::Vector3d& v) {
    const double norm = v.norm();
    if (norm < 1e-12) return;
    best = std::min(best, WidthAlong(points, v / norm));
  };
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j)
      for (int k = j + 1; k < n; ++k) consider((points[j] - points[i]).cross(points[k] - points[i]));
  std::vector<Eigen::Vector3d> edges;
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j) edges.push_back(points[j] - points[i]);
  for (size_t e = 0; e < edges.size(); ++e)
    for (size_t f = e + 1; f < edges.size(); ++f) consider(edges[e].cross(edges[f]));
  return best;
}

// Random flat-ish point sets: a warped patch (bending, twist, noise), moved rigidly.
std::vector<Eigen::Vector3d> RandomPatch(Random& rng, int count, double half, double warp) {
  const double bend = rng.Normal() * warp / (half * half);
  const double twist = rng.Normal() * warp / (half * half);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < count; ++i) {
    const double x = rng.Uniform(-half, half), y = rng.Uniform(-half, half);
    points.emplace_back(x, y, bend * x * x + twist * x * y + warp * 0.3 * rng.Normal());
  }
  const Eigen::Matrix3d r =
      SomeRotation(rng.Uniform(-0.5, 0.5), rng.Uniform(-0.5, 0.5), rng.Uniform(-3, 3));
  return Move(points, r, Eigen::Vector3d(rng.Normal() * 50, rng.Normal() * 50, 400));
}

TEST(Flatness, MinimumZoneAgainstExactBruteForce) {
  Random rng(99);
  for (int trial = 0; trial < 40; ++trial) {
    const int count = 5 + trial % 10;
    const auto points = RandomPatch(rng, count, 20.0, trial % 2 ? 0.5 : 3.0);
    Eigen::Vector3d zone_normal;
    const double minzone = MinimumZoneFlatness(points, &zone_normal);
    const double brute = BruteForceMinimumWidth(points);
    EXPECT_NEAR(minzone, brute, 1e-10 * (1.0 + brute)) << "trial " << trial;
    EXPECT_NEAR(zone_normal.norm(), 1.0, 1e-14);
    EXPECT_NEAR(WidthAlong(points, zone_normal), minzone, 1e-11);
  }
}

TEST(Flatness, MinimumZoneAgainstSampledNormals) {
  // No sampled direction near the zone normal gives a thinner slab.
  Random rng(5);
  for (int trial = 0; trial < 10; ++trial) {
    const auto points = RandomPatch(rng, 200, 30.0, 0.2);
    Eigen::Vector3d zone_normal;
    const double minzone = MinimumZoneFlatness(points, &zone_normal);
    double sampled = std::numeric_limits<double>::infinity();
    for (int s = 0; s < 20000; ++s) {
      const double spread = (s % 2) ? 1e-2 : 1e-4;
      const Eigen::Vector3d v =
          zone_normal + spread * Eigen::Vector3d(rng.Normal(), rng.Normal(), rng.Normal());
      sampled = std::min(sampled, WidthAlong(points, v.normalized()));
    }
    EXPECT_LE(minzone, sampled + 1e-12) << "trial " << trial;
    EXPECT_LE(minzone, LeastSquaresPeakToValley(points) + 1e-12);
  }
}

TEST(Flatness, MinimumZoneNeverExceedsLeastSquaresPv) {
  Random rng(1234);
  for (int trial = 0; trial < 100; ++trial) {
    const int count = 3 + static_cast<int>(rng.NextU64() % 300);
    const auto points = RandomPatch(rng, count, rng.Uniform(1.0, 100.0), rng.Uniform(0.0, 2.0));
    const double pv = LeastSquaresPeakToValley(points);
    const double minzone = MinimumZoneFlatness(points);
    EXPECT_LE(minzone, pv + 1e-12) << "trial " << trial;
    EXPECT_GE(minzone, 0.0);
    if (count == 3) {
      EXPECT_LT(minzone, 1e-11);
    }
  }
}

TEST(Flatness, CollinearPointsHaveZeroZone) {
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 20; ++i) points.emplace_back(1.0 + i, 2.0 - 0.5 * i, 3.0 + 0.25 * i);
  EXPECT_LT(LeastSquaresPeakToValley(points), 1e-12);
  EXPECT_LT(MinimumZoneFlatness(points), 1e-12);
}

TEST(Flatness, ComputeFlatnessTakesMaxHeight) {
  const double k = 1e-4, a = 20.0;
  const auto points = Grid(6, a, [k](double x, double y) { return k * x * y; });
  std::vector<double> heights;
  for (const Eigen::Vector3d& p : points) heights.push_back(p.z() + k * a * a);
  heights[7] = 0.75;
  const FlatnessValues v = ComputeFlatness(points, heights);
  EXPECT_EQ(v.flatness_mm, 0.75);
  EXPECT_NEAR(v.lsq_pv_mm, 2.0 * k * a * a, 1e-13);
  EXPECT_NEAR(v.minzone_mm, 2.0 * k * a * a, 1e-13);
  heights[7] = 0.0;
  EXPECT_NEAR(ComputeFlatness(points, heights).flatness_mm, 2.0 * k * a * a, 1e-15);
}

TEST(Flatness, BadInputThrows) {
  const std::vector<Eigen::Vector3d> two = {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 0, 0)};
  EXPECT_THROW(MinimumZoneFlatness(two), std::invalid_argument);
  const auto points = Grid(2, 1.0, [](double, double) { return 0.0; });
  EXPECT_THROW(ComputeFlatness(points, std::vector<double>(3, 0.0)), std::invalid_argument);
}

}  // namespace
}  // namespace flatscan
