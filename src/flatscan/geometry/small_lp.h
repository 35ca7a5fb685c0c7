#pragma once
// Exact linear programs with few equality rows and many columns, solved by the
// revised simplex method (two phases, Bland's rule against cycling):
//
//   minimize c^T y   subject to   A y = b,  y >= 0,     A: m x n, m small (<= 6).
//
// Its dual is   maximize b^T pi   subject to   A^T pi <= c   (pi free, size m);
// at an optimum both objectives are equal (strong duality), and pi = B^-T c_B for the
// optimal basis matrix B (the columns of A in `basis`): the constraints of the dual
// that are active (tight) are exactly those of the basic columns.
//
// Rows are equilibrated and flipped so that b >= 0 internally; phase 1 minimizes the
// sum of one artificial variable per row, phase 2 the true cost. Pricing is Dantzig's
// (most negative reduced cost) and falls back to Bland's rule (smallest index) after a
// run of degenerate pivots, which rules out cycling. Tolerances are relative to the
// magnitudes of the terms being compared (scale-free). If A is rank deficient
// (consistent redundant rows), the basis has rank(A) < m columns and the dual is 0 on
// the rows found redundant.
//
// Used through LP duality for the part's rest pose (which three points of the lower
// convex hull carry the part) and for minimum-zone flatness (ISO 1101).
#include <vector>

#include <Eigen/Core>

namespace flatscan {

struct StandardFormLpResult {
  enum class Status { kOptimal, kInfeasible, kUnbounded };
  Status status = Status::kInfeasible;
  Eigen::VectorXd y;       // optimal primal solution (size n)
  std::vector<int> basis;  // indices of the m basic columns at the optimum (ascending;
                           // rank(A) of them if A is rank deficient)
  double objective = 0.0;  // c^T y
  Eigen::VectorXd dual;    // optimal dual pi (size m): A^T pi <= c, b^T pi = objective
};

// Throws std::invalid_argument if the sizes of A, b and c disagree, and
// std::runtime_error if the iteration limit is hit (numerical breakdown; not expected).
StandardFormLpResult SolveStandardFormLp(const Eigen::MatrixXd& A, const Eigen::VectorXd& b,
                                         const Eigen::VectorXd& c);

}  // namespace flatscan
