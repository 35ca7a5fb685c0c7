#include "flatscan/evaluation/uncertainty_validation.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "flatscan/util/error.h"
#include "flatscan/util/statistics.h"

namespace flatscan {
namespace {

UncertaintyRow Summarize(const std::string& label, const std::vector<const PartMeasurement*>& parts) {
  UncertaintyRow row;
  row.label = label;
  std::vector<double> uncertainty, error, calibration;
  int covered = 0;
  for (const PartMeasurement* p : parts) {
    if (!p->measured) continue;
    ++row.parts;
    uncertainty.push_back(p->uncertainty.expanded_mm);
    calibration.push_back(std::hypot(p->uncertainty.rig_mm, p->uncertainty.plane_mm));
    row.mean_error_mm += p->ErrorMm();
    error.push_back(std::abs(p->ErrorMm()));
    covered += error.back() <= uncertainty.back();
    row.maximum_unmeasured += p->uncertainty.maximum_unmeasured;
  }
  row.covered_fraction = row.parts > 0 ? static_cast<double>(covered) / row.parts : 0.0;
  if (row.parts > 0) row.mean_error_mm /= row.parts;
  row.median_calibration_mm = Median(std::move(calibration));
  row.median_uncertainty_mm = Median(std::move(uncertainty));
  row.median_abs_error_mm = Median(std::move(error));
  return row;
}

nlohmann::json RowJson(const UncertaintyRow& r) {
  return {{"label", r.label},
          {"parts", r.parts},
          {"covered_fraction", r.covered_fraction},
          {"median_uncertainty_mm", r.median_uncertainty_mm},
          {"median_abs_error_mm", r.median_abs_error_mm},
          {"ratio", r.Ratio()},
          {"maximum_unmeasured", r.maximum_unmeasured},
          {"mean_error_mm", r.mean_error_mm},
          {"median_calibration_mm", r.median_calibration_mm}};
}

std::string RowMarkdown(const UncertaintyRow& r) {
  return fmt::format("| {} | {} | {:.1f}% | {:.2f} | {:.2f} | {:.2f} | {} | {:+.2f} | {:.2f} |\n", r.label, r.parts,
                     100 * r.covered_fraction, 1000 * r.median_uncertainty_mm, 1000 * r.median_abs_error_mm, r.Ratio(),
                     r.maximum_unmeasured, 1000 * r.mean_error_mm, 1000 * r.median_calibration_mm);
}

}  // namespace

UncertaintyValidation ValidateUncertainty(const std::vector<std::vector<PartMeasurement>>& stations,
                                          const std::vector<uint64_t>& seeds) {
  FLATSCAN_CHECK(stations.size() == seeds.size());
  UncertaintyValidation out;
  std::vector<const PartMeasurement*> all;
  for (size_t k = 0; k < stations.size(); ++k) {
    std::vector<const PartMeasurement*> station;
    for (const PartMeasurement& p : stations[k]) station.push_back(&p);
    out.by_station.push_back(Summarize(fmt::format("station seed {}", seeds[k]), station));
    all.insert(all.end(), station.begin(), station.end());
  }
  out.all = Summarize("all", all);
  double lower = 0;
  for (const double upper : kRotationBandsDeg) {
    std::vector<const PartMeasurement*> band;
    for (const PartMeasurement* p : all) {
      const double angle = AngleToBaselineDeg(p->rotation_deg);
      if (angle >= lower && (angle < upper || upper == kRotationBandsDeg[std::size(kRotationBandsDeg) - 1]))
        band.push_back(p);
    }
    out.by_rotation.push_back(Summarize(fmt::format("turned {:g}-{:g} deg", lower, upper), band));
    lower = upper;
  }
  return out;
}

std::string UncertaintyMarkdown(const UncertaintyValidation& v) {
  std::string md = "### Each part's uncertainty against its true error\n\n";
  md += "A part is covered when |measured - true| <= its uncertainty_mm (U, k = 2). Honest: about 95% covered, and "
        "median U / median |error| about 3 (Gaussian errors: 2 / 0.674). Per station, the mean error is mostly what "
        "its calibration shifts every part by; u_cal = sqrt(u_rig^2 + u_plane^2) is the calibration's standard "
        "uncertainty (median over the parts).\n\n";
  md += "| parts | measured | covered | median U (um) | median abs error (um) | ratio | maximum maybe unmeasured | "
        "mean error (um) | median u_cal (um) |\n";
  md += "|---|---|---|---|---|---|---|---|---|\n";
  md += RowMarkdown(v.all);
  for (const UncertaintyRow& r : v.by_rotation) md += RowMarkdown(r);
  if (v.by_station.size() > 1)
    for (const UncertaintyRow& r : v.by_station) md += RowMarkdown(r);
  return md;
}

nlohmann::json UncertaintyJson(const UncertaintyValidation& v) {
  nlohmann::json rotation = nlohmann::json::array(), station = nlohmann::json::array();
  for (const UncertaintyRow& r : v.by_rotation) rotation.push_back(RowJson(r));
  for (const UncertaintyRow& r : v.by_station) station.push_back(RowJson(r));
  return {{"all", RowJson(v.all)}, {"by_rotation", rotation}, {"by_station", station}};
}

}  // namespace flatscan
