#pragma once
// A station's record of one pair: the inspection record (inspection/inspection_record.h,
// the same schema `inspect --json` writes) plus what a line needs to trace it: which
// station, when, which pair from which source, which recipe and which image bytes.
//
// JSON: the inspection record's keys, plus
//   record_id          unique id of the record (a random UUID, RFC 4122 version 4)
//   station_id         the station's name ([A-Za-z0-9_-])
//   sequence           1, 2, ... in the order the station committed them (per store)
//   time_utc           when it was committed, ISO 8601 UTC with milliseconds
//                      ("2026-12-04T17:03:12.345Z")
//   source_id          the pair's id in its source (file stem, CSV id, camera frame)
//   recipe, recipe_sha256   the recipe's name and the SHA-256 of its file
//   left_sha256, right_sha256   SHA-256 of each image file's bytes
//   software_version   flatscan's version
//   archive            {left, right[, thumbnail]}: where the images (and the part's
//                      thumbnail, when the station made one) were archived, or null
//   study              {part, appraiser, trial}: the pair's gauge-study tags
//                      (io/study_tags.h); left out when the pair has none
#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "flatscan/io/study_tags.h"
#include "flatscan/inspection/inspection_record.h"

namespace flatscan {

struct ArchivedPair {
  std::string left, right;  // paths of the archived copies; empty when not archived
  std::string thumbnail;    // the part's thumbnail (JPEG) beside them; empty when none
};

struct StationRecord {
  std::string record_id;
  std::string station_id;
  int64_t sequence = 0;     // assigned by the store when committed
  std::string time_utc;     // assigned by the store when committed
  std::string source_id;
  std::string recipe_name, recipe_sha256;
  std::string left_sha256, right_sha256;
  std::string software_version;
  ArchivedPair archive;
  StudyTags study;
  InspectionRecord inspection;
};

nlohmann::json StationRecordToJson(const StationRecord& record);
// The inverse; throws InputError naming the key and what was expected.
StationRecord StationRecordFromJson(const nlohmann::json& json);
// The record as one line of JSON text (how stores and outputs carry it): text that is
// not UTF-8 (a Latin-1 file name) is written as U+FFFD rather than refused.
std::string StationRecordToJsonText(const StationRecord& record);
// The inverse; throws InputError when the text is not JSON or not a record.
StationRecord StationRecordFromJsonText(const std::string& text);

// A random UUID (version 4), lower-case: "1b4e28ba-2fa1-4d2b-883f-0016d3cca427".
std::string NewRecordId();

// The current time as ISO 8601 UTC with milliseconds: "2026-12-04T17:03:12.345Z".
std::string UtcNowIso8601();
// A time a user typed, as the stored form (so that the two compare as strings):
// "2026-12-04", "2026-12-04T17:03", "2026-12-04T17:03:12", "2026-12-04T17:03:12.5",
// each optionally followed by "Z". Throws InputError naming `what` otherwise (times are
// UTC; an offset such as +01:00 is refused rather than guessed).
std::string ParseUtcTime(const std::string& text, const std::string& what);

// A station id from a host name: characters outside [A-Za-z0-9_-] dropped ("station"
// when nothing is left).
std::string StationIdFromHostName(const std::string& host_name);

}  // namespace flatscan
