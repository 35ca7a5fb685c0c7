#pragma once
// Crossed gauge repeatability and reproducibility (GR&R) by analysis of variance, as in
// AIAG, Measurement Systems Analysis, 4th edition (2010), ch. III section B ("Analysis of
// Variance (ANOVA) Method") and Appendix A; checked against that chapter's worked example
// (10 parts, 3 appraisers, 3 trials) in gauge_rr_test.cc.
//
// Design: p parts, each measured r times by each of a appraisers (a = 1: an automatic
// station without appraisers, the part re-seated for every trial; several stations may
// stand as appraisers). Model: y = mu + P_i + A_j + (PA)_ij + e_ijk, all effects random.
//
// Sums of squares (ybar.. the grand mean, ybar_i.. a part's, ybar_.j. an appraiser's,
// ybar_ij. a cell's mean):
//   SS_P  = a r sum_i (ybar_i.. - ybar..)^2             df p - 1
//   SS_A  = p r sum_j (ybar_.j. - ybar..)^2             df a - 1
//   SS_E  = sum_ijk (y_ijk - ybar_ij.)^2                 df p a (r - 1)
//   SS_AP = SS_T - SS_P - SS_A - SS_E                    df (p - 1)(a - 1)
// and MS = SS / df. The interaction is tested by F = MS_AP / MS_E on (df_AP, df_E). When
// its p-value exceeds `alpha_interaction` (0.25, the default of R's qualityTools and a
// conservative choice: the term is dropped only when clearly insignificant) it is pooled
// into the error, MS_E' = (SS_AP + SS_E) / (df_AP + df_E), and
//   EV^2 = MS_E',  AV^2 = (MS_A - MS_E') / (p r),  PV^2 = (MS_P - MS_E') / (a r),  INT = 0;
// otherwise
//   EV^2 = MS_E,  INT^2 = (MS_AP - MS_E) / r,  AV^2 = (MS_A - MS_AP) / (p r),
//   PV^2 = (MS_P - MS_AP) / (a r).
// A negative variance estimate is set to 0 (AIAG). With one appraiser the model is
// one-way: EV^2 = MS_E (the re-seating is part of the repeatability), PV^2 = (MS_P - MS_E) / r.
// GRR^2 = EV^2 + AV^2 + INT^2, TV^2 = GRR^2 + PV^2; all spreads are standard deviations
// (in the data's unit, mm), "% of tolerance" uses 6 sigma: 100 * 6 GRR / T, where T is the
// tolerance's width (flatness: the upper limit, its lower limit being 0);
// "% of TV" is 100 * GRR / TV; ndc = floor(1.41 PV / GRR).
//
// Acceptance (AIAG 4th ed., ch. II section D): %GRR under 10% acceptable, 10-30% may be
// acceptable depending on the application, over 30% not acceptable; ndc at least 5. The
// verdict here is on %GRR of the tolerance (a station judges parts against the tolerance);
// %GRR of TV and ndc say whether the gauge can also follow the process (they depend on how
// much the study's parts differ, so they need parts spread over the process's range).
#include <string>
#include <vector>

namespace flatscan {

// One measurement of a study: which part, by which appraiser (or station), which trial.
struct GaugeObservation {
  std::string part, appraiser, trial;
  double value = 0;
  int line = 0;  // where it was read (for messages); 0 when not from a file
};

struct AnovaRow {
  std::string source;
  int df = 0;
  double ss = 0, ms = 0;
  double f = 0, p = 0;  // F ratio and its p-value; 0 where the row has no test (error, total)
};

struct GaugeRROptions {
  double tolerance_mm = 0;           // T, the tolerance's width (> 0)
  double alpha_interaction = 0.25;   // the interaction is pooled into the error when its p-value is above this
};

struct GaugeRRResult {
  int parts = 0, appraisers = 0, trials = 0;
  std::vector<AnovaRow> anova;  // parts, appraisers, interaction, repeatability, total (the rows that apply)
  bool interaction_included = false;
  std::string method;           // what was fitted and the rule that chose it
  // Standard deviations (the data's unit).
  double ev = 0, av = 0, interaction = 0, grr = 0, pv = 0, tv = 0;
  double pct_grr_tolerance = 0, pct_grr_tv = 0;
  int ndc = 0;
  std::string acceptance;       // "acceptable", "conditionally acceptable", "not acceptable" (on %GRR of the tolerance)
};

// The crossed study of `data`. Throws InputError when the data cannot make a study: an
// unbalanced or incomplete design (every part measured the same number of times by
// every appraiser), a repeated (part, appraiser, trial), fewer than 5 parts or 2 trials,
// or no variation between the trials at all. `file` names the data in messages.
GaugeRRResult AnalyseGaugeRR(const std::vector<GaugeObservation>& data, const GaugeRROptions& options,
                             const std::string& file);

// The acceptance class of a %GRR (AIAG): under 10, 10-30, over 30.
std::string GaugeAcceptance(double pct_grr);

}  // namespace flatscan
