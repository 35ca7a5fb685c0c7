#include "flatscan/gauge/gauge_report.h"

#include <fmt/format.h>

namespace flatscan {
namespace {

constexpr int kMinNdc = 5;  // AIAG: a gauge that tells at least 5 categories of parts apart

std::string Um(double mm) { return fmt::format("{:.2f} um", 1000 * mm); }

}  // namespace

nlohmann::json GaugeRRJson(const GaugeRRResult& r, const GaugeRROptions& options) {
  nlohmann::json anova = nlohmann::json::array();
  for (const AnovaRow& row : r.anova)
    anova.push_back({{"source", row.source}, {"df", row.df}, {"ss", row.ss}, {"ms", row.ms}, {"f", row.f},
                     {"p", row.p}});
  return {{"study", "gauge R&R (crossed, ANOVA)"},
          {"standard", "AIAG MSA 4th edition"},
          {"parts", r.parts},
          {"appraisers", r.appraisers},
          {"trials", r.trials},
          {"tolerance_mm", options.tolerance_mm},
          {"method", r.method},
          {"interaction_included", r.interaction_included},
          {"alpha_interaction", options.alpha_interaction},
          {"anova", anova},
          {"ev", r.ev},
          {"av", r.av},
          {"interaction", r.interaction},
          {"grr", r.grr},
          {"pv", r.pv},
          {"tv", r.tv},
          {"pct_grr_tolerance", r.pct_grr_tolerance},
          {"pct_grr_tv", r.pct_grr_tv},
          {"ndc", r.ndc},
          {"ndc_acceptable", r.ndc >= kMinNdc},
          {"acceptance", r.acceptance},
          {"acceptance_rule", "%GRR of the tolerance (6 GRR / T): under 10% acceptable, 10-30% conditionally "
                              "acceptable, over 30% not acceptable; ndc at least 5"}};
}

nlohmann::json Type1Json(const Type1Result& r, const Type1Options& options) {
  return {{"study", "type 1"},
          {"standard", "VDA 5"},
          {"n", r.n},
          {"tolerance_mm", options.tolerance_mm},
          {"reference_mm", options.reference_mm},
          {"mean_mm", r.mean},
          {"sd_mm", r.sd},
          {"bias_mm", r.bias},
          {"t", r.t},
          {"p", r.p},
          {"cg", r.cg},
          {"cgk", r.cgk},
          {"limit", kType1Limit},
          {"capable", r.capable},
          {"acceptance_rule", "Cg = 0.2 T / 6 s and Cgk = (0.1 T - |bias|) / 3 s, both at least 1.33"}};
}

nlohmann::json LinearityJson(const LinearityResult& r) {
  nlohmann::json parts = nlohmann::json::array();
  for (const LinearityPart& p : r.parts)
    parts.push_back({{"part", p.part}, {"reference_mm", p.reference}, {"n", p.n}, {"bias_mm", p.bias}, {"t", p.t},
                     {"p", p.p}});
  return {{"study", "bias and linearity"},
          {"standard", "AIAG MSA 4th edition"},
          {"n", r.n},
          {"parts", parts},
          {"slope", r.slope},
          {"intercept_mm", r.intercept},
          {"r_squared", r.r_squared},
          {"s_mm", r.s},
          {"t_slope", r.t_slope},
          {"p_slope", r.p_slope},
          {"t_intercept", r.t_intercept},
          {"p_intercept", r.p_intercept},
          {"pct_linearity", r.pct_linearity},
          {"zero_inside_band", r.zero_inside_band},
          {"worst_margin_mm", r.worst_margin},
          {"acceptance", r.zero_inside_band ? "acceptable" : "not acceptable"},
          {"acceptance_rule", "the line bias = 0 lies inside the 95% confidence band of the fitted bias over the "
                              "whole range of the reference values"}};
}

std::string GaugeRRMarkdown(const GaugeRRResult& r, const GaugeRROptions& options, const std::string& source) {
  std::string md = fmt::format(
      "## Gauge R&R (AIAG MSA 4th edition, ANOVA)\n\n{}: {} parts x {} appraiser{} x {} trials, tolerance {} mm.  \n"
      "Method: {}.\n\n",
      source, r.parts, r.appraisers, r.appraisers == 1 ? "" : "s", r.trials, options.tolerance_mm, r.method);
  md += "| source | df | SS | MS | F | p |\n|---|---|---|---|---|---|\n";
  for (const AnovaRow& row : r.anova)
    md += row.f > 0 ? fmt::format("| {} | {} | {:.6g} | {:.6g} | {:.4g} | {:.4g} |\n", row.source, row.df, row.ss,
                                  row.ms, row.f, row.p)
                    : fmt::format("| {} | {} | {:.6g} | {} | | |\n", row.source, row.df, row.ss,
                                  row.source == "total" ? "" : fmt::format("{:.6g}", row.ms));
  md += "\n| component | sd | % of TV | % of tolerance (6 sd / T) |\n|---|---|---|---|\n";
  const auto component = [&](const char* name, double sd) {
    return fmt::format("| {} | {} | {:.1f}% | {:.1f}% |\n", name, Um(sd), 100 * sd / r.tv,
                       100 * 6 * sd / options.tolerance_mm);
  };
  md += component("repeatability (EV)", r.ev) + component("reproducibility (AV)", r.av) +
        component("interaction", r.interaction) + component("GRR", r.grr) + component("part variation (PV)", r.pv) +
        component("total (TV)", r.tv);
  md += fmt::format("\n**%GRR of the tolerance {:.1f}%: {}**; %GRR of TV {:.1f}%; ndc {} ({}).\n", r.pct_grr_tolerance,
                    r.acceptance, r.pct_grr_tv, r.ndc,
                    r.ndc >= kMinNdc ? "at least 5: the gauge tells the study's parts apart"
                                     : "under 5: too few categories for process control");
  return md;
}

std::string Type1Markdown(const Type1Result& r, const Type1Options& options, const std::string& source) {
  return fmt::format(
      "## Type 1 study (VDA 5)\n\n{}: {} measurements of a reference part of {:.4f} mm, tolerance {} mm.\n\n"
      "| mean | sd | bias | t (p) | Cg | Cgk |\n|---|---|---|---|---|---|\n"
      "| {:.5f} mm | {} | {} | {:.2f} ({:.3g}) | {:.2f} | {:.2f} |\n\n"
      "**{}** (Cg and Cgk at least {}).\n",
      source, r.n, options.reference_mm, options.tolerance_mm, r.mean, Um(r.sd), Um(r.bias), r.t, r.p, r.cg, r.cgk,
      r.capable ? "capable" : "not capable", kType1Limit);
}

std::string LinearityMarkdown(const LinearityResult& r, const std::string& source) {
  std::string md = fmt::format("## Bias and linearity (AIAG MSA 4th edition)\n\n{}: {} reference parts, {} readings.\n\n"
                               "| part | reference | n | mean bias | t | p |\n|---|---|---|---|---|---|\n",
                               source, r.parts.size(), r.n);
  for (const LinearityPart& p : r.parts)
    md += fmt::format("| {} | {:.4f} mm | {} | {} | {:.2f} | {:.3g} |\n", p.part, p.reference, p.n, Um(p.bias), p.t, p.p);
  md += fmt::format(
      "\nbias = {:.6g} + {:.6g} x reference (mm); R^2 {:.4f}, s {}; slope t {:.3f} (p {:.3g}), intercept t {:.3f} "
      "(p {:.3g}); %linearity {:.2f}%.\n\n**{}**: the line bias = 0 {} the 95% confidence band over the range.\n",
      r.intercept, r.slope, r.r_squared, Um(r.s), r.t_slope, r.p_slope, r.t_intercept, r.p_intercept, r.pct_linearity,
      r.zero_inside_band ? "acceptable" : "not acceptable", r.zero_inside_band ? "lies inside" : "leaves");
  return md;
}

nlohmann::json AgreementJson(const AgreementResult& r, const std::string& quantity, double tolerance_mm) {
  nlohmann::json parts = nlohmann::json::array();
  for (const AgreementPair& p : r.pairs)
    parts.push_back({{"part", p.part}, {"reference_mm", p.reference}, {"measured_mm", p.measured}, {"trials", p.trials}});
  return {{"study", "agreement with a reference (Bland-Altman)"},
          {"quantity", quantity},
          {"n", r.n},
          {"tolerance_mm", tolerance_mm},
          {"bias_mm", r.bias},
          {"bias_ci95_half_mm", r.bias_ci_half},
          {"sd_mm", r.sd},
          {"lower_loa_mm", r.lower_loa},
          {"upper_loa_mm", r.upper_loa},
          {"loa_ci95_half_mm", r.loa_ci_half},
          {"pct_spread_tolerance", 100 * 6 * r.sd / tolerance_mm},
          {"pearson_r", r.pearson_r},
          {"slope", r.slope},
          {"intercept_mm", r.intercept},
          {"parts", parts}};
}

std::string AgreementMarkdown(const AgreementResult& r, const std::string& quantity, double tolerance_mm,
                              const std::string& source) {
  std::string md = fmt::format(
      "## Agreement with the reference (Bland-Altman)\n\n{}: {} parts, {} (measured - reference).\n\n"
      "| bias | sd of the differences | limits of agreement (95%) | 6 sd / T | Pearson r | measured = a + b reference |\n"
      "|---|---|---|---|---|---|\n"
      "| {} +- {} | {} | {} to {} (each +- {}) | {:.1f}% | {:.4f} | a {}, b {:.4f} |\n\n",
      source, r.n, quantity, Um(r.bias), Um(r.bias_ci_half), Um(r.sd), Um(r.lower_loa), Um(r.upper_loa),
      Um(r.loa_ci_half), 100 * 6 * r.sd / tolerance_mm, r.pearson_r, Um(r.intercept), r.slope);
  md += "| part | reference | measured (mean) | trials | difference |\n|---|---|---|---|---|\n";
  for (const AgreementPair& p : r.pairs)
    md += fmt::format("| {} | {:.4f} mm | {:.4f} mm | {} | {} |\n", p.part, p.reference, p.measured, p.trials,
                      Um(p.measured - p.reference));
  return md;
}

}  // namespace flatscan
