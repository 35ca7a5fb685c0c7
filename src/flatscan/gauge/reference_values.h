#pragma once
// A reference instrument's values per part (a laser profiler, a CMM, a height gauge), to
// compare flatscan with. Two forms:
//  - a CSV of values: `part` and one or more of `flatness_mm`, `lsq_pv_mm`, `minzone_mm`;
//  - the instrument's raw points, one CSV per part named <part>.csv in a folder, columns
//    `x,y,z` (mm): the rim's or the whole height map's points of the part lying on the
//    instrument's surface plate, z the height above that plate. flatscan computes the three
//    quantities from them with its own code (flatness/flatness_metrics.h: flatness_mm =
//    max z, the seated height; lsq_pv_mm and minzone_mm about the points' own planes), so
//    that both instruments are compared on one definition.
#include <filesystem>
#include <map>
#include <optional>
#include <string>

#include "flatscan/flatness/flatness_metrics.h"

namespace flatscan {

enum class FlatnessQuantity { kFlatness, kLsqPv, kMinZone };

// "flatness_mm", "lsq_pv_mm", "minzone_mm" (the JSON keys of a record).
const char* FlatnessQuantityName(FlatnessQuantity q);
// Throws InputError (field `field`) for any other name.
FlatnessQuantity ParseFlatnessQuantity(const std::string& name, const std::string& field);
double ValueOf(const FlatnessValues& values, FlatnessQuantity q);

// One part's reference values; a quantity the file did not give is empty.
struct ReferenceValue {
  std::optional<double> flatness_mm, lsq_pv_mm, minzone_mm;
  int line = 0;  // of the CSV row (0: from points)
  std::optional<double> Get(FlatnessQuantity q) const;
};

using ReferenceTable = std::map<std::string, ReferenceValue>;  // by part id

// Throws InputError naming the file and line: unknown columns, no quantity column, a
// part listed twice, values that are not numbers, negative or empty where the column is given.
ReferenceTable ReadReferenceCsv(const std::filesystem::path& path);

// Every <part>.csv of `folder` as profiler points (at least 3 per part, finite, x,y,z in mm).
ReferenceTable ReadReferencePoints(const std::filesystem::path& folder);

// The three quantities of one part's points (x,y,z CSV).
FlatnessValues FlatnessOfPointsCsv(const std::filesystem::path& path);

}  // namespace flatscan
