#pragma once
// The gauge studies' data files (CSV with a header, io/csv_table.h; values in mm):
//   gauge R&R   part,appraiser,trial,value   appraiser may be left out: one station, re-seated per trial
//   type 1      value[,trial][,part]         one reference part (a part column must name one part)
//   linearity   part,reference,value         reference: the part's value from the reference instrument
//   agreement   part,value[,trial]           a part measured several times: the mean is compared
// Labels are text (a part "7" and "07" are different parts). Every reader throws
// InputError naming the file, the line and the column.
#include <filesystem>
#include <string>
#include <vector>

#include "flatscan/gauge/agreement_study.h"
#include "flatscan/gauge/gauge_rr.h"
#include "flatscan/gauge/linearity_study.h"
#include "flatscan/gauge/reference_values.h"

namespace flatscan {

std::vector<GaugeObservation> ReadGaugeRRCsv(const std::filesystem::path& path);
std::vector<double> ReadType1Csv(const std::filesystem::path& path);
std::vector<LinearityObservation> ReadLinearityCsv(const std::filesystem::path& path);
std::vector<GaugeObservation> ReadAgreementCsv(const std::filesystem::path& path);

// Each measured part's mean beside its reference value of quantity `q`. Every measured part
// must be in the reference and every reference part measured (an unknown id is a typo or
// the wrong file: the study would quietly lose parts); the reference must give `q` for
// each; the two columns must not be 100 times apart (one in micrometres). `data_name` and
// `reference_name` name the two sources in messages.
std::vector<AgreementPair> PairWithReference(const std::vector<GaugeObservation>& measured,
                                             const ReferenceTable& reference, FlatnessQuantity q,
                                             const std::string& data_name, const std::string& reference_name);

// Values written in micrometres by mistake (1000 times too large) make a study that looks
// complete and is wrong. Refused when the median |value| exceeds 100 T: a lot of parts whose
// typical flatness is 100 times its tolerance is not one a gauge study is run on, while
// micrometres put parts near the tolerance at 1000 T.
void CheckMillimetres(const std::vector<double>& values, double tolerance_mm, const std::string& file,
                      const std::string& column = "value");

}  // namespace flatscan
