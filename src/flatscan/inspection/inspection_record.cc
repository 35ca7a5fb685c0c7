#include "flatscan/inspection/inspection_record.h"

#include <fmt/format.h>

#include "flatscan/util/error.h"

namespace flatscan {
namespace {

using nlohmann::json;

// Below this coverage the record warns that part of the outline came from the warp fit.
constexpr double kWarnCoverage = 0.9;
// What a part should be turned to the camera baseline for its outline to be measured
// (its sides then cross the epipolar rows; evaluate --rotation-step measures it).
constexpr int kPresentTurnedDeg = 10;

InspectionRecord BaseRecord(const InspectionParams& params, const FlatnessSpec& spec, const InspectionInputs& inputs) {
  InspectionRecord r;
  r.id = inputs.id;
  r.spec = spec;
  r.thickness_mm = params.thickness_mm;
  r.thickness_correction = params.thickness_correction;
  r.side_faces = params.side_faces;
  r.inputs = inputs;
  return r;
}

json NullUnless(bool present, const json& value) { return present ? value : json(nullptr); }

// Reads record keys, with messages that name the key and what was expected.
class RecordReader {
 public:
  explicit RecordReader(const json& j) : j_(j) {
    if (!j.is_object()) ThrowInputError("inspection record: expected a JSON object, got {}", j.type_name());
  }
  const json& At(const char* key, const char* expected) const {
    if (!j_.contains(key)) ThrowInputError("inspection record: missing key '{}' (expected {})", key, expected);
    return j_.at(key);
  }
  bool IsNull(const char* key) const { return !j_.contains(key) || j_.at(key).is_null(); }
  double Number(const char* key) const { return Get<double>(At(key, "a number"), key, "a number"); }
  int Integer(const json& v, const char* key) const { return Get<int>(v, key, "an integer"); }
  bool Bool(const char* key) const { return Get<bool>(At(key, "true or false"), key, "true or false"); }
  std::string String(const json& v, const char* key) const { return Get<std::string>(v, key, "a string"); }
  template <typename T>
  T Get(const json& v, const char* key, const char* expected) const {
    const bool ok = std::is_same_v<T, bool>          ? v.is_boolean()
                    : std::is_same_v<T, std::string> ? v.is_string()
                    : std::is_same_v<T, int>         ? v.is_number_integer()
                                                     : v.is_number();
    if (!ok) ThrowInputError("inspection record: key '{}' must be {}, found {}", key, expected, v.dump());
    return v.get<T>();
  }

 private:
  const json& j_;
};

}  // namespace

double InspectionRecord::TotalMs() const {
  double total = 0;
  for (const auto& [stage, ms] : timing_ms) total += ms;
  return total;
}

InspectionRecord MeasuredRecord(const InspectionResult& result, const InspectionParams& params,
                                const FlatnessSpec& spec, const InspectionInputs& inputs) {
  InspectionRecord r = BaseRecord(params, spec, inputs);
  r.measured = true;
  r.values = result.values;
  r.uncertainty = result.uncertainty;
  r.judgement = Judge(result.values.flatness_mm, spec, result.uncertainty.expanded_mm);
  r.coverage = result.coverage;
  r.crossings_left = result.crossings_left;
  r.crossings_right = result.crossings_right;
  r.matched = result.matched;
  r.valid = result.valid;
  r.completed = result.completed;
  r.rim_noise_mm = result.rim_noise_mm;
  r.side_tilt_rad = result.side_tilt_rad;
  r.max_face_tilt_rad = result.max_face_tilt_rad;
  r.local_deviations = result.local_deviations;
  r.blur_left_px = result.blur_left_px;
  r.blur_right_px = result.blur_right_px;
  r.timing_ms = result.timing_ms;
  if (result.coverage < kWarnCoverage)
    r.warnings.push_back(fmt::format(
        "only {:.0f}% of the outline was measured: stretches running along the epipolar rows cannot be matched and "
        "were completed from the fitted warp; turn the part at least {} degrees to the camera baseline for a full "
        "measurement", 100 * result.coverage, kPresentTurnedDeg));
  if (result.uncertainty.maximum_unmeasured)
    r.warnings.push_back(fmt::format(
        "the maximum may lie in a stretch of the outline the cameras cannot measure (along the epipolar rows): "
        "present the part turned at least {} degrees to the camera baseline", kPresentTurnedDeg));
  if (result.uncertainty.rig_replicates == 0)
    r.warnings.push_back(
        "the rig file has no calibration replicates (imported, written before they existed, or calibrated from "
        "fewer than 4 pairs): uncertainty_mm leaves out the rig calibration's share; calibrate the rig with "
        "calibrate-rig from 4 or more pairs to include it");
  return r;
}

InspectionRecord NotMeasuredRecord(const std::string& reason, const InspectionParams& params,
                                   const FlatnessSpec& spec, const InspectionInputs& inputs) {
  InspectionRecord r = BaseRecord(params, spec, inputs);
  r.measured = false;
  r.error = reason;
  return r;
}

json RecordToJson(const InspectionRecord& r) {
  const bool m = r.measured;
  json j;
  j["id"] = r.id;
  j["measured"] = m;
  j["error"] = NullUnless(!m, r.error);
  j["verdict"] = NullUnless(m, VerdictName(r.judgement.verdict));
  j["marginal"] = m && r.judgement.marginal;
  j["flatness_mm"] = NullUnless(m, r.values.flatness_mm);
  j["lsq_pv_mm"] = NullUnless(m, r.values.lsq_pv_mm);
  j["minzone_mm"] = NullUnless(m, r.values.minzone_mm);
  j["uncertainty_mm"] = NullUnless(m, r.uncertainty.expanded_mm);
  j["coverage"] = NullUnless(m, r.coverage);
  j["uncertainty"] = NullUnless(m, json{{"coverage_factor", 2},
                                        {"rim_mm", r.uncertainty.rim_mm},
                                        {"rig_mm", r.uncertainty.rig_mm},
                                        {"plane_mm", r.uncertainty.plane_mm},
                                        {"method_mm", r.uncertainty.method_mm},
                                        {"rig_replicates", r.uncertainty.rig_replicates},
                                        {"maximum_unmeasured", r.uncertainty.maximum_unmeasured}});
  j["tolerance_mm"] = r.spec.tolerance_mm;
  j["guard_band_mm"] = r.spec.guard_band_mm;
  j["thickness_mm"] = r.thickness_mm;
  j["thickness_correction"] = r.thickness_correction;
  j["points"] = {{"crossings_left", r.crossings_left}, {"crossings_right", r.crossings_right},
                 {"matched", r.matched}, {"valid", r.valid}, {"completed", r.completed}};
  j["rim_model"] = {{"noise_mm", r.rim_noise_mm}, {"local_deviations", r.local_deviations},
                    {"side_faces", SideFaceModelName(r.side_faces)}, {"side_tilt_rad", r.side_tilt_rad},
                    {"max_face_tilt_rad", r.max_face_tilt_rad}};
  j["blur_sigma_px"] = {r.blur_left_px, r.blur_right_px};
  json timing = json::object();
  for (const auto& [stage, ms] : r.timing_ms) timing[stage] = ms;
  timing["total"] = r.TotalMs();
  j["timing_ms"] = timing;
  j["inputs"] = {{"rig", r.inputs.rig_file},     {"rig_sha256", r.inputs.rig_sha256}, {"plane", r.inputs.plane_file},
                 {"plane_sha256", r.inputs.plane_sha256}, {"plane_rig", PlaneRigMatchName(r.inputs.plane_rig)},
                 {"left", r.inputs.left_file}, {"right", r.inputs.right_file}};
  j["warnings"] = r.warnings;
  return j;
}

InspectionRecord RecordFromJson(const json& j) {
  const RecordReader in(j);
  InspectionRecord r;
  r.id = in.String(in.At("id", "a string"), "id");
  r.measured = in.Bool("measured");
  r.spec.tolerance_mm = in.Number("tolerance_mm");
  r.spec.guard_band_mm = in.Number("guard_band_mm");
  r.thickness_mm = in.Number("thickness_mm");
  r.thickness_correction = in.Bool("thickness_correction");
  if (r.measured) {
    r.values = {in.Number("flatness_mm"), in.Number("lsq_pv_mm"), in.Number("minzone_mm")};
    r.coverage = in.Number("coverage");
    r.uncertainty.expanded_mm = in.Number("uncertainty_mm");
    const json& u = in.At("uncertainty", "an object");
    r.uncertainty.rim_mm = in.Get<double>(u.value("rim_mm", json()), "uncertainty.rim_mm", "a number");
    r.uncertainty.rig_mm = in.Get<double>(u.value("rig_mm", json()), "uncertainty.rig_mm", "a number");
    r.uncertainty.plane_mm = in.Get<double>(u.value("plane_mm", json()), "uncertainty.plane_mm", "a number");
    r.uncertainty.method_mm = in.Get<double>(u.value("method_mm", json()), "uncertainty.method_mm", "a number");
    r.uncertainty.rig_replicates = in.Integer(u.value("rig_replicates", json()), "uncertainty.rig_replicates");
    r.uncertainty.maximum_unmeasured =
        in.Get<bool>(u.value("maximum_unmeasured", json()), "uncertainty.maximum_unmeasured", "true or false");
    const std::string verdict = in.String(in.At("verdict", "\"pass\" or \"fail\""), "verdict");
    if (verdict != "pass" && verdict != "fail")
      ThrowInputError("inspection record: key 'verdict' must be \"pass\" or \"fail\", found \"{}\"", verdict);
    r.judgement.verdict = verdict == "pass" ? Verdict::kPass : Verdict::kFail;
    r.judgement.marginal = in.Bool("marginal");
  } else {
    if (!in.IsNull("verdict")) ThrowInputError("inspection record: key 'verdict' must be null when measured is false");
    r.error = in.String(in.At("error", "the reason the part was not measured"), "error");
  }
  const json& points = in.At("points", "an object");
  r.crossings_left = in.Integer(points.value("crossings_left", json()), "points.crossings_left");
  r.crossings_right = in.Integer(points.value("crossings_right", json()), "points.crossings_right");
  r.matched = in.Integer(points.value("matched", json()), "points.matched");
  r.valid = in.Integer(points.value("valid", json()), "points.valid");
  r.completed = in.Integer(points.value("completed", json()), "points.completed");
  const json& model = in.At("rim_model", "an object");
  r.rim_noise_mm = in.Get<double>(model.value("noise_mm", json()), "rim_model.noise_mm", "a number");
  r.local_deviations = in.Integer(model.value("local_deviations", json()), "rim_model.local_deviations");
  r.side_tilt_rad = in.Get<double>(model.value("side_tilt_rad", json()), "rim_model.side_tilt_rad", "a number");
  r.max_face_tilt_rad =
      in.Get<double>(model.value("max_face_tilt_rad", json()), "rim_model.max_face_tilt_rad", "a number");
  const std::string faces = in.Get<std::string>(model.value("side_faces", json()), "rim_model.side_faces", "a string");
  try {
    r.side_faces = ParseSideFaceModel(faces);
  } catch (const InputError& e) {
    ThrowInputError("inspection record: key 'rim_model.side_faces': {}", e.what());
  }
  const json& blur = in.At("blur_sigma_px", "[left, right]");
  if (!blur.is_array() || blur.size() != 2) ThrowInputError("inspection record: key 'blur_sigma_px' must be [left, right]");
  r.blur_left_px = in.Get<double>(blur[0], "blur_sigma_px", "a number");
  r.blur_right_px = in.Get<double>(blur[1], "blur_sigma_px", "a number");
  for (const auto& [stage, ms] : in.At("timing_ms", "an object").items())
    if (stage != "total") r.timing_ms.emplace_back(stage, in.Get<double>(ms, "timing_ms", "a number"));
  const json& inputs = in.At("inputs", "an object");
  auto text = [&](const char* key) { return in.String(inputs.value(key, json()), key); };
  r.inputs = {r.id, text("rig"), text("plane"), text("left"), text("right"), text("rig_sha256"), text("plane_sha256")};
  const std::string plane_rig = text("plane_rig");
  const auto match = ParsePlaneRigMatch(plane_rig);
  if (!match)
    ThrowInputError("inspection record: key 'inputs.plane_rig' must be \"matches\", \"foreign\" or \"unknown\", found \"{}\"",
                    plane_rig);
  r.inputs.plane_rig = *match;
  for (const json& w : in.At("warnings", "an array of strings")) r.warnings.push_back(in.String(w, "warnings"));
  return r;
}

}  // namespace flatscan
