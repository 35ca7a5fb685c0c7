#pragma once
// The report's charts as inline SVG text (no script, no external file): an individuals
// and moving-range control chart pair and a histogram against the upper specification limit.
#include <string>
#include <vector>

#include "flatscan/spc/spc.h"

namespace flatscan {

// The values in order with the chart's centre line and limits (dashed; the lower one only
// when above 0), the tolerance (red), and the points where a Western Electric rule fires circled in red (their rule as
// a tooltip). Values in mm.
std::string ControlChartSvg(const std::vector<double>& values, const IndividualsChart& chart, double tolerance_mm,
                            const std::vector<RuleSignal>& signals);

// The moving ranges |x_i - x_(i-1)| of the same values (the MR chart of an I-MR pair): the
// centre MRbar and the upper limit D4 MRbar (the lower one is 0), ranges beyond it circled
// in red. Values in mm; needs 2 values or more (the chart's).
std::string MovingRangeChartSvg(const IndividualsChart& chart);

// 20 bins from 0 to a little above the larger of the tolerance and the largest value,
// with the tolerance line.
std::string HistogramSvg(const std::vector<double>& values, double tolerance_mm);

// A Bland-Altman plot: each part's difference (measured - reference, um) against the mean of
// the two (mm), with the bias and the two limits of agreement (um) as lines.
std::string BlandAltmanSvg(const std::vector<double>& means_mm, const std::vector<double>& differences_um,
                           double bias_um, double lower_um, double upper_um);

}  // namespace flatscan
