#pragma once
// The report's charts as inline SVG text (no script, no external file): an individuals
// control chart and a histogram, each against the upper specification limit.
#include <string>
#include <vector>

#include "flatscan/spc/spc.h"

namespace flatscan {

// The values in order with the chart's centre line and limits (dashed; the lower one only
// when above 0), the tolerance (red), and the points where a Western Electric rule fires circled in red (their rule as
// a tooltip). Values in mm.
std::string ControlChartSvg(const std::vector<double>& values, const IndividualsChart& chart, double tolerance_mm,
                            const std::vector<RuleSignal>& signals);

// 20 bins from 0 to a little above the larger of the tolerance and the largest value,
// with the tolerance line.
std::string HistogramSvg(const std::vector<double>& values, double tolerance_mm);

}  // namespace flatscan
