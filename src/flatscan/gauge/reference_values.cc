#include "flatscan/gauge/reference_values.h"

#include <algorithm>
#include <vector>

#include "flatscan/io/csv_table.h"
#include "flatscan/util/error.h"

namespace flatscan {
namespace {

constexpr FlatnessQuantity kQuantities[] = {FlatnessQuantity::kFlatness, FlatnessQuantity::kLsqPv,
                                            FlatnessQuantity::kMinZone};
constexpr int kMinPoints = 3;  // a plane needs three

std::optional<double>& Slot(ReferenceValue& v, FlatnessQuantity q) {
  switch (q) {
    case FlatnessQuantity::kFlatness: return v.flatness_mm;
    case FlatnessQuantity::kLsqPv: return v.lsq_pv_mm;
    case FlatnessQuantity::kMinZone: return v.minzone_mm;
  }
  return v.flatness_mm;
}

}  // namespace

const char* FlatnessQuantityName(FlatnessQuantity q) {
  switch (q) {
    case FlatnessQuantity::kFlatness: return "flatness_mm";
    case FlatnessQuantity::kLsqPv: return "lsq_pv_mm";
    case FlatnessQuantity::kMinZone: return "minzone_mm";
  }
  return "flatness_mm";
}

FlatnessQuantity ParseFlatnessQuantity(const std::string& name, const std::string& field) {
  for (FlatnessQuantity q : kQuantities)
    if (name == FlatnessQuantityName(q)) return q;
  ThrowFieldError(field, "'{}' is not a flatness quantity (expected flatness_mm, lsq_pv_mm or minzone_mm)", name);
}

double ValueOf(const FlatnessValues& values, FlatnessQuantity q) {
  switch (q) {
    case FlatnessQuantity::kFlatness: return values.flatness_mm;
    case FlatnessQuantity::kLsqPv: return values.lsq_pv_mm;
    case FlatnessQuantity::kMinZone: return values.minzone_mm;
  }
  return values.flatness_mm;
}

std::optional<double> ReferenceValue::Get(FlatnessQuantity q) const {
  switch (q) {
    case FlatnessQuantity::kFlatness: return flatness_mm;
    case FlatnessQuantity::kLsqPv: return lsq_pv_mm;
    case FlatnessQuantity::kMinZone: return minzone_mm;
  }
  return flatness_mm;
}

ReferenceTable ReadReferenceCsv(const std::filesystem::path& path) {
  const std::string expected = "the columns part and flatness_mm, lsq_pv_mm and/or minzone_mm (mm)";
  const CsvTable table = CsvTable::Read(path, {"part"}, {"flatness_mm", "lsq_pv_mm", "minzone_mm"}, expected);
  if (!table.Has("flatness_mm") && !table.Has("lsq_pv_mm") && !table.Has("minzone_mm"))
    ThrowInputError("{}: line 1: no value column (expected {})", table.file(), expected);
  ReferenceTable out;
  for (size_t r = 0; r < table.rows(); ++r) {
    const std::string& part = table.Cell(r, "part");
    if (part.empty()) ThrowInputError("{}: line {}: the part is empty", table.file(), table.Line(r));
    ReferenceValue value;
    value.line = table.Line(r);
    for (FlatnessQuantity q : kQuantities) {
      const char* column = FlatnessQuantityName(q);
      if (!table.Has(column)) continue;
      const double v = table.Number(r, column);
      if (v < 0)
        ThrowInputError("{}: line {}: {} {} is negative (a flatness is at least 0)", table.file(), table.Line(r),
                        column, v);
      Slot(value, q) = v;
    }
    const auto [it, added] = out.emplace(part, value);
    if (!added)
      ThrowInputError("{}: line {}: part '{}' is listed twice (first on line {}): one reference value per part",
                      table.file(), table.Line(r), part, it->second.line);
  }
  if (out.empty()) ThrowInputError("{}: no parts listed (expected {})", table.file(), expected);
  return out;
}

FlatnessValues FlatnessOfPointsCsv(const std::filesystem::path& path) {
  const CsvTable table = CsvTable::Read(path, {"x", "y", "z"}, {}, "the columns x,y,z (mm)");
  std::vector<Eigen::Vector3d> points;
  std::vector<double> heights;
  for (size_t r = 0; r < table.rows(); ++r) {
    points.emplace_back(table.Number(r, "x"), table.Number(r, "y"), table.Number(r, "z"));
    heights.push_back(points.back().z());
  }
  if (static_cast<int>(points.size()) < kMinPoints)
    ThrowInputError("{}: {} points: the flatness of a part needs at least {} (x,y,z in mm)", table.file(),
                    points.size(), kMinPoints);
  return ComputeFlatness(points, heights);
}

ReferenceTable ReadReferencePoints(const std::filesystem::path& folder) {
  std::error_code ec;
  if (!std::filesystem::is_directory(folder, ec))
    ThrowInputError("{}: not a folder (expected one <part>.csv of x,y,z points per part)", folder.string());
  std::vector<std::filesystem::path> files;
  for (const auto& entry : std::filesystem::directory_iterator(folder))
    if (entry.is_regular_file() && entry.path().extension() == ".csv") files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  if (files.empty()) ThrowInputError("{}: no <part>.csv files of x,y,z points", folder.string());
  ReferenceTable out;
  for (const std::filesystem::path& file : files) {
    const FlatnessValues v = FlatnessOfPointsCsv(file);
    out[file.stem().string()] = ReferenceValue{v.flatness_mm, v.lsq_pv_mm, v.minzone_mm, 0};
  }
  return out;
}

}  // namespace flatscan
