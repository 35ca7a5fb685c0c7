#include "flatscan/outputs/live_summary.h"

#include "flatscan/report/svg_chart.h"
#include "flatscan/spc/spc.h"
#include "flatscan/util/error.h"

namespace flatscan {
namespace {

using std::chrono::system_clock;

// Yield, null before the first measured part (the page shows "-" rather than 0 %).
nlohmann::json YieldJson(const RecordCounts& counts) {
  return counts.measured > 0 ? nlohmann::json(counts.Yield()) : nlohmann::json(nullptr);
}

nlohmann::json WithYield(const RecordCounts& counts) {
  nlohmann::json j = CountsJson(counts);
  j["yield"] = YieldJson(counts);
  return j;
}

// A fail or a not-measured part as the page lists it.
nlohmann::json Problem(const StationRecord& record) {
  const InspectionRecord& r = record.inspection;
  nlohmann::json archive = nullptr;
  if (!record.archive.left.empty()) archive = {{"left", record.archive.left}, {"right", record.archive.right}};
  return {{"sequence", record.sequence},
          {"time_utc", record.time_utc},
          {"source_id", record.source_id},
          {"verdict", r.measured ? "fail" : "not measured"},
          {"flatness_mm", r.measured ? nlohmann::json(r.values.flatness_mm) : nlohmann::json(nullptr)},
          {"reason", r.measured ? fmt::format("flatness {:.4f} mm over the tolerance {:.3f} mm", r.values.flatness_mm,
                                              r.spec.tolerance_mm)
                                : r.error},
          {"archive", archive}};
}

}  // namespace

nlohmann::json CountsJson(const RecordCounts& c) {
  return {{"measured", c.measured}, {"pass", c.pass}, {"fail", c.fail}, {"marginal", c.marginal},
          {"not_measured", c.not_measured}};
}

LiveSummary::LiveSummary(std::string station_id, ShiftCalendar shifts, SystemTime started, size_t trend_length,
                         size_t problems)
    : station_id_(std::move(station_id)),
      shifts_(std::move(shifts)),
      started_(started),
      trend_length_(trend_length),
      problems_length_(problems) {
  RollShift(started);
}

void LiveSummary::RollShift(SystemTime now) {
  const SystemTime start = shifts_.ShiftStart(now);
  if (start == shift_start_) return;
  shift_start_ = start;
  shift_start_utc_ = FormatUtc(start);
  shift_ = {};
}

void LiveSummary::Remember(const StationRecord& record) {
  store_.Add(record.inspection);
  const InspectionRecord& r = record.inspection;
  if (r.measured) {
    trend_.push_back(r.values.flatness_mm);
    if (trend_.size() > trend_length_) trend_.pop_front();
    tolerance_mm_ = r.spec.tolerance_mm;
  }
  if (!r.measured || !r.judgement.pass()) {
    problems_.push_front(Problem(record));
    if (problems_.size() > problems_length_) problems_.pop_back();
  }
  last_ = record;
}

void LiveSummary::AddStored(const StationRecord& record) {
  Remember(record);
  if (record.time_utc >= shift_start_utc_) shift_.Add(record.inspection);  // the stored form compares as text
}

void LiveSummary::AddNew(const StationRecord& record, SystemTime now) {
  RollShift(now);
  Remember(record);
  since_start_.Add(record.inspection);
  shift_.Add(record.inspection);
  recent_commits_.push_back(now);
}

void LiveSummary::SetReadiness(bool ready, const std::string& reason) {
  ready_ = ready;
  not_ready_reason_ = ready ? "" : reason;
}

nlohmann::json LiveSummary::ToJson(SystemTime now) {
  RollShift(now);
  while (!recent_commits_.empty() && recent_commits_.front() < now - std::chrono::minutes(1))
    recent_commits_.pop_front();
  nlohmann::json problems = nlohmann::json::array();
  for (const nlohmann::json& p : problems_) problems.push_back(p);
  return {{"station_id", station_id_},
          {"state", ready_ ? "ready" : "not_ready"},
          {"not_ready_reason", ready_ ? nlohmann::json(nullptr) : nlohmann::json(not_ready_reason_)},
          {"started_utc", FormatUtc(started_)},
          {"counts", CountsJson(store_)},
          {"yield", YieldJson(store_)},
          {"since_start", WithYield(since_start_)},
          {"shift", {{"name", shifts_.ShiftName(now)}, {"start_utc", shift_start_utc_}, {"counts", WithYield(shift_)}}},
          {"rate_per_min", recent_commits_.size()},
          {"last", last_ ? StationRecordToJson(*last_) : nlohmann::json(nullptr)},
          {"trend", {{"flatness_mm", trend_}, {"tolerance_mm", tolerance_mm_}}},
          {"recent_problems", problems}};
}

std::string LiveSummary::TrendSvg(TrendChart which) const {
  if (trend_.size() < 2)
    return R"(<svg xmlns="http://www.w3.org/2000/svg" width="640" height="40"><text x="8" y="24">)"
           "the trend starts at the second measured part</text></svg>";
  const std::vector<double> values(trend_.begin(), trend_.end());
  const IndividualsChart chart = ComputeIndividualsChart(values);
  if (which == TrendChart::kMovingRange) return MovingRangeChartSvg(chart);
  return ControlChartSvg(values, chart, tolerance_mm_, WesternElectricSignals(values, chart));
}

}  // namespace flatscan
