#pragma once
// Student's t distribution for the studies' tests and intervals (Boost.Math).
namespace flatscan {

// P(|T| >= |t|) for T ~ t(df): the two-sided p-value of a t statistic (0 for an infinite t).
double TwoSidedTP(double t, int df);

// The 97.5% quantile of t(df): the half width of a 95% interval is this times the standard error.
double TQuantile975(int df);

}  // namespace flatscan
