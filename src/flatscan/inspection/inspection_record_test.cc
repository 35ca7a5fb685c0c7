#include "flatscan/inspection/inspection_record.h"

#include <map>
#include <set>

#include <gtest/gtest.h>

#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {

InspectionResult SomeResult(double flatness_mm, double coverage) {
  InspectionResult r;
  r.values = {flatness_mm, 0.8 * flatness_mm, 0.75 * flatness_mm};
  r.crossings_left = 2200;
  r.crossings_right = 2190;
  r.matched = 2150;
  r.valid = 2101;
  r.coverage = coverage;
  r.completed = 12;
  r.side_tilt_rad = 0.0123;
  r.max_face_tilt_rad = 0.0456;
  r.rim_noise_mm = 0.0004;
  r.local_deviations = 3;
  r.blur_left_px = 1.01;
  r.blur_right_px = 0.99;
  r.timing_ms = {{"boundary_left", 1.5}, {"matching", 1.7}};
  r.uncertainty.expanded_mm = 0.0061;
  r.uncertainty.rim_mm = 0.0021;
  r.uncertainty.rig_mm = 0.0019;
  r.uncertainty.plane_mm = 0.0002;
  r.uncertainty.rig_replicates = 14;
  return r;
}

const InspectionInputs kInputs{"part_007",          "rig.yml",           "plane.yml",
                               "l.png",             "r.png",             std::string(64, 'a'),
                               std::string(64, 'b'), PlaneRigMatch::kForeign};

std::set<std::string> Keys(const nlohmann::json& j) {
  std::set<std::string> keys;
  for (const auto& [k, v] : j.items()) keys.insert(k);
  return keys;
}

const std::set<std::string> kRecordKeys = {
    "id",          "measured",      "error",        "verdict",      "marginal",    "flatness_mm", "lsq_pv_mm",
    "minzone_mm",  "coverage",      "tolerance_mm", "guard_band_mm", "thickness_mm", "thickness_correction",
    "points",      "rim_model",     "blur_sigma_px", "timing_ms",    "inputs",      "warnings",
    "uncertainty_mm", "uncertainty"};

TEST(InspectionRecord, MeasuredRecordHasEveryKeyAndRoundTrips) {
  InspectionParams params;
  params.thickness_mm = 0.25;
  params.side_faces = SideFaceModel::kCentreNormal;
  const InspectionRecord record = MeasuredRecord(SomeResult(0.1031, 0.85), params, {0.1, 0.004}, kInputs);
  EXPECT_EQ(record.judgement.verdict, Verdict::kFail);
  EXPECT_TRUE(record.judgement.marginal);
  const nlohmann::json j = RecordToJson(record);
  EXPECT_EQ(Keys(j), kRecordKeys);
  EXPECT_EQ(j["verdict"], "fail");
  EXPECT_EQ(j["measured"], true);
  EXPECT_TRUE(j["error"].is_null());
  EXPECT_EQ(j["timing_ms"]["total"], 3.2);
  ASSERT_EQ(j["warnings"].size(), 1u);  // coverage below 0.9
  EXPECT_EQ(j["warnings"][0].get<std::string>().rfind("only 85% of the outline was measured", 0), 0u);

  const InspectionRecord back = RecordFromJson(nlohmann::json::parse(j.dump()));
  EXPECT_EQ(RecordToJson(back), j);
  EXPECT_EQ(back.values.flatness_mm, 0.1031);
  EXPECT_EQ(back.inputs.plane_sha256, std::string(64, 'b'));
  EXPECT_EQ(j["inputs"]["plane_rig"], "foreign");
  EXPECT_EQ(back.inputs.plane_rig, PlaneRigMatch::kForeign);
  EXPECT_EQ(back.spec.guard_band_mm, 0.004);
  EXPECT_EQ(j["rim_model"]["side_faces"], "centre");
  EXPECT_EQ(back.side_faces, SideFaceModel::kCentreNormal);
  EXPECT_EQ(back.max_face_tilt_rad, 0.0456);
  EXPECT_EQ(j["uncertainty_mm"], 0.0061);
  EXPECT_EQ(j["uncertainty"]["coverage_factor"], 2);
  EXPECT_EQ(back.uncertainty.rig_mm, 0.0019);
  EXPECT_EQ(back.uncertainty.rig_replicates, 14);
  EXPECT_FALSE(back.uncertainty.maximum_unmeasured);
  nlohmann::json bad = j;
  bad["rim_model"]["side_faces"] = "sideways";
  EXPECT_EQ(testing::InputErrorOf([&] { RecordFromJson(bad); }).rfind(
                "inspection record: key 'rim_model.side_faces': unknown side-face model 'sideways' (expected local", 0),
            0u);
}

TEST(InspectionRecord, NotMeasuredHasNoVerdictAndNoValues) {
  const InspectionRecord record = NotMeasuredRecord("l.png: no part found", {}, {}, kInputs);
  const nlohmann::json j = RecordToJson(record);
  EXPECT_EQ(Keys(j), kRecordKeys);
  EXPECT_EQ(j["measured"], false);
  EXPECT_TRUE(j["verdict"].is_null());
  EXPECT_EQ(j["marginal"], false);
  EXPECT_TRUE(j["flatness_mm"].is_null());
  EXPECT_TRUE(j["coverage"].is_null());
  EXPECT_TRUE(j["uncertainty_mm"].is_null());
  EXPECT_TRUE(j["uncertainty"].is_null());
  EXPECT_EQ(j["error"], "l.png: no part found");
  EXPECT_EQ(j["id"], "part_007");
  EXPECT_EQ(RecordToJson(RecordFromJson(j)), j);
}

// A part is marginal within its own uncertainty of the tolerance, even without a guard
// band; a maximum that may lie in an unmeasured stretch, and a rig without replicates,
// are said in the warnings.
TEST(InspectionRecord, MarginalWithinThePartsOwnUncertainty) {
  InspectionResult result = SomeResult(0.105, 1.0);
  result.uncertainty.expanded_mm = 0.006;
  EXPECT_TRUE(MeasuredRecord(result, {}, {0.1, 0.0}, kInputs).judgement.marginal);
  result.uncertainty.expanded_mm = 0.004;
  const InspectionRecord decided = MeasuredRecord(result, {}, {0.1, 0.0}, kInputs);
  EXPECT_FALSE(decided.judgement.marginal);
  EXPECT_EQ(decided.judgement.verdict, Verdict::kFail);
  EXPECT_TRUE(decided.warnings.empty());

  result.uncertainty.maximum_unmeasured = true;
  result.uncertainty.rig_replicates = 0;
  const InspectionRecord warned = MeasuredRecord(result, {}, {0.1, 0.0}, kInputs);
  ASSERT_EQ(warned.warnings.size(), 2u);
  EXPECT_EQ(warned.warnings[0],
            "the maximum may lie in a stretch of the outline the cameras cannot measure (along the epipolar rows): "
            "present the part turned at least 10 degrees to the camera baseline");
  EXPECT_EQ(warned.warnings[1].rfind("the rig file has no calibration replicates", 0), 0u);
  EXPECT_EQ(RecordToJson(warned)["uncertainty"]["maximum_unmeasured"], true);
}

TEST(InspectionRecord, ReaderNamesTheKey) {
  nlohmann::json j = RecordToJson(MeasuredRecord(SomeResult(0.05, 1.0), {}, {}, kInputs));
  EXPECT_TRUE(j["warnings"].empty());
  j["verdict"] = "maybe";
  EXPECT_EQ(testing::InputErrorOf([&] { RecordFromJson(j); }),
            "inspection record: key 'verdict' must be \"pass\" or \"fail\", found \"maybe\"");
  j.erase("tolerance_mm");
  EXPECT_EQ(testing::InputErrorOf([&] { RecordFromJson(j); }),
            "inspection record: missing key 'tolerance_mm' (expected a number)");
  j = RecordToJson(NotMeasuredRecord("why", {}, {}, kInputs));
  j["inputs"]["plane_rig"] = "mine";
  EXPECT_EQ(testing::InputErrorOf([&] { RecordFromJson(j); }),
            "inspection record: key 'inputs.plane_rig' must be \"matches\", \"foreign\" or \"unknown\", found \"mine\"");
  j["inputs"]["plane_rig"] = "unknown";
  j["verdict"] = "pass";
  EXPECT_EQ(testing::InputErrorOf([&] { RecordFromJson(j); }),
            "inspection record: key 'verdict' must be null when measured is false");
}

}  // namespace
}  // namespace flatscan
