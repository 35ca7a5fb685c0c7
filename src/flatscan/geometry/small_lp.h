#pragma once
// Exact linear programs with few equality rows and many columns, solved by the
// revised simplex method (two phases, Bland's rule against cycling):
//
//   minimize c^T y   subject to   A y = b,  y >= 0,     A: m x n, m small (<= 6).
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
  std::vector<int> basis;  // indices of the m basic columns at the optimum
  double objective = 0.0;  // c^T y
};

StandardFormLpResult SolveStandardFormLp(const Eigen::MatrixXd& A, const Eigen::VectorXd& b,
                                         const Eigen::VectorXd& c);

}  // namespace flatscan
