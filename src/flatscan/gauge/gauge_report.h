#pragma once
// The gauge studies' results as JSON (the keys `flatscan gauge` writes; docs/gauge.md) and
// as Markdown (the terminal's summary and, through report/html_page, the HTML report).
#include <string>

#include <nlohmann/json.hpp>

#include "flatscan/gauge/agreement_study.h"
#include "flatscan/gauge/gauge_rr.h"
#include "flatscan/gauge/linearity_study.h"
#include "flatscan/gauge/type1_study.h"

namespace flatscan {

nlohmann::json GaugeRRJson(const GaugeRRResult& r, const GaugeRROptions& options);
nlohmann::json Type1Json(const Type1Result& r, const Type1Options& options);
nlohmann::json LinearityJson(const LinearityResult& r);
// `quantity` names what was compared (flatness_mm ...); `tolerance_mm` (> 0) puts the
// limits of agreement beside the tolerance.
nlohmann::json AgreementJson(const AgreementResult& r, const std::string& quantity, double tolerance_mm);

// `source` names the data (a file) in the text.
std::string GaugeRRMarkdown(const GaugeRRResult& r, const GaugeRROptions& options, const std::string& source);
std::string Type1Markdown(const Type1Result& r, const Type1Options& options, const std::string& source);
std::string LinearityMarkdown(const LinearityResult& r, const std::string& source);
std::string AgreementMarkdown(const AgreementResult& r, const std::string& quantity, double tolerance_mm,
                              const std::string& source);

}  // namespace flatscan
