#include "flatscan/geometry/small_lp.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/LU>
#include <gtest/gtest.h>

#include "flatscan/util/random.h"

namespace flatscan {
namespace {

using Status = StandardFormLpResult::Status;

// Checks primal feasibility, dual feasibility and equal objectives (optimality
// certificate), and that y vanishes off the basis.
void ExpectOptimalCertificate(const Eigen::MatrixXd& a, const Eigen::VectorXd& b,
                              const Eigen::VectorXd& c, const StandardFormLpResult& r,
                              double tol = 1e-9) {
  ASSERT_EQ(r.status, Status::kOptimal);
  ASSERT_EQ(r.y.size(), a.cols());
  ASSERT_EQ(r.dual.size(), a.rows());
  const double scale = 1.0 + b.cwiseAbs().maxCoeff() + c.cwiseAbs().maxCoeff();
  EXPECT_GE(r.y.minCoeff(), 0.0);
  EXPECT_LE((a * r.y - b).cwiseAbs().maxCoeff(), tol * scale);
  const Eigen::VectorXd slack = c - a.transpose() * r.dual;
  EXPECT_GE(slack.minCoeff(), -tol * scale);
  EXPECT_NEAR(c.dot(r.y), r.objective, tol * scale);
  EXPECT_NEAR(b.dot(r.dual), r.objective, tol * scale);
  std::vector<char> basic(a.cols(), 0);
  for (int j : r.basis) {
    ASSERT_GE(j, 0);
    ASSERT_LT(j, a.cols());
    basic[j] = 1;
  }
  EXPECT_TRUE(std::is_sorted(r.basis.begin(), r.basis.end()));
  for (int j = 0; j < a.cols(); ++j) {
    if (!basic[j]) {
      EXPECT_EQ(r.y(j), 0.0) << "non-basic column " << j;
    }
  }
}

TEST(SmallLp, TextbookMaximization) {
  // max x1 + x2 s.t. x1 + 2 x2 <= 4, 3 x1 + x2 <= 6 (slacks s1, s2): optimum
  // x = (8/5, 6/5), value 14/5.
  Eigen::MatrixXd a(2, 4);
  a << 1, 2, 1, 0,  //
      3, 1, 0, 1;
  const Eigen::Vector2d b(4, 6);
  const Eigen::Vector4d c(-1, -1, 0, 0);
  const auto r = SolveStandardFormLp(a, b, c);
  ExpectOptimalCertificate(a, b, c, r);
  EXPECT_NEAR(r.objective, -14.0 / 5.0, 1e-14);
  EXPECT_NEAR(r.y(0), 8.0 / 5.0, 1e-14);
  EXPECT_NEAR(r.y(1), 6.0 / 5.0, 1e-14);
  EXPECT_EQ(r.basis, (std::vector<int>{0, 1}));
  // The dual is the (negated) shadow prices: (-2/5, -1/5).
  EXPECT_NEAR(r.dual(0), -0.4, 1e-14);
  EXPECT_NEAR(r.dual(1), -0.2, 1e-14);
}

TEST(SmallLp, NegativeRightHandSideNeedsPhaseOne) {
  // min 2 y0 + 3 y1 + y2 s.t. -y0 - y1 + y2 = -4, y0 - y1 = 1: y1 = y0 - 1,
  // y2 = 2 y0 - 5 >= 0 ... objective 2 y0 + 3 (y0 - 1) + (2 y0 - 5) = 7 y0 - 8 minimal at
  // y0 = 5/2 (y2 = 0): value 19/2.
  Eigen::MatrixXd a(2, 3);
  a << -1, -1, 1,  //
      1, -1, 0;
  const Eigen::Vector2d b(-4, 1);
  const Eigen::Vector3d c(2, 3, 1);
  const auto r = SolveStandardFormLp(a, b, c);
  ExpectOptimalCertificate(a, b, c, r);
  EXPECT_NEAR(r.objective, 9.5, 1e-13);
  EXPECT_NEAR(r.y(0), 2.5, 1e-13);
  EXPECT_NEAR(r.y(1), 1.5, 1e-13);
  EXPECT_EQ(r.y(2), 0.0);
}

TEST(SmallLp, Infeasible) {
  {  // y0 + y1 = -1 with y >= 0
    Eigen::MatrixXd a(1, 2);
    a << 1, 1;
    EXPECT_EQ(SolveStandardFormLp(a, Eigen::VectorXd::Constant(1, -1.0), Eigen::Vector2d(1, 1))
                  .status,
              Status::kInfeasible);
  }
  {  // y0 + y1 = 1 and y0 + y1 = 2
    Eigen::MatrixXd a(2, 2);
    a << 1, 1,  //
        1, 1;
    EXPECT_EQ(SolveStandardFormLp(a, Eigen::Vector2d(1, 2), Eigen::Vector2d(0, 0)).status,
              Status::kInfeasible);
  }
  {  // a point outside the convex hull of three points, as a rest-pose LP
    Eigen::MatrixXd a(3, 3);
    a << 0, 1, 0,  //
        0, 0, 1,   //
        1, 1, 1;
    EXPECT_EQ(SolveStandardFormLp(a, Eigen::Vector3d(0.6, 0.6, 1), Eigen::Vector3d(0, 0, 0))
                  .status,
              Status::kInfeasible);
  }
  {  // zero row with a nonzero right-hand side
    Eigen::MatrixXd a = Eigen::MatrixXd::Zero(2, 3);
    a.row(0) << 1, 2, 3;
    EXPECT_EQ(
        SolveStandardFormLp(a, Eigen::Vector2d(1, 1e-3), Eigen::Vector3d(1, 1, 1)).status,
        Status::kInfeasible);
  }
}

TEST(SmallLp, Unbounded) {
  {  // min -y0 s.t. y0 - y1 = 1
    Eigen::MatrixXd a(1, 2);
    a << 1, -1;
    EXPECT_EQ(
        SolveStandardFormLp(a, Eigen::VectorXd::Constant(1, 1.0), Eigen::Vector2d(-1, 0)).status,
        Status::kUnbounded);
  }
  {  // a zero column with a negative cost
    Eigen::MatrixXd a(2, 3);
    a << 1, 0, 0,  //
        0, 1, 0;
    EXPECT_EQ(SolveStandardFormLp(a, Eigen::Vector2d(1, 1), Eigen::Vector3d(0, 0, -1)).status,
              Status::kUnbounded);
  }
  {  // bounded by the cost even though the feasible set is not
    Eigen::MatrixXd a(1, 2);
    a << 1, -1;
    const auto r =
        SolveStandardFormLp(a, Eigen::VectorXd::Constant(1, 1.0), Eigen::Vector2d(1, 0));
    ExpectOptimalCertificate(a, Eigen::VectorXd::Constant(1, 1.0), Eigen::Vector2d(1, 0), r);
    EXPECT_NEAR(r.objective, 1.0, 1e-15);
  }
}

TEST(SmallLp, SizeMismatchThrows) {
  EXPECT_THROW(SolveStandardFormLp(Eigen::MatrixXd::Ones(2, 3), Eigen::VectorXd::Ones(3),
                                   Eigen::VectorXd::Ones(3)),
               std::invalid_argument);
  EXPECT_THROW(SolveStandardFormLp(Eigen::MatrixXd::Ones(2, 3), Eigen::VectorXd::Ones(2),
                                   Eigen::VectorXd::Ones(2)),
               std::invalid_argument);
}

TEST(SmallLp, BealeCyclingExample) {
  // Beale (1955): Dantzig's rule with the lowest-index tie break cycles on this
  // degenerate problem. Optimum -5/4 at y3 = 1, y5 = 1, y0 = 3/4.
  Eigen::MatrixXd a(3, 7);
  a << 1, 0, 0, 0.25, -8, -1, 9,  //
      0, 1, 0, 0.5, -12, -0.5, 3,  //
      0, 0, 1, 0, 0, 1, 0;
  const Eigen::Vector3d b(0, 0, 1);
  Eigen::VectorXd c(7);
  c << 0, 0, 0, -0.75, 20, -0.5, 6;
  const auto r = SolveStandardFormLp(a, b, c);
  ExpectOptimalCertificate(a, b, c, r);
  EXPECT_NEAR(r.objective, -1.25, 1e-14);
}

TEST(SmallLp, RedundantRows) {
  // Row 2 = row 0 + row 1 (consistent); row 3 is all zero with b = 0.
  Eigen::MatrixXd a(4, 4);
  a << 1, 1, 0, 2,  //
      0, 1, 1, 1,   //
      1, 2, 1, 3,   //
      0, 0, 0, 0;
  const Eigen::Vector4d b(2, 3, 5, 0);
  const Eigen::Vector4d c(1, 4, 1, 3);
  const auto r = SolveStandardFormLp(a, b, c);
  ExpectOptimalCertificate(a, b, c, r);
  EXPECT_EQ(r.basis.size(), 2u);
  // Candidates: {0,2}: y0=2,y2=3 -> 5; {0,1}: y1=3, y0=-1 infeasible; {2,3}: y3=1, y2=2 -> 5;
  // {0,3}: y3 = 3, y0 = -4 infeasible; {1,2}: y1 = 2, y2 = 1 -> 9; {1,3}... min 5.
  EXPECT_NEAR(r.objective, 5.0, 1e-14);
}

TEST(SmallLp, DegenerateCoplanarRestPoseLp) {
  // All points on one plane z = 0.3 x - 0.2 y + 7 on a grid: every column ties. The
  // weighted height at (cx, cy) must be the plane's height there.
  const int k = 41;
  Eigen::MatrixXd a(3, k * k);
  Eigen::VectorXd c(k * k);
  for (int i = 0; i < k; ++i) {
    for (int j = 0; j < k; ++j) {
      const double x = -20.0 + i, y = -20.0 + j;
      a.col(i * k + j) << x, y, 1.0;
      c(i * k + j) = 0.3 * x - 0.2 * y + 7.0;
    }
  }
  for (const Eigen::Vector3d& b : {Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(3, -5, 1),
                                  Eigen::Vector3d(20, 20, 1), Eigen::Vector3d(-20, 3, 1)}) {
    const auto r = SolveStandardFormLp(a, b, c);
    ExpectOptimalCertificate(a, b, c, r, 1e-12);
    EXPECT_EQ(r.basis.size(), 3u);
    EXPECT_NEAR(r.objective, 0.3 * b(0) - 0.2 * b(1) + 7.0, 1e-12);
  }
  // Collinear in (x, y): rank 2, still solved.
  Eigen::MatrixXd line(3, k);
  Eigen::VectorXd cl(k);
  for (int i = 0; i < k; ++i) {
    line.col(i) << i, 2.0 * i, 1.0;
    cl(i) = std::abs(i - 10.0);
  }
  const Eigen::Vector3d bl(12, 24, 1);
  const auto r = SolveStandardFormLp(line, bl, cl);
  ExpectOptimalCertificate(line, bl, cl, r, 1e-12);
  EXPECT_EQ(r.basis.size(), 2u);
  EXPECT_NEAR(r.objective, 2.0, 1e-12);
}

TEST(SmallLp, ScaleInvariant) {
  // The same problem with rows and costs rescaled by large and small factors.
  Eigen::MatrixXd a(2, 4);
  a << 1, 2, 1, 0,  //
      3, 1, 0, 1;
  const Eigen::Vector2d b(4, 6);
  const Eigen::Vector4d c(-1, -1, 0, 0);
  for (const double s : {1e-8, 1e-3, 1e4, 1e9}) {
    Eigen::MatrixXd as = a;
    as.row(0) *= s;
    as.row(1) /= s;
    const Eigen::Vector2d bs(b(0) * s, b(1) / s);
    const auto r = SolveStandardFormLp(as, bs, c * s);
    ASSERT_EQ(r.status, Status::kOptimal);
    EXPECT_NEAR(r.objective / s, -14.0 / 5.0, 1e-12);
    EXPECT_NEAR(r.y(0), 8.0 / 5.0, 1e-12);
  }
}

// Minimum of c^T y over all basic feasible solutions (the LP optimum when it is
// bounded), by enumerating every m-subset of the columns.
double BruteForceOverBases(const Eigen::MatrixXd& a, const Eigen::VectorXd& b,
                           const Eigen::VectorXd& c) {
  const int m = static_cast<int>(a.rows()), n = static_cast<int>(a.cols());
  double best = std::numeric_limits<double>::infinity();
  std::vector<int> idx(m);
  for (int i = 0; i < m; ++i) idx[i] = i;
  for (;;) {
    Eigen::MatrixXd bm(m, m);
    Eigen::VectorXd cb(m);
    for (int i = 0; i < m; ++i) {
      bm.col(i) = a.col(idx[i]);
      cb(i) = c(idx[i]);
    }
    Eigen::FullPivLU<Eigen::MatrixXd> lu(bm);
    if (lu.isInvertible()) {
      const Eigen::VectorXd x = lu.solve(b);
      if (x.minCoeff() >= -1e-12) best = std::min(best, cb.dot(x));
    }
    int i = m - 1;
    while (i >= 0 && idx[i] == n - m + i) --i;
    if (i < 0) break;
    ++idx[i];
    for (int k = i + 1; k < m; ++k) idx[k] = idx[k - 1] + 1;
  }
  return best;
}

TEST(SmallLp, RandomAgainstBruteForceOverBases) {
  Random rng(20240611);
  for (int trial = 0; trial < 300; ++trial) {
    const int m = 1 + trial % 6;
    const int n = m + 1 + static_cast<int>(rng.NextU64() % 9);
    Eigen::MatrixXd a(m, n);
    for (int i = 0; i < m; ++i)
      for (int j = 0; j < n; ++j) a(i, j) = rng.Normal();
    // Small integer entries in a third of the trials make ties and degeneracy common.
    if (trial % 3 == 0) a = a.array().round();
    Eigen::VectorXd y0(n);
    for (int j = 0; j < n; ++j) y0(j) = (rng.Uniform() < 0.4) ? 0.0 : rng.Uniform();
    const Eigen::VectorXd b = a * y0;
    // c = A^T pi0 + s with s >= 0 keeps the dual feasible, so the LP is bounded.
    Eigen::VectorXd pi0(m);
    for (int i = 0; i < m; ++i) pi0(i) = rng.Normal();
    Eigen::VectorXd s(n);
    for (int j = 0; j < n; ++j) s(j) = (rng.Uniform() < 0.3) ? 0.0 : rng.Uniform();
    Eigen::VectorXd c = a.transpose() * pi0 + s;
    if (trial % 3 == 0) c = c.array().round();  // may lose boundedness: checked below
    const auto r = SolveStandardFormLp(a, b, c);
    if (r.status == Status::kUnbounded) {
      EXPECT_EQ(trial % 3, 0) << "trial " << trial;
      continue;
    }
    ASSERT_EQ(r.status, Status::kOptimal) << "trial " << trial;
    ExpectOptimalCertificate(a, b, c, r);
    Eigen::FullPivLU<Eigen::MatrixXd> lu(a);
    if (lu.rank() == m) {
      EXPECT_NEAR(r.objective, BruteForceOverBases(a, b, c), 1e-9) << "trial " << trial;
    }
  }
}

TEST(SmallLp, ManyColumnsConvexCombination) {
  // Lower convex hull of the paraboloid z = x^2 + y^2 sampled on 20000 points: the
  // optimum weighted height at (cx, cy) is that of the facet below it, between the
  // paraboloid's value there and a grid spacing's worth above.
  Random rng(7);
  const int n = 20000;
  Eigen::MatrixXd a(3, n);
  Eigen::VectorXd c(n);
  for (int j = 0; j < n; ++j) {
    const double x = rng.Uniform(-50, 50), y = rng.Uniform(-50, 50);
    a.col(j) << x, y, 1.0;
    c(j) = 1e-3 * (x * x + y * y);
  }
  const Eigen::Vector3d b(3.0, -4.0, 1.0);
  const auto r = SolveStandardFormLp(a, b, c);
  ExpectOptimalCertificate(a, b, c, r, 1e-10);
  EXPECT_EQ(r.basis.size(), 3u);
  EXPECT_GE(r.objective, 1e-3 * 25.0 - 1e-12);
  EXPECT_LE(r.objective, 1e-3 * 25.0 + 0.01);
}

}  // namespace
}  // namespace flatscan
