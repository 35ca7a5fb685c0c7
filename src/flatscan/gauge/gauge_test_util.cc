#include "flatscan/gauge/gauge_test_util.h"

#include <fstream>
#include <string>

#include <fmt/format.h>

namespace flatscan::testing {

std::vector<GaugeObservation> AiagGaugeRRExample() {
  // [appraiser][trial][part]
  const double sheet[3][3][10] = {
      {{0.29, -0.56, 1.34, 0.47, -0.80, 0.02, 0.59, -0.31, 2.26, -1.36},
       {0.41, -0.68, 1.17, 0.50, -0.92, -0.11, 0.75, -0.20, 1.99, -1.25},
       {0.64, -0.58, 1.27, 0.64, -0.84, -0.21, 0.66, -0.17, 2.01, -1.31}},
      {{0.08, -0.47, 1.19, 0.01, -0.56, -0.20, 0.47, -0.63, 1.80, -1.68},
       {0.25, -1.22, 0.94, 1.03, -1.20, 0.22, 0.55, 0.08, 2.12, -1.62},
       {0.07, -0.68, 1.34, 0.20, -1.28, 0.06, 0.83, -0.34, 2.19, -1.50}},
      {{0.04, -1.38, 0.88, 0.14, -1.46, -0.29, 0.02, -0.46, 1.77, -1.49},
       {-0.11, -1.13, 1.09, 0.20, -1.07, -0.67, 0.01, -0.56, 1.45, -1.77},
       {-0.15, -0.96, 0.67, 0.11, -1.45, -0.49, 0.21, -0.49, 1.87, -2.16}}};
  std::vector<GaugeObservation> out;
  for (int a = 0; a < 3; ++a)
    for (int t = 0; t < 3; ++t)
      for (int p = 0; p < 10; ++p)
        out.push_back({std::to_string(p + 1), std::string(1, char('A' + a)), std::to_string(t + 1), sheet[a][t][p], 0});
  return out;
}

std::vector<LinearityObservation> AiagLinearityExample() {
  const double readings[5][12] = {
      {2.70, 2.50, 2.40, 2.50, 2.70, 2.30, 2.50, 2.50, 2.40, 2.40, 2.60, 2.40},
      {5.10, 3.90, 4.20, 5.00, 3.80, 3.90, 3.90, 3.90, 3.90, 4.00, 4.10, 3.80},
      {5.80, 5.70, 5.90, 5.90, 6.00, 6.10, 6.00, 6.10, 6.40, 6.30, 6.00, 6.10},
      {7.60, 7.70, 7.80, 7.70, 7.80, 7.80, 7.80, 7.70, 7.80, 7.50, 7.60, 7.70},
      {9.10, 9.30, 9.50, 9.30, 9.40, 9.50, 9.50, 9.50, 9.60, 9.20, 9.30, 9.40}};
  std::vector<LinearityObservation> out;
  for (int p = 0; p < 5; ++p)
    for (double v : readings[p]) out.push_back({std::to_string(p + 1), 2.0 * (p + 1), v, 0});
  return out;
}

void WriteGaugeRRCsv(const std::filesystem::path& path, const std::vector<GaugeObservation>& data) {
  std::ofstream out(path);
  out << "part,appraiser,trial,value\n";
  for (const GaugeObservation& o : data) out << fmt::format("{},{},{},{}\n", o.part, o.appraiser, o.trial, o.value);
}

}  // namespace flatscan::testing
