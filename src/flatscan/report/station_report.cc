#include "flatscan/report/station_report.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <fmt/format.h>

namespace flatscan {
namespace {

constexpr size_t kListed = 10;

void AddOnce(std::vector<std::string>& list, const std::string& value) {
  if (!value.empty() && std::find(list.begin(), list.end(), value) == list.end()) list.push_back(value);
}

std::string VerdictText(const InspectionRecord& r) {
  if (!r.measured) return "not measured: " + r.error;
  return std::string(VerdictName(r.judgement.verdict)) + (r.judgement.marginal ? " (marginal)" : "");
}

ReportedPart Part(const StationRecord& r) {
  return {r.sequence,      r.time_utc, r.source_id, r.inspection.values.flatness_mm, VerdictText(r.inspection),
          r.archive.thumbnail, ""};
}

void FinishRecipe(RecipeReport& recipe, const std::vector<const StationRecord*>& records) {
  std::vector<ReportedPart> measured;
  for (const StationRecord* r : records) {
    if (r->inspection.measured) measured.push_back(Part(*r));
    else recipe.not_measured.push_back(Part(*r));
  }
  std::stable_sort(measured.begin(), measured.end(),
                   [](const ReportedPart& a, const ReportedPart& b) { return a.flatness_mm > b.flatness_mm; });
  measured.resize(std::min(measured.size(), kListed));
  recipe.worst = std::move(measured);
  std::reverse(recipe.not_measured.begin(), recipe.not_measured.end());
  recipe.not_measured.resize(std::min(recipe.not_measured.size(), kListed));
  if (recipe.flatness_mm.size() >= 2) {
    recipe.capability = ComputeUpperCapability(recipe.flatness_mm, recipe.tolerance_mm);
    recipe.chart = ComputeIndividualsChart(recipe.flatness_mm);
    recipe.signals = WesternElectricSignals(recipe.flatness_mm, *recipe.chart);
  }
}

// Per (period, recipe): the records of a day or a shift, in time order.
class PeriodTable {
 public:
  void Add(const std::string& period, const StationRecord& r) {
    PeriodReport& p = rows_[{period, r.recipe_name}];
    p.period = period;
    p.recipe = r.recipe_name;
    p.tolerance_mm = r.inspection.spec.tolerance_mm;
    p.counts.Add(r.inspection);
    if (r.inspection.measured) flatness_[{period, r.recipe_name}].push_back(r.inspection.values.flatness_mm);
  }
  std::vector<PeriodReport> Rows() const {
    std::vector<PeriodReport> out;
    for (const auto& [key, row] : rows_) {
      out.push_back(row);
      const auto values = flatness_.find(key);
      if (values != flatness_.end() && values->second.size() >= 2)
        out.back().capability = ComputeUpperCapability(values->second, row.tolerance_mm);
    }
    return out;
  }

 private:
  std::map<std::pair<std::string, std::string>, PeriodReport> rows_;
  std::map<std::pair<std::string, std::string>, std::vector<double>> flatness_;
};

}  // namespace

void RecordCounts::Add(const InspectionRecord& r) {
  ++records;
  if (!r.measured) {
    ++not_measured;
    return;
  }
  ++measured;
  (r.judgement.pass() ? pass : fail) += 1;
  marginal += r.judgement.marginal;
}

int AttachThumbnails(StationReport& report) {
  int read = 0;
  for (RecipeReport& recipe : report.recipes)
    for (std::vector<ReportedPart>* list : {&recipe.worst, &recipe.not_measured})
      for (ReportedPart& part : *list) {
        if (part.thumbnail.empty()) continue;
        std::ifstream in(part.thumbnail, std::ios::binary);
        std::stringstream bytes;
        bytes << in.rdbuf();
        if (!in || bytes.str().empty()) continue;
        part.image_jpeg = bytes.str();
        ++read;
      }
  return read;
}

StationReport SummariseRecords(const std::vector<StationRecord>& records, const std::string& recipe_name,
                               const std::string& query, const ShiftCalendar& shifts) {
  StationReport report;
  PeriodTable days, shift_table;
  report.query = query;
  report.generated_utc = UtcNowIso8601();
  std::map<std::string, std::vector<const StationRecord*>> by_recipe;
  for (const StationRecord& r : records) {
    if (!recipe_name.empty() && r.recipe_name != recipe_name) continue;
    if (report.first_utc.empty()) report.first_utc = r.time_utc;
    report.last_utc = r.time_utc;
    report.counts.Add(r.inspection);
    AddOnce(report.software_versions, r.software_version);
    AddOnce(report.stations, r.station_id);
    by_recipe[r.recipe_name].push_back(&r);
    SystemTime time;
    try {
      time = ParseStoredUtc(r.time_utc);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(fmt::format("record {}: time_utc {}", r.sequence, e.what()));
    }
    days.Add(LocalDay(time), r);
    shift_table.Add(shifts.ShiftLabel(time), r);
  }
  report.days = days.Rows();
  report.shifts = shift_table.Rows();
  for (const auto& [name, list] : by_recipe) {
    RecipeReport recipe;
    recipe.name = name;
    for (const StationRecord* r : list) {
      recipe.counts.Add(r->inspection);
      recipe.tolerance_mm = r->inspection.spec.tolerance_mm;
      if (std::find(recipe.tolerances.begin(), recipe.tolerances.end(), recipe.tolerance_mm) == recipe.tolerances.end())
        recipe.tolerances.push_back(recipe.tolerance_mm);
      AddOnce(recipe.rigs, r->inspection.inputs.rig_sha256);
      AddOnce(recipe.planes, r->inspection.inputs.plane_sha256);
      if (r->inspection.measured) recipe.flatness_mm.push_back(r->inspection.values.flatness_mm);
    }
    FinishRecipe(recipe, list);
    report.recipes.push_back(std::move(recipe));
  }
  return report;
}

}  // namespace flatscan
