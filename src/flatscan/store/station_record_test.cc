#include "flatscan/store/station_record.h"

#include <regex>
#include <set>

#include <gtest/gtest.h>

#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {

StationRecord SomeStationRecord() {
  InspectionResult result;
  result.values = {0.0812, 0.0734, 0.0701};
  result.coverage = 0.93;
  result.uncertainty.expanded_mm = 0.006;
  const InspectionInputs inputs{"p1", "rig.yml", "plane.yml", "l.png", "r.png", std::string(64, 'a'),
                                std::string(64, 'b'), PlaneRigMatch::kMatches};
  StationRecord r;
  r.record_id = NewRecordId();
  r.station_id = "line-3";
  r.sequence = 42;
  r.time_utc = "2026-12-04T17:03:12.345Z";
  r.source_id = "p1";
  r.recipe_name = "shield";
  r.recipe_sha256 = std::string(64, 'c');
  r.left_sha256 = std::string(64, 'd');
  r.right_sha256 = std::string(64, 'e');
  r.software_version = "0.1.0";
  r.archive = {"archive/p1_left.png", "archive/p1_right.png", "archive/p1_thumb.jpg"};
  r.inspection = MeasuredRecord(result, InspectionParams{}, {0.1, 0.0}, inputs);
  return r;
}

TEST(StationRecord, RoundTripsThroughJsonWithTheStationKeys) {
  const StationRecord r = SomeStationRecord();
  const nlohmann::json j = StationRecordToJson(r);
  for (const char* key : {"record_id", "station_id", "sequence", "time_utc", "source_id", "recipe", "recipe_sha256",
                          "left_sha256", "right_sha256", "software_version", "archive", "flatness_mm", "verdict"})
    EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_EQ(j["verdict"], "pass");
  EXPECT_EQ(j["archive"]["thumbnail"], "archive/p1_thumb.jpg");
  const StationRecord back = StationRecordFromJson(nlohmann::json::parse(j.dump()));
  EXPECT_EQ(StationRecordToJson(back), j);
  // Records from before thumbnails: no key, read as none.
  nlohmann::json old = j;
  old["archive"].erase("thumbnail");
  EXPECT_EQ(StationRecordFromJson(old).archive.thumbnail, "");
  EXPECT_EQ(back.inspection.values.flatness_mm, 0.0812);  // exact: JSON keeps doubles round-trip
  EXPECT_FALSE(j.contains("study"));  // a pair without study tags
}

TEST(StationRecord, StudyTagsRoundTripWhenThePairHasThem) {
  StationRecord r = SomeStationRecord();
  r.study = {"p7", "A", "2"};
  const nlohmann::json j = StationRecordToJson(r);
  EXPECT_EQ(j["study"], (nlohmann::json{{"part", "p7"}, {"appraiser", "A"}, {"trial", "2"}}));
  EXPECT_EQ(StationRecordFromJson(nlohmann::json::parse(j.dump())).study, r.study);
}

TEST(StationRecord, AMissingKeyIsNamed) {
  nlohmann::json j = StationRecordToJson(SomeStationRecord());
  j.erase("left_sha256");
  EXPECT_EQ(testing::InputErrorOf([&] { StationRecordFromJson(j); }),
            "station record: key 'left_sha256' must be a string, found nothing");
}

TEST(StationRecord, RecordIdsAreVersion4UuidsAndDiffer) {
  const std::regex uuid("[0-9a-f]{8}-[0-9a-f]{4}-4[0-9a-f]{3}-[89ab][0-9a-f]{3}-[0-9a-f]{12}");
  std::set<std::string> seen;
  for (int i = 0; i < 1000; ++i) {
    const std::string id = NewRecordId();
    ASSERT_TRUE(std::regex_match(id, uuid)) << id;
    seen.insert(id);
  }
  EXPECT_EQ(seen.size(), 1000u);
}

TEST(StationRecord, UtcTimesAreNormalisedToTheStoredForm) {
  EXPECT_EQ(ParseUtcTime("2026-12-04", "--from"), "2026-12-04T00:00:00.000Z");
  EXPECT_EQ(ParseUtcTime("2026-12-04T17:03", "--from"), "2026-12-04T17:03:00.000Z");
  EXPECT_EQ(ParseUtcTime("2026-12-04T17:03:12Z", "--from"), "2026-12-04T17:03:12.000Z");
  EXPECT_EQ(ParseUtcTime("2026-12-04T17:03:12.5", "--from"), "2026-12-04T17:03:12.500Z");
  EXPECT_EQ(ParseUtcTime("2026-12-04T17:03:12.34567Z", "--to"), "2026-12-04T17:03:12.345Z");
  EXPECT_EQ(testing::InputErrorOf([] { ParseUtcTime("2026-12-04T17:03+01:00", "--to"); }),
            "--to: expected a UTC time in ISO 8601 (2026-12-04, 2026-12-04T17:03, 2026-12-04T17:03:12.345Z), found "
            "'2026-12-04T17:03+01:00'");
  EXPECT_EQ(testing::InputErrorOf([] { ParseUtcTime("2026-13-04", "--from"); }),
            "--from: '2026-13-04' is not a valid date and time");
  EXPECT_EQ(testing::InputErrorOf([] { ParseUtcTime("2026-12-04T24:00", "--from"); }),
            "--from: '2026-12-04T24:00' is not a valid date and time");
  const std::string now = UtcNowIso8601();
  EXPECT_EQ(ParseUtcTime(now, "now"), now);
}

TEST(StationRecord, StationIdsFromHostNames) {
  EXPECT_EQ(StationIdFromHostName("line3.plant.example"), "line3plantexample");
  EXPECT_EQ(StationIdFromHostName("cell_7-b"), "cell_7-b");
  EXPECT_EQ(StationIdFromHostName("..."), "station");
}

}  // namespace
}  // namespace flatscan
