#pragma once
// The published worked examples the gauge studies are checked against, and a writer of
// study data as CSV (tests only).
#include <filesystem>
#include <vector>

#include "flatscan/gauge/gauge_rr.h"
#include "flatscan/gauge/linearity_study.h"

namespace flatscan::testing {

// AIAG, Measurement Systems Analysis, 4th edition (2010), ch. III section B: the gauge
// study's data sheet, 10 parts ("1".."10") x 3 appraisers ("A", "B", "C") x 3 trials.
std::vector<GaugeObservation> AiagGaugeRRExample();

// The same manual's linearity example: 5 reference parts (2, 4, 6, 8, 10) x 12 readings.
std::vector<LinearityObservation> AiagLinearityExample();

// part,appraiser,trial,value
void WriteGaugeRRCsv(const std::filesystem::path& path, const std::vector<GaugeObservation>& data);

}  // namespace flatscan::testing
