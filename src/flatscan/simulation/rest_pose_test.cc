#include "flatscan/simulation/rest_pose.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <gtest/gtest.h>

#include "flatscan/geometry/small_lp.h"
#include "flatscan/util/random.h"

namespace flatscan {
namespace {

std::vector<Eigen::Vector3d> Transform(const Rigid3d& t, const std::vector<Eigen::Vector3d>& p) {
  std::vector<Eigen::Vector3d> out;
  for (const Eigen::Vector3d& x : p) out.push_back(t * x);
  return out;
}

// The boundary of [-a, a]^2 (corners included) and an interior grid, z = f(x, y).
template <typename F>
std::vector<Eigen::Vector3d> SquareSamples(double a, int per_side, int interior, F f) {
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < per_side; ++i) {
    const double s = -a + 2.0 * a * i / per_side;
    for (const Eigen::Vector2d& xy : {Eigen::Vector2d(s, -a), Eigen::Vector2d(a, s),
                                     Eigen::Vector2d(-s, a), Eigen::Vector2d(-a, -s)}) {
      points.emplace_back(xy.x(), xy.y(), f(xy.x(), xy.y()));
    }
  }
  for (int i = 1; i < interior; ++i) {
    for (int j = 1; j < interior; ++j) {
      const double x = -a + 2.0 * a * i / interior, y = -a + 2.0 * a * j / interior;
      points.emplace_back(x, y, f(x, y));
    }
  }
  return points;
}

// The properties every rest pose has (rest_pose.h).
void ExpectValidPose(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& com,
                     const RestPose& pose, double z_tol = 1e-12) {
  const Eigen::Matrix3d& r = pose.support_from_part.rotation;
  EXPECT_LT((r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-14);
  EXPECT_NEAR(r.determinant(), 1.0, 1e-14);
  // No spin about z: the rotation axis is horizontal, i.e. the upper-left 2 x 2 block
  // (cos t I + (1 - cos t) u u^T for a horizontal axis u) is symmetric.
  EXPECT_NEAR(r(0, 1), r(1, 0), 1e-14);
  const Eigen::Vector3d com_s = pose.support_from_part * com;
  EXPECT_NEAR(com_s.x(), 0.0, 1e-12);
  EXPECT_NEAR(com_s.y(), 0.0, 1e-12);
  const auto s = Transform(pose.support_from_part, points);
  for (size_t i = 0; i < s.size(); ++i) ASSERT_GE(s[i].z(), -z_tol) << "point " << i;
  EXPECT_NE(pose.contacts[0], pose.contacts[1]);
  EXPECT_NE(pose.contacts[0], pose.contacts[2]);
  EXPECT_NE(pose.contacts[1], pose.contacts[2]);
  Eigen::Vector2d weighted = Eigen::Vector2d::Zero();
  double sum = 0.0;
  for (int k = 0; k < 3; ++k) {
    ASSERT_GE(pose.contacts[k], 0);
    ASSERT_LT(pose.contacts[k], static_cast<int>(points.size()));
    EXPECT_NEAR(s[pose.contacts[k]].z(), 0.0, z_tol);
    EXPECT_GE(pose.barycentric[k], 0.0);
    sum += pose.barycentric[k];
    weighted += pose.barycentric[k] * s[pose.contacts[k]].head<2>();
  }
  EXPECT_NEAR(sum, 1.0, 1e-14);
  EXPECT_LT(weighted.norm(), 1e-9);
}

double MaxHeight(const std::vector<Eigen::Vector3d>& points, const RestPose& pose) {
  double h = -1e300;
  for (const Eigen::Vector3d& p : points) h = std::max(h, (pose.support_from_part * p).z());
  return h;
}

TEST(RestPose, TiltedFlatSquareRestsFlat) {
  for (const Eigen::Vector2d& slope :
       {Eigen::Vector2d(0.01, 0.02), Eigen::Vector2d(-0.3, 0.15), Eigen::Vector2d(0, 0)}) {
    auto plane = [&](double x, double y) { return slope.x() * x + slope.y() * y + 3.0; };
    const auto points = SquareSamples(50.0, 40, 20, plane);
    const Eigen::Vector3d com(1.5, -2.0, plane(1.5, -2.0) + 0.5);
    const RestPose pose = ComputeRestPose(points, com);
    ExpectValidPose(points, com, pose);
    for (const Eigen::Vector3d& p : Transform(pose.support_from_part, points))
      EXPECT_NEAR(p.z(), 0.0, 1e-12);
    const Eigen::Vector3d up = Eigen::Vector3d(-slope.x(), -slope.y(), 1.0).normalized();
    EXPECT_LT((pose.support_from_part.rotation * up - Eigen::Vector3d::UnitZ()).norm(), 1e-14);
    // The centre of mass sits 0.5 cos(tilt) above the support.
    EXPECT_NEAR((pose.support_from_part * com).z(), 0.5 * up.z(), 1e-12);
  }
}

TEST(RestPose, TwistRestsOnThreeCornersWithAnalyticFlatness) {
  // z = k x y over [-a, a]^2. Its lower convex hull is the two planes through three
  // corners each, z = -k a (x + y) - k a^2 and z = k a (x + y) - k a^2 (they meet over
  // the diagonal through (a, -a) and (-a, a)); the part rests on either. Over the first,
  // z - plane = k (x + a)(y + a) >= 0, largest at the fourth corner (a, a): 4 k a^2
  // vertically, i.e. 4 k a^2 / sqrt(1 + 2 k^2 a^2) along the plane's normal
  // (k a, k a, 1) / sqrt(1 + 2 k^2 a^2). Same for the other plane by symmetry.
  for (const double k : {1e-4, 4e-4, -3e-4}) {
    const double a = 40.0;
    const auto points = SquareSamples(a, 32, 16, [k](double x, double y) { return k * x * y; });
    for (const Eigen::Vector3d& com : {Eigen::Vector3d(0, 0, 0.5), Eigen::Vector3d(0, 0, 0),
                                      Eigen::Vector3d(0.7, 0.7, 0.5)}) {
      const RestPose pose = ComputeRestPose(points, com);
      ExpectValidPose(points, com, pose);
      const double expected = 4.0 * std::abs(k) * a * a / std::sqrt(1.0 + 2.0 * k * k * a * a);
      EXPECT_NEAR(MaxHeight(points, pose), expected, 1e-9 * expected) << "k " << k;
      // The highest point is a corner, the one opposite the support facet's apex.
      int highest = 0;
      const auto s = Transform(pose.support_from_part, points);
      for (size_t i = 0; i < s.size(); ++i)
        if (s[i].z() > s[highest].z()) highest = static_cast<int>(i);
      EXPECT_NEAR(std::abs(points[highest].x()), a, 1e-12);
      EXPECT_NEAR(std::abs(points[highest].y()), a, 1e-12);
      EXPECT_NEAR(points[highest].z(), std::abs(k) * a * a, 1e-12);
    }
  }
}

TEST(RestPose, CylinderBendHasValidSupport) {
  // z = c x^2: the lower hull has a degenerate support line x = 0; any facet next to it
  // with the centre of mass over it is a valid answer.
  for (const double c : {1e-4, 1e-3}) {
    const auto points = SquareSamples(30.0, 30, 15, [c](double x, double) { return c * x * x; });
    for (const Eigen::Vector3d& com : {Eigen::Vector3d(0, 0, 0.5), Eigen::Vector3d(0, 0, 0),
                                      Eigen::Vector3d(0, 3, 0.5)}) {
      const RestPose pose = ComputeRestPose(points, com);
      ExpectValidPose(points, com, pose);
      // Resting next to the valley line x = 0, on a facet reaching a sample spacing h
      // (2 mm) beyond it, the highest points are on an edge x = +-a: c a (a +- h).
      EXPECT_LE(MaxHeight(points, pose), c * 30.0 * 32.0 * (1.0 + 1e-9));
      EXPECT_GE(MaxHeight(points, pose), c * 30.0 * 28.0 * (1.0 - 1e-3));
    }
  }
  // The dome (c < 0) rests on its rim edges' corners.
  const auto dome = SquareSamples(30.0, 30, 15, [](double x, double) { return -1e-3 * x * x; });
  const Eigen::Vector3d com(0, 0, 0.5);
  const RestPose pose = ComputeRestPose(dome, com);
  ExpectValidPose(dome, com, pose);
  EXPECT_NEAR(MaxHeight(dome, pose), 0.9, 1e-12);
}

// Brute force of the defining property in the support frame: the plane z = 0 through
// the contacts is, among all planes through three points that stay below every point,
// the highest at the centre of mass (x = y = 0).
void ExpectBruteForceOptimal(const std::vector<Eigen::Vector3d>& points,
                             const Eigen::Vector3d& com, const RestPose& pose) {
  const auto s = Transform(pose.support_from_part, points);
  const int n = static_cast<int>(s.size());
  int planes_below = 0;
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      for (int k = j + 1; k < n; ++k) {
        Eigen::Matrix3d m;
        m << s[i].x(), s[i].y(), 1.0, s[j].x(), s[j].y(), 1.0, s[k].x(), s[k].y(), 1.0;
        if (std::abs(m.determinant()) < 1e-6) continue;
        const Eigen::Vector3d p = m.fullPivLu().solve(Eigen::Vector3d(s[i].z(), s[j].z(), s[k].z()));
        bool below = true;
        for (int l = 0; l < n && below; ++l)
          below = s[l].z() - (p(0) * s[l].x() + p(1) * s[l].y() + p(2)) >= -1e-9;
        if (!below) continue;
        ++planes_below;
        EXPECT_LE(p(2), 1e-9) << "plane through " << i << " " << j << " " << k;
      }
    }
  }
  EXPECT_GE(planes_below, 1);
  (void)com;
}

TEST(RestPose, RandomWarpMatchesBruteForce) {
  // Random low-order warps with a sizeable tilt of the part frame and a high centre of
  // mass, so that tilting onto the first facet often moves the rest to another one.
  Random rng(31337);
  int facet_changed = 0;
  for (int trial = 0; trial < 25; ++trial) {
    const double a = 50.0;
    const double bend = rng.Normal() * 1e-4, twist = rng.Normal() * 1e-4;
    const double c3 = rng.Normal() * 1e-6, c4 = rng.Normal() * 1e-6, tilt = rng.Normal() * 0.3;
    auto warp = [&](double x, double y) {
      return bend * x * x + twist * x * y + c3 * x * x * y + c4 * y * y * y + tilt * x;
    };
    std::vector<Eigen::Vector3d> points;
    for (const Eigen::Vector2d& corner :
         {Eigen::Vector2d(-a, -a), Eigen::Vector2d(a, -a), Eigen::Vector2d(a, a),
          Eigen::Vector2d(-a, a)}) {
      points.emplace_back(corner.x(), corner.y(), warp(corner.x(), corner.y()));
    }
    while (points.size() < 40) {
      const double x = rng.Uniform(-a, a), y = rng.Uniform(-a, a);
      points.emplace_back(x, y, warp(x, y));
    }
    const Eigen::Vector3d com(rng.Uniform(-10, 10), rng.Uniform(-10, 10), rng.Uniform(0.5, 20));
    const RestPose pose = ComputeRestPose(points, com);
    ExpectValidPose(points, com, pose, 1e-11);
    ExpectBruteForceOptimal(points, com, pose);
    // The support facet seen straight down the part frame's z axis (one LP).
    Eigen::MatrixXd lp_a(3, points.size());
    Eigen::VectorXd lp_c(points.size());
    for (size_t i = 0; i < points.size(); ++i) {
      lp_a.col(i) << points[i].x() - com.x(), points[i].y() - com.y(), 1.0;
      lp_c(i) = points[i].z();
    }
    const auto first = SolveStandardFormLp(lp_a, Eigen::Vector3d(0, 0, 1), lp_c);
    ASSERT_EQ(first.status, StandardFormLpResult::Status::kOptimal);
    std::array<int, 3> contacts = pose.contacts;
    std::sort(contacts.begin(), contacts.end());
    if (!std::equal(contacts.begin(), contacts.end(), first.basis.begin())) ++facet_changed;
  }
  EXPECT_GE(facet_changed, 3);  // the refinement in the facet frame was exercised
}

TEST(RestPose, IndependentOfSpinAndSmallTiltOfPartFrame) {
  // A twist with the centre of mass well inside one support facet: spinning the part
  // frame about the vertical (and translating it), or tilting it slightly, gives the
  // same contacts and heights.
  const auto points =
      SquareSamples(40.0, 20, 10, [](double x, double y) { return 2e-4 * x * y; });
  const Eigen::Vector3d com(5.0, 3.0, 0.5);
  const RestPose reference = ComputeRestPose(points, com);
  ExpectValidPose(points, com, reference);
  for (const Eigen::Matrix3d& r :
       {Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()).toRotationMatrix(),
        Eigen::AngleAxisd(1e-3, Eigen::Vector3d(1, 2, 0).normalized()).toRotationMatrix()}) {
    const Eigen::Vector3d shift(10.0, -20.0, 3.0);
    std::vector<Eigen::Vector3d> moved;
    for (const Eigen::Vector3d& p : points) moved.push_back(r * p + shift);
    const Eigen::Vector3d moved_com = r * com + shift;
    const RestPose pose = ComputeRestPose(moved, moved_com);
    ExpectValidPose(moved, moved_com, pose);
    std::array<int, 3> c0 = reference.contacts, c1 = pose.contacts;
    std::sort(c0.begin(), c0.end());
    std::sort(c1.begin(), c1.end());
    EXPECT_EQ(c0, c1);
    EXPECT_NEAR(MaxHeight(moved, pose), MaxHeight(points, reference), 1e-12);
    for (size_t i = 0; i < points.size(); ++i) {
      EXPECT_NEAR((pose.support_from_part * moved[i]).z(),
                  (reference.support_from_part * points[i]).z(), 1e-12);
    }
  }
}

TEST(RestPose, BadInputThrows) {
  const std::vector<Eigen::Vector3d> two = {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 0, 0)};
  EXPECT_THROW(ComputeRestPose(two, Eigen::Vector3d(0.5, 0, 1)), std::invalid_argument);
  const std::vector<Eigen::Vector3d> square = {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 0, 0),
                                               Eigen::Vector3d(1, 1, 0), Eigen::Vector3d(0, 1, 0)};
  try {
    ComputeRestPose(square, Eigen::Vector3d(5, 5, 0.1));
    ADD_FAILURE() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("convex hull"), std::string::npos) << e.what();
  }
  const std::vector<Eigen::Vector3d> line = {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 1, 0),
                                             Eigen::Vector3d(2, 2, 0.1)};
  EXPECT_THROW(ComputeRestPose(line, Eigen::Vector3d(1, 1, 1)), std::invalid_argument);
  // Valid minimal input: exactly three points.
  const std::vector<Eigen::Vector3d> tri = {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(4, 0, 0.2),
                                            Eigen::Vector3d(0, 4, -0.1)};
  const Eigen::Vector3d com(1, 1, 0.5);
  ExpectValidPose(tri, com, ComputeRestPose(tri, com));
}

}  // namespace
}  // namespace flatscan
