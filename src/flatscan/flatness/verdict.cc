#include "flatscan/flatness/verdict.h"

#include <algorithm>
#include <cmath>

#include "flatscan/util/error.h"

namespace flatscan {

void CheckFlatnessSpec(const FlatnessSpec& spec) {
  if (!(std::isfinite(spec.tolerance_mm) && spec.tolerance_mm > 0))
    ThrowFieldError("tolerance_mm", "expected a flatness tolerance > 0 mm, got {}", spec.tolerance_mm);
  if (!(std::isfinite(spec.guard_band_mm) && spec.guard_band_mm >= 0))
    ThrowFieldError("guard_band_mm", "expected a guard band >= 0 mm, got {}", spec.guard_band_mm);
}

const char* VerdictName(Verdict verdict) { return verdict == Verdict::kPass ? "pass" : "fail"; }

Judgement Judge(double flatness_mm, const FlatnessSpec& spec, double part_uncertainty_mm) {
  // A non-finite flatness is no measurement (InspectPart reports it as not measured):
  // judging it would give NaN > T, a pass.
  FLATSCAN_CHECK(std::isfinite(flatness_mm) && part_uncertainty_mm >= 0);
  Judgement j;
  j.verdict = flatness_mm > spec.tolerance_mm ? Verdict::kFail : Verdict::kPass;
  j.marginal = std::abs(flatness_mm - spec.tolerance_mm) <= std::max(spec.guard_band_mm, part_uncertainty_mm);
  return j;
}

}  // namespace flatscan
