#pragma once
// The verdict on a measured part: the one place where a flatness is judged against a
// tolerance. InspectPart measures; this judges; `inspect`, the studies and the
// station's recipes all call it.
//
// Flatness has an upper specification limit only, the tolerance T (there is no lower
// limit: a perfectly flat part is perfect):
//   verdict  = fail  if flatness_mm > T,  pass otherwise        (the paper's eq. 2.13)
//   marginal = |flatness_mm - T| <= max(guard band, U_part)
// The guard band is the station's measurement uncertainty as the user states it (ISO
// 14253-1 style; for example U, the 95th percentile of |error| from `flatscan
// evaluate` on a model of the rig); U_part is the part's own uncertainty once the
// measurement gives one (0 until then). A marginal part is neither proven good nor
// proven bad: its verdict stays pass or fail, and what to do with it (re-measure, send
// it to a gauge) is the line's decision. A part that was not measured has no verdict
// at all (its record says measured: false and why, never pass or fail).
//
// Units: mm.
namespace flatscan {

struct FlatnessSpec {
  static constexpr double kDefaultToleranceMm = 0.1;  // the usual tolerance of EMI shield covers
  double tolerance_mm = kDefaultToleranceMm;
  double guard_band_mm = 0.0;
};
// Throws InputError (field "tolerance_mm" or "guard_band_mm") unless the tolerance is
// finite and > 0 and the guard band finite and >= 0.
void CheckFlatnessSpec(const FlatnessSpec& spec);

enum class Verdict { kPass, kFail };
const char* VerdictName(Verdict verdict);  // "pass" / "fail"

struct Judgement {
  Verdict verdict = Verdict::kPass;
  bool marginal = false;
  bool pass() const { return verdict == Verdict::kPass; }
};

// `flatness_mm`: the measured flatness_mm (finite: a part that could not be measured
// is never judged); `part_uncertainty_mm`: U_part (>= 0).
Judgement Judge(double flatness_mm, const FlatnessSpec& spec, double part_uncertainty_mm = 0.0);

}  // namespace flatscan
