#pragma once
// Records for the store tests (SQLite and PostgreSQL): the same keys a station writes.
#include <string>
#include <vector>

#include "flatscan/store/results_store.h"

namespace flatscan::testing {

// A record of pair `source_id` from station `station_id`: measured with flatness_mm
// when it is >= 0, otherwise not measured ("no part in the images").
StationRecord TestRecord(const std::string& source_id, const std::string& left_sha256, double flatness_mm,
                         const std::string& station_id = "test");

// Every record of `store` in `range`, as ForEach gives them.
std::vector<StationRecord> AllRecords(ResultsStore& store, const TimeRange& range = {});

}  // namespace flatscan::testing
