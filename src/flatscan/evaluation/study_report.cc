#include "flatscan/evaluation/study_report.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "flatscan/evaluation/plot.h"

namespace flatscan {
namespace {

const cv::Scalar kBlue(180, 100, 30), kGreen(60, 160, 60), kRed(40, 40, 220), kGrey(120, 120, 120), kOrange(30, 140, 240);

std::string Percent(double fraction) { return fmt::format("{:.2f}%", 100 * fraction); }
std::string OrNa(double v, const std::string& text) { return v < 0 ? "N/A" : text; }

nlohmann::json MeasurementJson(const PartMeasurement& m) {
  nlohmann::json j = {{"id", m.id},
                      {"true_flatness_mm", m.true_flatness_mm},
                      {"true_lsq_pv_mm", m.true_lsq_pv_mm},
                      {"true_minzone_mm", m.true_minzone_mm},
                      {"thickness_mm", m.thickness_mm},
                      {"rotation_deg", m.rotation_deg},
                      {"measured", m.measured}};
  if (!m.measured) {
    j["error"] = m.error;
    return j;
  }
  j["flatness_mm"] = m.values.flatness_mm;
  j["lsq_pv_mm"] = m.values.lsq_pv_mm;
  j["minzone_mm"] = m.values.minzone_mm;
  j["error_mm"] = m.ErrorMm();
  j["verdict"] = m.pass ? "pass" : "fail";
  j["coverage"] = m.coverage;
  j["uncertainty_mm"] = m.uncertainty.expanded_mm;
  j["uncertainty"] = {{"rim_mm", m.uncertainty.rim_mm},
                      {"rig_mm", m.uncertainty.rig_mm},
                      {"plane_mm", m.uncertainty.plane_mm},
                      {"method_mm", m.uncertainty.method_mm},
                      {"maximum_unmeasured", m.uncertainty.maximum_unmeasured}};
  j["valid_points"] = m.valid_points;
  j["inspect_ms"] = m.inspect_ms;
  return j;
}

nlohmann::json ErrorJson(const ErrorSummary& e) {
  return {{"count", e.count},          {"mean_mm", e.mean_mm},       {"sd_mm", e.sd_mm},
          {"median_abs_mm", e.median_abs_mm}, {"p95_abs_mm", e.p95_abs_mm}, {"max_abs_mm", e.max_abs_mm}};
}

std::string ErrorLine(const ErrorSummary& e) {
  return fmt::format("error (measured - true) over {} parts: mean {:+.2f} um, SD {:.2f} um; |error| median {:.2f} um, "
                     "95th percentile {:.2f} um, max {:.2f} um\n",
                     e.count, 1000 * e.mean_mm, 1000 * e.sd_mm, 1000 * e.median_abs_mm, 1000 * e.p95_abs_mm,
                     1000 * e.max_abs_mm);
}

std::string StructuredLightRows(const StructuredLightStudy& sl) {
  std::string md;
  for (const StructuredLightRow& r : sl.rows)
    md += fmt::format("| structured light, {} phase (simulated) | {:.4f} | {:.1e} | {} | {:.1f} |\n",
                      PhaseMethodName(r.method), r.mean_mm, r.variance_mm2, Percent(r.relative_error),
                      r.median_decode_ms);
  return md;
}

nlohmann::json StructuredLightJson(const StructuredLightStudy& sl) {
  nlohmann::json rows = nlohmann::json::array();
  for (const StructuredLightRow& r : sl.rows) {
    nlohmann::json shots = nlohmann::json::array();
    for (const StructuredLightMeasurement& m : r.shots) {
      nlohmann::json j = {{"measured", m.measured}, {"cells", m.cells}, {"decode_ms", m.decode_ms}};
      if (m.measured)
        j.update({{"flatness_mm", m.values.flatness_mm}, {"lsq_pv_mm", m.values.lsq_pv_mm}, {"minzone_mm", m.values.minzone_mm}});
      else
        j["error"] = m.error;
      shots.push_back(j);
    }
    rows.push_back({{"phase", PhaseMethodName(r.method)},
                    {"measured", r.measured},
                    {"mean_mm", r.mean_mm},
                    {"variance_mm2", r.variance_mm2},
                    {"relative_error", r.relative_error},
                    {"median_decode_ms", r.median_decode_ms},
                    {"errors", ErrorJson(r.errors)},
                    {"errors_over_what_it_sees", ErrorJson(r.errors_seen)},
                    {"shots", shots}});
  }
  const StructuredLightSpec& s = sl.spec;
  return {{"shots", sl.shots},
          {"triangulation_deg", s.triangulation_deg},
          {"projector", {s.projector_width, s.projector_height}},
          {"fringe_periods", s.fringe_periods},
          {"finish", {{"albedo", s.finish.albedo}, {"specular", s.finish.specular}, {"shininess", s.finish.shininess}}},
          {"rows", rows}};
}

}  // namespace

std::string CalibrationMarkdown(const CalibratedStation& s) {
  const RigCalibrationReport& r = s.rig_report;
  return fmt::format(
      "Station '{}' calibrated from simulated images: rig from {} chessboard pairs ({} distortion model; RMS {:.3f} px, "
      "epipolar {:.3f} px, baseline {:.3f} mm, true {:.3f} mm); support plane from {} markers (residual RMS {:.4f} "
      "mm).\n",
      s.truth.scene.name, r.views.size(), DistortionModelName(r.model), r.rms_px, r.epipolar_px, r.rig.BaselineMm(),
      s.truth.rig.BaselineMm(), s.plane_report.matched.size(), s.plane_report.tls.RmsMm());
}

nlohmann::json CalibrationJson(const CalibratedStation& s) {
  return {{"scene", s.truth.scene.name},
          {"rig", s.rig_report.ToJson()},
          {"true_baseline_mm", s.truth.rig.BaselineMm()},
          {"plane_markers", s.plane_report.matched.size()},
          {"plane_residual_rms_mm", s.plane_report.tls.RmsMm()}};
}

std::string RepeatMarkdown(const RepeatStudy& st, const RepeatStudyOptions& o, const StructuredLightStudy* sl) {
  std::string md = fmt::format("### Repeatability (paper Table 1): one part shot {} times\n\n", o.shots);
  md += "| method | mean flatness (mm) | variance (mm^2) | relative error | time per part (ms) |\n";
  md += "|---|---|---|---|---|\n";
  for (const PaperRow& p : kPaperTable1)
    md += fmt::format("| {} | {:.3f} | {} | {} | {} |\n", p.method, p.mean_mm, OrNa(p.variance_mm2, fmt::format("{:.1e}", p.variance_mm2)),
                      OrNa(p.relative_error, Percent(p.relative_error)), OrNa(p.time_ms, fmt::format("{:.0f}", p.time_ms)));
  md += fmt::format("| flatscan (simulated truth {:.4f} mm) | {:.4f} | {:.1e} | {} | {:.1f} |\n", st.true_flatness_mm,
                    st.mean_mm, st.variance_mm2, Percent(st.relative_error), st.median_inspect_ms);
  if (sl != nullptr) md += StructuredLightRows(*sl);
  md += "\n";
  md += fmt::format("{} of {} shots measured; SD {:.2f} um; ", st.measured, o.shots, 1000 * std::sqrt(st.variance_mm2));
  md += ErrorLine(st.errors);
  md += "Time per part: median CPU time of the inspection (one thread) from the decoded pair; the paper's figure is "
        "its whole processing per part.\n";
  if (sl != nullptr) {
    md += fmt::format(
        "Structured light: the same part and placements (the first {} shots), one camera straight above and a projector "
        "{:.0f} degrees off it, {} fringe periods, Gray code + 3-step phase shift (35 images), finish albedo {:.2f}, "
        "specular {:.2f}, shininess {:.0f} (docs/evaluation.md); its time is the decoding, triangulation and flatness "
        "(one thread), without the 35 exposures. It measures the whole top surface except a 12 px band at the edge, "
        "so it misses the rim's own extremes and sees what lies inside the rim.\n",
        sl->shots, sl->spec.triangulation_deg, sl->spec.fringe_periods, sl->spec.finish.albedo, sl->spec.finish.specular,
        sl->spec.finish.shininess);
    for (const StructuredLightRow& r : sl->rows) {
      md += fmt::format("- structured light, {} phase: ", PhaseMethodName(r.method)) + ErrorLine(r.errors);
      md += "  against the true flatness of the surface it measured (the top inside the edge band): " + ErrorLine(r.errors_seen);
    }
  }
  return md;
}

nlohmann::json RepeatJson(const RepeatStudy& st, const RepeatStudyOptions& o, const StructuredLightStudy* sl) {
  nlohmann::json shots = nlohmann::json::array();
  for (const PartMeasurement& m : st.shots) shots.push_back(MeasurementJson(m));
  nlohmann::json j = {{"shots_requested", o.shots},
          {"seed", o.seed},
          {"tolerance_mm", o.tolerance_mm},
          {"true_flatness_mm", st.true_flatness_mm},
          {"measured", st.measured},
          {"mean_mm", st.mean_mm},
          {"variance_mm2", st.variance_mm2},
          {"relative_error", st.relative_error},
          {"median_inspect_ms", st.median_inspect_ms},
          {"errors", ErrorJson(st.errors)},
          {"paper", {{"laser_profiler_mm", 0.323}, {"structured_light", {{"mean_mm", 0.352}, {"variance_mm2", 5.6e-3}, {"relative_error", 0.08978}, {"time_ms", 1590}}},
                     {"boundary_stereo", {{"mean_mm", 0.337}, {"variance_mm2", 3.2e-3}, {"relative_error", 0.04334}, {"time_ms", 627}}}}},
          {"shots", shots}};
  if (sl != nullptr) j["structured_light"] = StructuredLightJson(*sl);
  return j;
}

std::string BatchMarkdown(const BatchStudy& st, const BatchStudyOptions& o) {
  const Classification& c = st.classification;
  std::string md = fmt::format("### Batch classification (paper Table 2): {} parts, tolerance {:.3f} mm\n\n", o.parts, o.tolerance_mm);
  md += fmt::format(
      "Lot: log-normal flatness, median {:.4f} mm, log spread {:.2f}; {} beyond the tolerance, {} within 10 um of it.\n\n",
      LotMedianMm(o.lot, o.tolerance_mm), o.lot.log_spread, Percent(st.true_beyond_fraction), Percent(st.near_tolerance_fraction));
  md += "| method | parts | TP | FP | TN | FN | Pr | Rc | Acc |\n|---|---|---|---|---|---|---|---|---|\n";
  md += fmt::format("| boundary stereo (paper) | {} | | | | | {} | {} | {} |\n", kPaperBatchParts, Percent(kPaperPrecision),
                    Percent(kPaperRecall), Percent(kPaperAccuracy));
  md += fmt::format("| flatscan | {} | {} | {} | {} | {} | {} | {} | {} |\n\n", o.parts - c.unmeasured, c.tp, c.fp, c.tn, c.fn,
                    Percent(c.precision), Percent(c.recall), Percent(c.accuracy));
  md += "Positive: an unqualified part (true flatness > tolerance); TP: unqualified parts that failed.\n";
  if (c.unmeasured > 0) md += fmt::format("{} parts could not be measured (no verdict; not counted).\n", c.unmeasured);
  md += ErrorLine(st.errors);
  md += fmt::format("- parts with coverage >= {:.1f}: ", BatchStudy::kGoodCoverage) + ErrorLine(st.errors_good_coverage);
  md += fmt::format("- parts with coverage < {:.1f} (outline along the epipolar rows): ", BatchStudy::kGoodCoverage) +
        ErrorLine(st.errors_low_coverage);
  md += fmt::format("- parts turned at least {:.0f} degrees from the baseline and its perpendicular: ", BatchStudy::kTurnedDeg) +
        ErrorLine(st.errors_turned);
  const GuardBandSummary& g = st.guard_band;
  md += fmt::format(
      "Measurement uncertainty U (95th percentile of |error|): {:.2f} um. With a guard band of U, {} parts measured within "
      "U of the tolerance are marginal ({} of the {} wrong verdicts among them); the other {} decided parts are {} right.\n",
      1000 * st.uncertainty_mm, g.marginal, g.wrong_marginal, c.fp + c.fn, g.decided, Percent(g.decided_accuracy));
  md += fmt::format("Time per part: median inspection CPU time (one thread) {:.1f} ms.\n", st.median_inspect_ms);
  return md;
}

nlohmann::json BatchJson(const BatchStudy& st, const BatchStudyOptions& o) {
  const Classification& c = st.classification;
  const GuardBandSummary& g = st.guard_band;
  nlohmann::json parts = nlohmann::json::array();
  for (const PartMeasurement& m : st.parts) parts.push_back(MeasurementJson(m));
  return {{"parts_requested", o.parts},
          {"seed", o.seed},
          {"tolerance_mm", o.tolerance_mm},
          {"lot", {{"distribution", "log-normal"}, {"median_mm", LotMedianMm(o.lot, o.tolerance_mm)}, {"log_spread", o.lot.log_spread},
                   {"beyond_fraction_target", o.lot.beyond_fraction}, {"beyond_fraction", st.true_beyond_fraction},
                   {"within_10um_fraction", st.near_tolerance_fraction}, {"min_mm", o.lot.min_mm}, {"max_mm", o.lot.max_mm}}},
          {"confusion", {{"tp", c.tp}, {"fp", c.fp}, {"tn", c.tn}, {"fn", c.fn}, {"unmeasured", c.unmeasured}}},
          {"precision", c.precision},
          {"recall", c.recall},
          {"accuracy", c.accuracy},
          {"errors", ErrorJson(st.errors)},
          {"errors_good_coverage", ErrorJson(st.errors_good_coverage)},
          {"errors_low_coverage", ErrorJson(st.errors_low_coverage)},
          {"errors_turned", ErrorJson(st.errors_turned)},
          {"uncertainty_mm", st.uncertainty_mm},
          {"guard_band", {{"uncertainty_mm", g.uncertainty_mm}, {"marginal", g.marginal}, {"wrong_marginal", g.wrong_marginal},
                          {"decided", g.decided}, {"decided_wrong", g.decided_wrong}, {"decided_accuracy", g.decided_accuracy}}},
          {"median_inspect_ms", st.median_inspect_ms},
          {"paper", {{"parts", kPaperBatchParts}, {"precision", kPaperPrecision}, {"recall", kPaperRecall}, {"accuracy", kPaperAccuracy}}},
          {"parts", parts}};
}

cv::Mat3b RepeatShotsChart(const RepeatStudy& st) {
  PlotSpec spec;
  spec.title = fmt::format("Repeatability: {} shots of one part (true flatness {:.4f} mm)", st.shots.size(), st.true_flatness_mm);
  spec.x_label = "shot";
  spec.y_label = "measured flatness (mm)";
  PlotSeries shots;
  shots.colour = kBlue;
  shots.label = "measured";
  for (size_t i = 0; i < st.shots.size(); ++i)
    if (st.shots[i].measured) {
      shots.x.push_back(static_cast<double>(i));
      shots.y.push_back(st.shots[i].values.flatness_mm);
    }
  spec.series.push_back(shots);
  const double sd = std::sqrt(st.variance_mm2);
  spec.bands.push_back({false, st.mean_mm - 2 * sd, st.mean_mm + 2 * sd, cv::Scalar(250, 238, 225)});
  spec.references.push_back({false, st.true_flatness_mm, kGreen, "truth"});
  spec.references.push_back({false, st.mean_mm, kOrange, fmt::format("mean (band: +-2 SD = {:.2f} um)", 2000 * sd)});
  return DrawPlot(spec);
}

std::string RotationMarkdown(const RotationStudy& st, const RotationStudyOptions& o) {
  std::string md = fmt::format(
      "### Coverage against the part's rotation to the camera baseline: the same {} parts at every angle\n\n", o.parts);
  md += "| rotation (deg) | measured | coverage lowest | coverage median | abs(error) median (um) | abs(error) max (um) |\n";
  md += "|---|---|---|---|---|---|\n";
  for (const RotationRow& r : st.rows)
    md += fmt::format("| {:.1f} | {}/{} | {:.3f} | {:.3f} | {:.2f} | {:.2f} |\n", r.rotation_deg, r.measured, r.parts.size(),
                      r.coverage_min, r.coverage_median, 1000 * r.errors.median_abs_mm, 1000 * r.errors.max_abs_mm);
  md += "\nCoverage: the fraction of the outline's length with valid 3D points. Sides within a few degrees of the "
        "baseline lie in one epipolar plane: two cameras on one baseline cannot see their depth, and they are completed "
        "from the fitted warp surface (a prior, not a measurement).\n";
  return md;
}

nlohmann::json RotationJson(const RotationStudy& st, const RotationStudyOptions& o) {
  nlohmann::json rows = nlohmann::json::array();
  for (const RotationRow& r : st.rows) {
    nlohmann::json parts = nlohmann::json::array();
    for (const PartMeasurement& m : r.parts) parts.push_back(MeasurementJson(m));
    rows.push_back({{"rotation_deg", r.rotation_deg}, {"measured", r.measured}, {"coverage_min", r.coverage_min},
                    {"coverage_median", r.coverage_median}, {"errors", ErrorJson(r.errors)}, {"parts", parts}});
  }
  return {{"parts_per_angle", o.parts}, {"step_deg", o.step_deg}, {"max_deg", o.max_deg}, {"seed", o.seed}, {"rows", rows}};
}

std::string RobustnessMarkdown(const RobustnessStudy& st, const BatchStudyOptions& o) {
  std::string md = fmt::format(
      "### Robustness to the defects of real images: the same {} parts, ideal and with each effect\n\n"
      "Ideal images: {}/{} parts measured. Columns over the parts measured in both: abs(error) median / 95th "
      "percentile (um) ideal and with the effect; wrong verdicts against the truth (tolerance {} mm).\n\n",
      o.parts, st.ideal.errors.count, o.parts, o.tolerance_mm);
  md += "| effect | range | ideal median / p95 (um) | with it median / p95 (um) | not measured | wrong verdicts ideal / with it |\n";
  md += "|---|---|---|---|---|---|\n";
  for (const RobustnessRow& r : st.rows)
    md += fmt::format("| {} | {} | {:.2f} / {:.2f} | {:.2f} / {:.2f} | {}/{} ({:.1f}%) | {} / {} |\n", r.name, r.range,
                      1000 * r.ideal.median_abs_mm, 1000 * r.ideal.p95_abs_mm, 1000 * r.with_effect.median_abs_mm,
                      1000 * r.with_effect.p95_abs_mm, r.not_measured, r.parts,
                      r.parts > 0 ? 100.0 * r.not_measured / r.parts : 0.0, r.wrong_ideal, r.wrong_with_effect);
  for (const RobustnessRow& r : st.rows)
    for (const std::string& reason : r.reasons) md += fmt::format("\n- not measured ({}): {}", r.name, reason);
  md += "\n";
  return md;
}

nlohmann::json RobustnessJson(const RobustnessStudy& st, const BatchStudyOptions& o) {
  nlohmann::json rows = nlohmann::json::array();
  for (const RobustnessRow& r : st.rows)
    rows.push_back({{"effect", r.name}, {"range", r.range}, {"parts", r.parts}, {"measured_both", r.measured_both},
                    {"errors_ideal", ErrorJson(r.ideal)}, {"errors_with_effect", ErrorJson(r.with_effect)},
                    {"not_measured", r.not_measured}, {"not_measured_reasons", r.reasons},
                    {"wrong_verdicts_ideal", r.wrong_ideal}, {"wrong_verdicts_with_effect", r.wrong_with_effect}});
  return {{"parts", o.parts}, {"seed", o.seed}, {"tolerance_mm", o.tolerance_mm},
          {"ideal_measured", st.ideal.errors.count}, {"errors_ideal", ErrorJson(st.ideal.errors)}, {"rows", rows}};
}

cv::Mat3b RotationChart(const RotationStudy& st) {
  PlotSpec spec;
  spec.title = "Coverage against the part's rotation to the camera baseline";
  spec.x_label = "rotation (deg)";
  spec.y_label = "coverage of the outline";
  spec.y_from_zero = true;
  PlotSeries lowest, median;
  lowest.style = median.style = PlotSeries::Style::kLine;
  lowest.colour = kRed;
  lowest.label = "lowest";
  median.colour = kBlue;
  median.label = "median";
  for (const RotationRow& r : st.rows) {
    lowest.x.push_back(r.rotation_deg);
    lowest.y.push_back(r.coverage_min);
    median.x.push_back(r.rotation_deg);
    median.y.push_back(r.coverage_median);
  }
  spec.series = {median, lowest};
  spec.references.push_back({false, BatchStudy::kGoodCoverage, kOrange, "0.9"});
  return DrawPlot(spec);
}

cv::Mat3b MeasuredVsTrueChart(const BatchStudy& st, double tol) {
  PlotSpec spec;
  spec.title = fmt::format("Measured against true flatness, {} parts", st.parts.size());
  spec.x_label = "true flatness (mm)";
  spec.y_label = "measured flatness (mm)";
  PlotSeries right, wrong, diagonal;
  right.colour = kGreen;
  right.label = "right verdict";
  wrong.colour = kRed;
  wrong.label = "wrong verdict";
  diagonal.style = PlotSeries::Style::kLine;
  diagonal.colour = kGrey;
  double hi = tol;
  for (const PartMeasurement& m : st.parts) {
    if (!m.measured) continue;
    PlotSeries& s = m.pass == (m.true_flatness_mm > tol) ? wrong : right;
    s.x.push_back(m.true_flatness_mm);
    s.y.push_back(m.values.flatness_mm);
    hi = std::max({hi, m.true_flatness_mm, m.values.flatness_mm});
  }
  diagonal.x = {0, hi};
  diagonal.y = {0, hi};
  spec.series = {diagonal, right, wrong};
  const double u = st.uncertainty_mm;
  spec.bands.push_back({false, tol - u, tol + u, cv::Scalar(210, 235, 250)});
  spec.references.push_back({true, tol, kOrange, fmt::format("tolerance {:.3f} mm (band: +-U = {:.1f} um)", tol, 1000 * u)});
  spec.references.push_back({false, tol, kOrange, ""});
  return DrawPlot(spec);
}

cv::Mat3b ErrorHistogramChart(const std::vector<PartMeasurement>& parts, double u, const std::string& title) {
  std::vector<double> errors_um;
  for (const PartMeasurement& m : parts)
    if (m.measured) errors_um.push_back(1000 * m.ErrorMm());
  PlotSpec spec;
  spec.title = title;
  spec.x_label = "flatness error, measured - true (um)";
  spec.y_label = "parts";
  spec.y_from_zero = true;
  const int bins = std::clamp(static_cast<int>(std::sqrt(static_cast<double>(errors_um.size()))) * 2, 5, 60);
  PlotSeries bars = HistogramBars(errors_um, bins, kBlue);
  spec.series.push_back(bars);
  spec.references.push_back({true, -1000 * u, kOrange, fmt::format("+-U = {:.2f} um", 1000 * u)});
  spec.references.push_back({true, 1000 * u, kOrange, ""});
  spec.references.push_back({true, 0.0, kGrey, ""});
  return DrawPlot(spec);
}

}  // namespace flatscan
