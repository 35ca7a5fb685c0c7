#include "flatscan/gauge/gauge_data.h"

#include <algorithm>
#include <cmath>
#include <map>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "flatscan/io/csv_table.h"
#include "flatscan/util/error.h"
#include "flatscan/util/statistics.h"

namespace flatscan {
namespace {

constexpr double kMicrometreRatio = 100;  // median |value| / T beyond which values look like micrometres

// How many times apart two columns' typical magnitudes are (max / min of the medians), 1
// when either is 0: one column in micrometres puts two instruments' values 1000x apart.
double TimesApart(const double median_a, const double median_b) {
  if (!(median_a > 0 && median_b > 0)) return 1.0;
  return std::max(median_a, median_b) / std::min(median_a, median_b);
}

const std::string& NonEmpty(const CsvTable& table, size_t row, const std::string& column) {
  const std::string& cell = table.Cell(row, column);
  if (cell.empty()) ThrowInputError("{}: line {}: the {} is empty", table.file(), table.Line(row), column);
  return cell;
}

}  // namespace

std::vector<GaugeObservation> ReadGaugeRRCsv(const std::filesystem::path& path) {
  const CsvTable table =
      CsvTable::Read(path, {"part", "trial", "value"}, {"appraiser"}, "the columns part,appraiser,trial,value (mm)");
  std::vector<GaugeObservation> out;
  for (size_t r = 0; r < table.rows(); ++r) {
    GaugeObservation o;
    o.part = NonEmpty(table, r, "part");
    o.appraiser = table.Has("appraiser") ? NonEmpty(table, r, "appraiser") : "station";
    o.trial = NonEmpty(table, r, "trial");
    o.value = table.Number(r, "value");
    o.line = table.Line(r);
    out.push_back(std::move(o));
  }
  return out;
}

std::vector<double> ReadType1Csv(const std::filesystem::path& path) {
  const CsvTable table = CsvTable::Read(path, {"value"}, {"trial", "part"}, "the columns value[,trial][,part] (mm)");
  std::vector<double> out;
  for (size_t r = 0; r < table.rows(); ++r) {
    if (table.Has("part") && table.Cell(r, "part") != table.Cell(0, "part"))
      ThrowInputError("{}: line {}: part '{}', but line {} is part '{}': a type 1 study measures one reference part",
                      table.file(), table.Line(r), table.Cell(r, "part"), table.Line(0), table.Cell(0, "part"));
    out.push_back(table.Number(r, "value"));
  }
  return out;
}

std::vector<LinearityObservation> ReadLinearityCsv(const std::filesystem::path& path) {
  const CsvTable table =
      CsvTable::Read(path, {"part", "reference", "value"}, {}, "the columns part,reference,value (mm)");
  std::vector<LinearityObservation> out;
  std::vector<double> values, references;
  for (size_t r = 0; r < table.rows(); ++r) {
    LinearityObservation o{NonEmpty(table, r, "part"), table.Number(r, "reference"), table.Number(r, "value"),
                           table.Line(r)};
    values.push_back(std::abs(o.value));
    references.push_back(std::abs(o.reference));
    out.push_back(std::move(o));
  }
  const double value_median = Median(values), reference_median = Median(references);
  if (const double apart = TimesApart(value_median, reference_median); apart > kMicrometreRatio)
    ThrowInputError("{}: the values (median {:.4g}) and the references (median {:.4g}) are {:.0f} times apart: one "
                    "column is in micrometres? (both must be in mm)",
                    table.file(), value_median, reference_median, apart);
  return out;
}

std::vector<GaugeObservation> ReadAgreementCsv(const std::filesystem::path& path) {
  const CsvTable table = CsvTable::Read(path, {"part", "value"}, {"trial"}, "the columns part,value[,trial] (mm)");
  std::vector<GaugeObservation> out;
  for (size_t r = 0; r < table.rows(); ++r)
    out.push_back({NonEmpty(table, r, "part"), "", table.Cell(r, "trial"), table.Number(r, "value"), table.Line(r)});
  return out;
}

namespace {

// Up to five ids, then how many more.
std::string FewIds(const std::vector<std::string>& ids) {
  std::vector<std::string> shown(ids.begin(), ids.begin() + std::min<size_t>(ids.size(), 5));
  for (std::string& id : shown) id = "'" + id + "'";
  return fmt::format("{}{}", fmt::join(shown, ", "), ids.size() > 5 ? fmt::format(" and {} more", ids.size() - 5) : "");
}

}  // namespace

std::vector<AgreementPair> PairWithReference(const std::vector<GaugeObservation>& measured,
                                             const ReferenceTable& reference, FlatnessQuantity q,
                                             const std::string& data_name, const std::string& reference_name) {
  std::map<std::string, AgreementPair> by_part;
  std::vector<std::string> unknown;
  for (const GaugeObservation& o : measured) {
    const auto ref = reference.find(o.part);
    if (ref == reference.end()) {
      if (by_part.find(o.part) == by_part.end() &&
          std::find(unknown.begin(), unknown.end(), o.part) == unknown.end())
        unknown.push_back(o.part);
      continue;
    }
    const std::optional<double> value = ref->second.Get(q);
    if (!value)
      ThrowInputError("{}: part '{}' has no {} (the study compares {})", reference_name, o.part,
                      FlatnessQuantityName(q), FlatnessQuantityName(q));
    AgreementPair& pair = by_part.emplace(o.part, AgreementPair{o.part, *value, 0, 0}).first->second;
    pair.measured += o.value;  // summed here, the mean below
    ++pair.trials;
  }
  if (!unknown.empty())
    ThrowInputError("{}: unknown part ids {}: not in the reference {} (a typo, or the wrong file?)", data_name,
                    FewIds(unknown), reference_name);
  std::vector<std::string> unmeasured;
  for (const auto& [part, value] : reference)
    if (by_part.find(part) == by_part.end()) unmeasured.push_back(part);
  if (!unmeasured.empty())
    ThrowInputError("{}: part ids {} were not measured in {} (a typo, or the wrong file?)", reference_name,
                    FewIds(unmeasured), data_name);
  std::vector<AgreementPair> out;
  std::vector<double> references, values;
  for (auto& [part, pair] : by_part) {
    pair.measured /= pair.trials;
    references.push_back(std::abs(pair.reference));
    values.push_back(std::abs(pair.measured));
    out.push_back(pair);
  }
  const double rm = Median(references), vm = Median(values);
  if (const double apart = TimesApart(rm, vm); apart > kMicrometreRatio)
    ThrowInputError("{} (median {:.4g}) and {} (median {:.4g}) are {:.0f} times apart: one of them is in micrometres? "
                    "(both must be in mm)",
                    reference_name, rm, data_name, vm, apart);
  return out;
}

void CheckMillimetres(const std::vector<double>& values, double tolerance_mm, const std::string& file,
                      const std::string& column) {
  std::vector<double> magnitudes;
  for (double v : values) magnitudes.push_back(std::abs(v));
  const double median = Median(magnitudes);
  if (tolerance_mm > 0 && median > kMicrometreRatio * tolerance_mm)
    ThrowInputError("{}: the {}s look like micrometres: their median {:.4g} is {:.0f} times the tolerance {} mm "
                    "(expected values in mm: divide by 1000)",
                    file, column, median, median / tolerance_mm, tolerance_mm);
}

}  // namespace flatscan
