#include "flatscan/geometry/small_lp.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include <Eigen/LU>

namespace flatscan {
namespace {

// A column j prices out (may enter) if its reduced cost d_j = c_j - pi^T a_j is below
// -kOptimalityTol * (|c_j| + sum_k |pi_k a_kj|): the round-off in d_j is a small
// multiple of machine epsilon times the magnitudes of the terms that were summed.
constexpr double kOptimalityTol = 1e-11;
// Absolute floor for the test above, relative to the largest cost.
constexpr double kCostFloor = 1e-14;
// A pivot w_i of the entering direction w = B^-1 a_q must exceed this times max|w|.
constexpr double kPivotTol = 1e-9;
// Harris ratio test: basic values may drift below zero by this times max|x_B|.
constexpr double kPrimalTol = 1e-12;
// Phase 1 declares the problem feasible if the artificial total is at most this times
// max(b) (rows equilibrated).
constexpr double kPhase1Tol = 1e-9;
// After this many consecutive degenerate pivots, price by Bland's rule until the
// objective strictly decreases again.
constexpr int kDegenerateRunForBland = 8;

class RevisedSimplex {
 public:
  // a: m x n with rows equilibrated, b >= 0. Starts from the all-artificial basis.
  RevisedSimplex(const Eigen::MatrixXd& a, const Eigen::VectorXd& b)
      : a_(a),
        b_(b),
        m_(static_cast<int>(a.rows())),
        n_(static_cast<int>(a.cols())),
        basis_(m_),
        in_basis_(n_ + m_, 0),
        locked_(m_, 0),
        budget_(1000 + 50L * (n_ + m_)) {
    for (int i = 0; i < m_; ++i) {
      basis_[i] = n_ + i;
      in_basis_[n_ + i] = 1;
    }
  }

  bool IsArtificial(int j) const { return j >= n_; }

  // Runs simplex iterations with `cost` (size n + m; artificial columns never enter).
  // Returns false if the objective is unbounded below.
  bool Optimize(const Eigen::VectorXd& cost) {
    const double floor = kCostFloor * cost.cwiseAbs().maxCoeff();
    int degenerate_run = 0;
    Eigen::VectorXd cb(m_);
    for (;;) {
      if (--budget_ < 0) {
        throw std::runtime_error("SolveStandardFormLp: iteration limit reached (m=" +
                                 std::to_string(m_) + ", n=" + std::to_string(n_) + ")");
      }
      Factorize();
      for (int i = 0; i < m_; ++i) cb(i) = cost(basis_[i]);
      pi_.noalias() = binv_.transpose() * cb;

      // Pricing.
      const bool bland = degenerate_run >= kDegenerateRunForBland;
      int q = -1;
      double best = 0.0;
      for (int j = 0; j < n_; ++j) {
        if (in_basis_[j]) continue;
        const double* col = a_.col(j).data();
        double dot = 0.0;
        double magnitude = std::abs(cost(j));
        for (int k = 0; k < m_; ++k) {
          const double t = pi_(k) * col[k];
          dot += t;
          magnitude += std::abs(t);
        }
        const double d = cost(j) - dot;
        if (d >= -(kOptimalityTol * magnitude + floor)) continue;
        if (bland) {
          q = j;
          break;
        }
        if (d < best) {
          best = d;
          q = j;
        }
      }
      if (q < 0) return true;

      // Entering direction and ratio test (Harris' two passes).
      const Eigen::VectorXd w = binv_ * a_.col(q);
      double wmax = 0.0;
      for (int i = 0; i < m_; ++i)
        if (!locked_[i]) wmax = std::max(wmax, std::abs(w(i)));
      const double noise = 1e-13 * binv_.cwiseAbs().rowwise().sum().maxCoeff() *
                           a_.col(q).cwiseAbs().maxCoeff();
      if (wmax <= noise) return false;  // a_q is (numerically) zero in the basis: a ray
      const double pivot_tol = kPivotTol * wmax;
      const double delta = kPrimalTol * x_.cwiseAbs().maxCoeff();
      double theta_max = std::numeric_limits<double>::infinity();
      for (int i = 0; i < m_; ++i) {
        if (locked_[i] || w(i) <= pivot_tol) continue;
        theta_max = std::min(theta_max, (std::max(x_(i), 0.0) + delta) / w(i));
      }
      if (!std::isfinite(theta_max)) return false;  // no blocking variable: unbounded
      int r = -1;
      for (int i = 0; i < m_; ++i) {
        if (locked_[i] || w(i) <= pivot_tol) continue;
        if (std::max(x_(i), 0.0) / w(i) > theta_max) continue;
        if (r < 0 || (bland ? basis_[i] < basis_[r] : w(i) > w(r))) r = i;
      }
      const double theta = std::max(x_(r), 0.0) / w(r);
      if (theta * wmax <= delta) {
        ++degenerate_run;
      } else {
        degenerate_run = 0;
      }
      in_basis_[basis_[r]] = 0;
      basis_[r] = q;
      in_basis_[q] = 1;
    }
  }

  // After phase 1: pivots artificial variables (at zero level) out of the basis where
  // possible; those that cannot leave belong to redundant rows and are locked in.
  void DriveOutArtificials() {
    for (int r = 0; r < m_; ++r) {
      if (!IsArtificial(basis_[r])) continue;
      Factorize();
      const Eigen::RowVectorXd row = binv_.row(r) * a_;  // row r of B^-1 A
      const double tol = kPivotTol * binv_.row(r).cwiseAbs().sum();
      int best = -1;
      double best_score = 0.0;
      for (int j = 0; j < n_; ++j) {
        if (in_basis_[j] || std::abs(row(j)) <= tol) continue;
        // Prefer positive pivots (they keep the entering value >= 0), then magnitude.
        const double score = std::abs(row(j)) * (row(j) > 0.0 ? 2.0 : 1.0);
        if (score > best_score) {
          best_score = score;
          best = j;
        }
      }
      if (best < 0) {
        locked_[r] = 1;
        continue;
      }
      in_basis_[basis_[r]] = 0;
      basis_[r] = best;
      in_basis_[best] = 1;
    }
    Factorize();
  }

  double ArtificialTotal() const {
    double total = 0.0;
    for (int i = 0; i < m_; ++i)
      if (IsArtificial(basis_[i])) total += std::max(x_(i), 0.0);
    return total;
  }

  const std::vector<int>& basis() const { return basis_; }
  const Eigen::VectorXd& x() const { return x_; }
  const Eigen::VectorXd& pi() const { return pi_; }

 private:
  void Factorize() {
    Eigen::MatrixXd bmat = Eigen::MatrixXd::Zero(m_, m_);
    for (int i = 0; i < m_; ++i) {
      if (IsArtificial(basis_[i])) {
        bmat(basis_[i] - n_, i) = 1.0;
      } else {
        bmat.col(i) = a_.col(basis_[i]);
      }
    }
    Eigen::FullPivLU<Eigen::MatrixXd> lu(bmat);
    if (!lu.isInvertible()) {
      throw std::runtime_error("SolveStandardFormLp: basis matrix became singular");
    }
    binv_ = lu.inverse();
    x_.noalias() = binv_ * b_;
  }

  const Eigen::MatrixXd& a_;
  const Eigen::VectorXd& b_;
  const int m_;
  const int n_;
  std::vector<int> basis_;      // column per basis position; j >= n is artificial e_{j-n}
  std::vector<char> in_basis_;  // per column (n + m)
  std::vector<char> locked_;    // per basis position: redundant row's artificial
  long budget_;
  Eigen::MatrixXd binv_;
  Eigen::VectorXd x_;   // basic values B^-1 b
  Eigen::VectorXd pi_;  // simplex multipliers B^-T c_B
};

}  // namespace

StandardFormLpResult SolveStandardFormLp(const Eigen::MatrixXd& A, const Eigen::VectorXd& b,
                                         const Eigen::VectorXd& c) {
  const int m = static_cast<int>(A.rows());
  const int n = static_cast<int>(A.cols());
  if (b.size() != m || c.size() != n) {
    throw std::invalid_argument("SolveStandardFormLp: A is " + std::to_string(m) + " x " +
                                std::to_string(n) + " but b has " + std::to_string(b.size()) +
                                " and c has " + std::to_string(c.size()) + " entries");
  }
  if (!A.allFinite() || !b.allFinite() || !c.allFinite()) {
    throw std::invalid_argument("SolveStandardFormLp: non-finite entries in A, b or c");
  }

  // Equilibrate the rows (largest |entry| 1) and flip them so that b >= 0. Row k of the
  // working problem is row_scale(k) times row k of the given one, so the given
  // problem's dual is pi = row_scale .* pi_working.
  Eigen::VectorXd row_scale(m);
  for (int k = 0; k < m; ++k) {
    const double row_max = n > 0 ? A.row(k).cwiseAbs().maxCoeff() : 0.0;
    row_scale(k) = row_max > 0.0 ? 1.0 / row_max : 1.0;
    if (b(k) < 0.0) row_scale(k) = -row_scale(k);
  }
  const Eigen::MatrixXd a = row_scale.asDiagonal() * A;
  const Eigen::VectorXd bw = row_scale.cwiseProduct(b);

  StandardFormLpResult result;
  result.y = Eigen::VectorXd::Zero(n);
  result.dual = Eigen::VectorXd::Zero(m);
  if (m == 0) {  // no constraints: y = 0 is optimal unless some cost is negative
    result.status = (n > 0 && c.minCoeff() < 0.0) ? StandardFormLpResult::Status::kUnbounded
                                                   : StandardFormLpResult::Status::kOptimal;
    return result;
  }

  RevisedSimplex simplex(a, bw);
  Eigen::VectorXd cost = Eigen::VectorXd::Zero(n + m);
  cost.tail(m).setOnes();
  simplex.Optimize(cost);  // phase 1 is bounded below by 0
  if (simplex.ArtificialTotal() > kPhase1Tol * bw.maxCoeff()) {
    result.status = StandardFormLpResult::Status::kInfeasible;
    return result;
  }
  simplex.DriveOutArtificials();

  cost.head(n) = c;
  cost.tail(m).setZero();
  if (!simplex.Optimize(cost)) {
    result.status = StandardFormLpResult::Status::kUnbounded;
    return result;
  }

  result.status = StandardFormLpResult::Status::kOptimal;
  for (int i = 0; i < m; ++i) {
    const int j = simplex.basis()[i];
    if (j >= n) continue;  // locked artificial of a redundant row (value 0)
    result.y(j) = std::max(simplex.x()(i), 0.0);
    result.basis.push_back(j);
  }
  std::sort(result.basis.begin(), result.basis.end());
  result.objective = c.dot(result.y);
  result.dual = row_scale.cwiseProduct(simplex.pi());
  return result;
}

}  // namespace flatscan
