#include "flatscan/store/store_test_util.h"

namespace flatscan::testing {

StationRecord TestRecord(const std::string& source_id, const std::string& left_sha256, double flatness_mm,
                         const std::string& station_id) {
  StationRecord r;
  r.record_id = NewRecordId();
  r.station_id = station_id;
  r.source_id = source_id;
  r.recipe_name = "shield";
  r.recipe_sha256 = std::string(64, 'c');
  r.left_sha256 = left_sha256;
  r.right_sha256 = std::string(64, 'e');
  r.software_version = "0.1.0";
  InspectionResult result;
  result.values = {flatness_mm, flatness_mm, flatness_mm};
  result.coverage = 0.9;
  InspectionInputs inputs;
  inputs.id = source_id;
  r.inspection = flatness_mm >= 0 ? MeasuredRecord(result, InspectionParams{}, {0.1, 0}, inputs)
                                  : NotMeasuredRecord("no part in the images", InspectionParams{}, {0.1, 0}, inputs);
  return r;
}

std::vector<StationRecord> AllRecords(ResultsStore& store, const TimeRange& range) {
  std::vector<StationRecord> out;
  store.ForEach(range, [&](const StationRecord& r) { out.push_back(r); });
  return out;
}

}  // namespace flatscan::testing
