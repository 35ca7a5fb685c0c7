#include "flatscan/gauge/t_distribution.h"

#include <cmath>

#include <boost/math/distributions/students_t.hpp>

namespace flatscan {

double TwoSidedTP(double t, int df) {
  if (!std::isfinite(t)) return 0.0;
  return 2 * boost::math::cdf(boost::math::complement(boost::math::students_t(df), std::abs(t)));
}

double TQuantile975(int df) {
  return boost::math::quantile(boost::math::complement(boost::math::students_t(df), 0.025));
}

}  // namespace flatscan
