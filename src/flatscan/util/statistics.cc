#include "flatscan/util/statistics.h"

#include <algorithm>

namespace flatscan {

double Median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const size_t n = values.size();
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

double JackknifeVariance(const std::vector<double>& replicates) {
  const double n = static_cast<double>(replicates.size());
  if (replicates.size() < 2) return 0.0;
  double mean = 0;
  for (const double r : replicates) mean += r;
  mean /= n;
  double sum_squares = 0;
  for (const double r : replicates) sum_squares += (r - mean) * (r - mean);
  return (n - 1) / n * sum_squares;
}

}  // namespace flatscan
