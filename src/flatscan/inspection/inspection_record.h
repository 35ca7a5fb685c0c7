#pragma once
// The record of one inspected part: one schema for `flatscan inspect`'s JSON and, next,
// the station's stored records, its MQTT payload and its web API. It is what a part
// leaves behind: the measurement, the verdict (flatness/verdict.h), and what produced
// them (the part's id, the files and their SHA-256).
//
// JSON keys (every record has all of them; null where a value does not apply):
//   id                 the part's id (a batch's or a source's), "" when not given
//   measured           true when the part was measured
//   error              why it was not measured (null when measured)
//   verdict            "pass" or "fail"; null when not measured
//   marginal           |flatness_mm - tolerance_mm| <= max(guard_band_mm, uncertainty_mm); false
//                      when not measured
//   flatness_mm, lsq_pv_mm, minzone_mm    the three flatness values (null when not measured)
//   uncertainty_mm     U: expanded uncertainty of flatness_mm (k = 2, about 95%;
//                      inspection/part_uncertainty.h); null when not measured
//   coverage           fraction of the outline measured (null when not measured)
//   uncertainty        {coverage_factor (2), rim_mm, rig_mm, plane_mm, method_mm (standard
//                      uncertainties), rig_replicates (0: the rig file has none and
//                      rig_mm is left out), maximum_unmeasured (the maximum may lie in a
//                      stretch the cameras cannot measure)}; null when not measured
//   tolerance_mm, guard_band_mm, thickness_mm, thickness_correction    what it was judged
//                      and measured with
//   points             {crossings_left, crossings_right, matched, valid, completed}
//   rim_model          {noise_mm, local_deviations, side_faces (local / centre / support),
//                      side_tilt_rad (at the footprint centre), max_face_tilt_rad (over the rim)}
//   blur_sigma_px      [left, right]
//   timing_ms          {stage: ms, ..., total}
//   inputs             {rig, rig_sha256, plane, plane_sha256, plane_rig, left, right}; plane_rig:
//                      "matches" (the plane file was calibrated with this rig file), "foreign"
//                      (with another one, allowed by --allow-foreign-plane) or "unknown" (the
//                      plane file does not say)
//   warnings           [text, ...]
// Names: snake_case with the unit as a suffix (docs/conventions.md, "JSON").
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "flatscan/flatness/verdict.h"
#include "flatscan/inspection/inspect_part.h"
#include "flatscan/io/rig_file.h"

namespace flatscan {

struct InspectionInputs {
  std::string id;  // part id (batch, source) or empty
  std::string rig_file, plane_file, left_file, right_file;
  std::string rig_sha256, plane_sha256;
  PlaneRigMatch plane_rig = PlaneRigMatch::kUnknown;  // the plane file's rig_sha256 against rig_sha256
};

struct InspectionRecord {
  std::string id;
  bool measured = false;
  std::string error;               // when not measured
  FlatnessValues values;           // when measured
  Judgement judgement;             // when measured
  double coverage = 0;             // when measured
  PartUncertainty uncertainty;     // when measured
  FlatnessSpec spec;
  double thickness_mm = 0;
  bool thickness_correction = true;
  int crossings_left = 0, crossings_right = 0, matched = 0, valid = 0, completed = 0;
  SideFaceModel side_faces = SideFaceModel::kLocalNormal;
  double rim_noise_mm = 0, side_tilt_rad = 0, max_face_tilt_rad = 0;
  int local_deviations = 0;
  double blur_left_px = 0, blur_right_px = 0;
  std::vector<std::pair<std::string, double>> timing_ms;  // per stage, in order (total apart)
  InspectionInputs inputs;
  std::vector<std::string> warnings;

  double TotalMs() const;
};

// The record of a measured part, judged against `spec`.
InspectionRecord MeasuredRecord(const InspectionResult& result, const InspectionParams& params,
                                const FlatnessSpec& spec, const InspectionInputs& inputs);
// The record of a part that could not be measured: no verdict, the reason.
InspectionRecord NotMeasuredRecord(const std::string& reason, const InspectionParams& params,
                                   const FlatnessSpec& spec, const InspectionInputs& inputs);

nlohmann::json RecordToJson(const InspectionRecord& record);
// The inverse of RecordToJson; throws InputError naming the key and what was expected.
InspectionRecord RecordFromJson(const nlohmann::json& json);

}  // namespace flatscan
