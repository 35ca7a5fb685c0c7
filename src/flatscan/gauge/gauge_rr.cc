#include "flatscan/gauge/gauge_rr.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>

#include <boost/math/distributions/fisher_f.hpp>
#include <fmt/format.h>

#include "flatscan/util/error.h"

namespace flatscan {
namespace {

constexpr int kMinParts = 5;   // fewer give PV (and ndc) from under 4 degrees of freedom
constexpr int kMinTrials = 2;  // repeatability needs a repeat

// The labels in order of first appearance, and each observation's index into them.
struct Factor {
  std::vector<std::string> levels;
  std::vector<int> index;  // per observation
};

Factor FactorOf(const std::vector<GaugeObservation>& data, std::string GaugeObservation::*label) {
  Factor f;
  std::map<std::string, int> seen;
  for (const GaugeObservation& o : data) {
    const auto [it, added] = seen.emplace(o.*label, static_cast<int>(f.levels.size()));
    if (added) f.levels.push_back(o.*label);
    f.index.push_back(it->second);
  }
  return f;
}

std::string Where(const GaugeObservation& o) { return o.line > 0 ? fmt::format("line {}: ", o.line) : ""; }

void CheckNoRepeats(const std::vector<GaugeObservation>& data, const std::string& file) {
  std::map<std::tuple<std::string, std::string, std::string>, int> first;
  for (const GaugeObservation& o : data) {
    const auto [it, added] = first.emplace(std::tuple{o.part, o.appraiser, o.trial}, o.line);
    if (!added)
      ThrowInputError("{}: {}part '{}', appraiser '{}', trial '{}' is listed twice (first on line {}): each "
                      "measurement once",
                      file, Where(o), o.part, o.appraiser, o.trial, it->second);
  }
}

// Every part measured the same number of times (r) by every appraiser; returns r.
int CheckBalanced(const Factor& parts, const Factor& appraisers, const std::vector<GaugeObservation>& data,
                  const std::string& file) {
  const size_t p = parts.levels.size(), a = appraisers.levels.size();
  std::vector<int> count(p * a, 0);
  for (size_t k = 0; k < data.size(); ++k) ++count[parts.index[k] * a + appraisers.index[k]];
  const int r = count[0];
  for (size_t i = 0; i < p; ++i)
    for (size_t j = 0; j < a; ++j)
      if (count[i * a + j] != r)
        ThrowInputError("{}: unbalanced design: part '{}' by appraiser '{}' has {} trials, part '{}' by appraiser '{}' "
                        "has {} (a crossed study needs every part measured the same number of times by every "
                        "appraiser)",
                        file, parts.levels[i], appraisers.levels[j], count[i * a + j], parts.levels[0],
                        appraisers.levels[0], r);
  if (static_cast<int>(p) < kMinParts)
    ThrowInputError("{}: {} parts: a gauge R&R study needs at least {} (AIAG recommends 10 spread over the process's "
                    "range)",
                    file, p, kMinParts);
  if (r < kMinTrials)
    ThrowInputError("{}: {} trial per part and appraiser: a gauge R&R study needs at least {} (repeatability needs a "
                    "repeat)",
                    file, r, kMinTrials);
  return r;
}

double UpperTailF(double f, int df1, int df2) {
  if (!(f > 0) || !std::isfinite(f)) return f > 0 ? 0.0 : 1.0;
  return boost::math::cdf(boost::math::complement(boost::math::fisher_f(df1, df2), f));
}

AnovaRow Row(std::string source, int df, double ss) {
  return {std::move(source), df, ss, df > 0 ? ss / df : 0.0, 0, 0};
}

void Test(AnovaRow& row, const AnovaRow& against) {
  row.f = against.ms > 0 ? row.ms / against.ms : 0.0;
  row.p = UpperTailF(row.f, row.df, against.df);
}

}  // namespace

std::string GaugeAcceptance(double pct_grr) {
  if (pct_grr < 10) return "acceptable";
  if (pct_grr <= 30) return "conditionally acceptable";
  return "not acceptable";
}

GaugeRRResult AnalyseGaugeRR(const std::vector<GaugeObservation>& data, const GaugeRROptions& options,
                             const std::string& file) {
  if (!(options.tolerance_mm > 0) || !std::isfinite(options.tolerance_mm))
    ThrowFieldError("tolerance_mm", "expected a tolerance above 0 mm, got {}", options.tolerance_mm);
  if (data.empty()) ThrowInputError("{}: no measurements (expected rows part,appraiser,trial,value)", file);
  CheckNoRepeats(data, file);
  const Factor parts = FactorOf(data, &GaugeObservation::part);
  const Factor appraisers = FactorOf(data, &GaugeObservation::appraiser);
  const int r = CheckBalanced(parts, appraisers, data, file);
  const int p = static_cast<int>(parts.levels.size()), a = static_cast<int>(appraisers.levels.size());

  // Means of the grand total, parts, appraisers and cells.
  double grand = 0;
  std::vector<double> part_mean(p, 0), appraiser_mean(a, 0), cell_mean(p * a, 0);
  for (size_t k = 0; k < data.size(); ++k) {
    grand += data[k].value;
    part_mean[parts.index[k]] += data[k].value / (a * r);
    appraiser_mean[appraisers.index[k]] += data[k].value / (p * r);
    cell_mean[parts.index[k] * a + appraisers.index[k]] += data[k].value / r;
  }
  grand /= static_cast<double>(data.size());
  double ss_total = 0, ss_error = 0, ss_parts = 0, ss_appraisers = 0;
  for (size_t k = 0; k < data.size(); ++k) {
    ss_total += std::pow(data[k].value - grand, 2);
    ss_error += std::pow(data[k].value - cell_mean[parts.index[k] * a + appraisers.index[k]], 2);
  }
  for (double m : part_mean) ss_parts += a * r * std::pow(m - grand, 2);
  for (double m : appraiser_mean) ss_appraisers += p * r * std::pow(m - grand, 2);
  const double ss_interaction = std::max(0.0, ss_total - ss_parts - ss_appraisers - ss_error);
  if (!(ss_error > 1e-12 * std::max(1.0, ss_total)))
    ThrowInputError("{}: every trial of every part and appraiser gives the same value: the data cannot show the "
                    "gauge's variation (values copied, or rounded coarser than the gauge's resolution?)",
                    file);

  GaugeRRResult out;
  out.parts = p;
  out.appraisers = a;
  out.trials = r;
  AnovaRow part_row = Row("parts", p - 1, ss_parts);
  AnovaRow appraiser_row = Row("appraisers", a - 1, ss_appraisers);
  AnovaRow interaction_row = Row("parts x appraisers", (p - 1) * (a - 1), ss_interaction);
  AnovaRow error_row = Row("repeatability", p * a * (r - 1), ss_error);
  const AnovaRow total_row = Row("total", p * a * r - 1, ss_total);
  double ev2 = 0, av2 = 0, int2 = 0, pv2 = 0;
  if (a == 1) {
    Test(part_row, error_row);
    out.method = "parts x trials, one appraiser (station): one-way ANOVA, the re-seating between trials is part of "
                 "the repeatability";
    ev2 = error_row.ms;
    pv2 = (part_row.ms - error_row.ms) / r;
    out.anova = {part_row, error_row, total_row};
  } else {
    Test(interaction_row, error_row);
    out.interaction_included = interaction_row.p <= options.alpha_interaction;
    if (out.interaction_included) {
      Test(part_row, interaction_row);
      Test(appraiser_row, interaction_row);
      ev2 = error_row.ms;
      int2 = (interaction_row.ms - error_row.ms) / r;
      av2 = (appraiser_row.ms - interaction_row.ms) / (p * r);
      pv2 = (part_row.ms - interaction_row.ms) / (a * r);
      out.anova = {part_row, appraiser_row, interaction_row, error_row, total_row};
    } else {
      const AnovaRow pooled = Row("repeatability", interaction_row.df + error_row.df, ss_interaction + ss_error);
      Test(part_row, pooled);
      Test(appraiser_row, pooled);
      ev2 = pooled.ms;
      av2 = (appraiser_row.ms - pooled.ms) / (p * r);
      pv2 = (part_row.ms - pooled.ms) / (a * r);
      out.anova = {part_row, appraiser_row, interaction_row, pooled, total_row};
    }
    out.method = fmt::format(
        "crossed two-way ANOVA {} the parts x appraisers interaction (its p-value {:.3g} is {} alpha {}: {})",
        out.interaction_included ? "with" : "without", interaction_row.p,
        out.interaction_included ? "at or below" : "above", options.alpha_interaction,
        out.interaction_included ? "kept" : "pooled into the repeatability");
  }
  out.ev = std::sqrt(std::max(0.0, ev2));
  out.av = std::sqrt(std::max(0.0, av2));
  out.interaction = std::sqrt(std::max(0.0, int2));
  out.pv = std::sqrt(std::max(0.0, pv2));
  out.grr = std::hypot(out.ev, out.av, out.interaction);
  out.tv = std::hypot(out.grr, out.pv);
  out.pct_grr_tolerance = 100 * 6 * out.grr / options.tolerance_mm;
  out.pct_grr_tv = 100 * out.grr / out.tv;
  out.ndc = static_cast<int>(std::floor(1.41 * out.pv / out.grr));
  out.acceptance = GaugeAcceptance(out.pct_grr_tolerance);
  return out;
}

}  // namespace flatscan
