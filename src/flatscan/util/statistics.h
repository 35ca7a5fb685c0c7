#pragma once
// Small statistics shared by the measurement and the studies.
#include <vector>

namespace flatscan {

// The median; for an even count the mean of the middle two. 0 for no values.
double Median(std::vector<double> values);

// The jackknife variance of an estimate from its leave-one-out (or leave-one-block-out)
// replicates theta_i, i = 1..n: (n - 1) / n sum (theta_i - mean theta)^2 (Efron and
// Tibshirani, An Introduction to the Bootstrap, ch. 11). 0 for fewer than 2 replicates.
double JackknifeVariance(const std::vector<double>& replicates);

}  // namespace flatscan
