#include "flatscan/simulation/scene_config.h"

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <opencv2/core.hpp>

#include "flatscan/io/file_storage_limits.h"
#include "flatscan/util/error.h"

namespace flatscan {
namespace {

using nlohmann::json;

// Binds scene fields to document keys, in one of two directions: reading (validate
// and copy document values into the struct) or writing (struct to document). One
// field list (BindScene) serves both, so the file format and its docs cannot drift.
class Binder {
 public:
  Binder(const json* in, json* out, std::string source)
      : in_(in), out_(out), source_(std::move(source)) {}

  // Runs `body` on the sub-object `key` (when writing, or when the document has it).
  template <typename F>
  void Section(const std::string& key, F&& body) {
    if (in_ && !in_->contains(key)) {
      consumed_.insert(path_ + "/" + key);
      return;
    }
    if (!in_ && !out_) return;
    const json* saved_in = in_;
    json* saved_out = out_;
    const std::string saved_path = path_;
    path_ = Path(key);
    if (out_) out_ = &(*out_)[key];
    if (in_) {
      consumed_.insert(saved_path + "/" + key);
      in_ = &in_->at(key);
      if (in_->is_null()) Fail("{}: '{}' has no fields (expected a mapping)", source_, path_);
      if (!in_->is_object())
        Fail("{}: '{}' must be a mapping of fields, got {}", source_, path_, in_->dump());
    }
    body();
    if (in_) CheckUnknownKeys();
    in_ = saved_in;
    out_ = saved_out;
    path_ = saved_path;
  }
  bool reading() const { return in_ != nullptr; }
  // Reports document keys that no field consumed (typos), at the top level.
  void Finish() const {
    if (in_) CheckUnknownKeys();
  }

  void Number(const std::string& key, double& value, double min, double max) {
    if (out_) (*out_)[key] = value;
    if (const json* v = Value(key, fmt::format("a number in [{}, {}]", min, max))) {
      value = ToNumber(*v, key, min, max);
    }
  }
  void Integer(const std::string& key, int& value, int min, int max) {
    if (out_) (*out_)[key] = value;
    if (const json* v = Value(key, fmt::format("an integer in [{}, {}]", min, max))) {
      value = ToInteger(*v, key, min, max);
    }
  }
  void Boolean(const std::string& key, bool& value) {
    if (out_) (*out_)[key] = value;
    if (const json* v = Value(key, "true or false")) {
      if (v->is_boolean()) value = v->get<bool>();
      else if (v->is_number_integer() && (v->get<int>() == 0 || v->get<int>() == 1)) value = v->get<int>() == 1;
      else Fail("{}: {} must be true or false, got {}", source_, Path(key), v->dump());
    }
  }
  // [lo, hi] with min <= lo <= hi <= max, or a scalar meaning lo = hi.
  void RangeField(const std::string& key, Range& range, double min, double max) {
    if (out_) (*out_)[key] = {range.lo, range.hi};
    const std::string expected = fmt::format("a number or a [lo, hi] pair within [{}, {}]", min, max);
    if (const json* v = Value(key, expected)) {
      if (v->is_number()) {
        range.lo = range.hi = ToNumber(*v, key, min, max);
        return;
      }
      if (!v->is_array() || v->size() != 2) Fail("{}: {} must be {}, got {}", source_, Path(key), expected, v->dump());
      range.lo = ToNumber((*v)[0], key + "[0]", min, max);
      range.hi = ToNumber((*v)[1], key + "[1]", min, max);
      if (range.lo > range.hi) Fail("{}: {} must have lo <= hi, got {}", source_, Path(key), v->dump());
    }
  }
  void IntRange(const std::string& key, std::array<int, 2>& range, int min, int max) {
    if (out_) (*out_)[key] = {range[0], range[1]};
    const std::string expected = fmt::format("an integer or a [lo, hi] pair within [{}, {}]", min, max);
    if (const json* v = Value(key, expected)) {
      if (v->is_number()) {
        range[0] = range[1] = ToInteger(*v, key, min, max);
        return;
      }
      if (!v->is_array() || v->size() != 2) Fail("{}: {} must be {}, got {}", source_, Path(key), expected, v->dump());
      range[0] = ToInteger((*v)[0], key + "[0]", min, max);
      range[1] = ToInteger((*v)[1], key + "[1]", min, max);
      if (range[0] > range[1]) Fail("{}: {} must have lo <= hi, got {}", source_, Path(key), v->dump());
    }
  }
  template <size_t N, typename T>
  void Tuple(const std::string& key, std::array<T, N>& values, T min, T max) {
    if (out_) (*out_)[key] = values;
    const std::string expected = fmt::format("a list of {} numbers within [{}, {}]", N, min, max);
    if (const json* v = Value(key, expected)) {
      if (!v->is_array() || v->size() != N) Fail("{}: {} must be {}, got {}", source_, Path(key), expected, v->dump());
      for (size_t i = 0; i < N; ++i) {
        const std::string k = fmt::format("{}[{}]", key, i);
        if constexpr (std::is_integral_v<T>) values[i] = ToInteger((*v)[i], k, min, max);
        else values[i] = ToNumber((*v)[i], k, min, max);
      }
    }
  }
  void SideFaces(const std::string& key, SideFaceModel& value) {
    if (out_) (*out_)[key] = SideFaceModelName(value);
    const std::string expected = "local or centre";
    if (const json* v = Value(key, expected)) {
      if (!v->is_string() || (*v != "local" && *v != "centre"))
        Fail("{}: {} must be {}, got {}", source_, Path(key), expected, v->dump());
      value = ParseSideFaceModel(v->get<std::string>());
    }
  }
  void Distortion(const std::string& key, std::vector<double>& values) {
    if (out_) (*out_)[key] = values;
    const std::string expected = "a list of 4, 5 or 8 coefficients (k1 k2 p1 p2 [k3 [k4 k5 k6]])";
    if (const json* v = Value(key, expected)) {
      if (!v->is_array() || (v->size() != 4 && v->size() != 5 && v->size() != 8))
        Fail("{}: {} must be {}, got {}", source_, Path(key), expected, v->dump());
      values.clear();
      for (size_t i = 0; i < v->size(); ++i) values.push_back(ToNumber((*v)[i], fmt::format("{}[{}]", key, i), -10.0, 10.0));
    }
  }

 private:
  template <typename... Args>
  [[noreturn]] static void Fail(fmt::format_string<Args...> f, Args&&... args) {
    ThrowInputError(f, std::forward<Args>(args)...);
  }
  std::string Path(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }

  // The document's value for `key`, or nullptr when reading nothing or absent.
  const json* Value(const std::string& key, const std::string& expected) {
    if (!in_ || !in_->contains(key)) return nullptr;
    consumed_.insert(path_ + "/" + key);
    const json& v = in_->at(key);
    if (v.is_null()) Fail("{}: {} has no value (expected {})", source_, Path(key), expected);
    return &v;
  }
  double ToNumber(const json& v, const std::string& key, double min, double max) const {
    if (v.is_null()) Fail("{}: {} has no value (expected a number in [{}, {}])", source_, Path(key), min, max);
    if (!v.is_number()) Fail("{}: {} must be a number in [{}, {}], got {}", source_, Path(key), min, max, v.dump());
    const double x = v.get<double>();
    if (!std::isfinite(x)) Fail("{}: {} must be finite", source_, Path(key));
    if (x < min) Fail("{}: {} must be >= {}, got {}", source_, Path(key), min, x);
    if (x > max) Fail("{}: {} must be <= {}, got {}", source_, Path(key), max, x);
    return x;
  }
  int ToInteger(const json& v, const std::string& key, int min, int max) const {
    if (v.is_null()) Fail("{}: {} has no value (expected an integer in [{}, {}])", source_, Path(key), min, max);
    if (!v.is_number() || std::floor(v.get<double>()) != v.get<double>())
      Fail("{}: {} must be an integer in [{}, {}], got {}", source_, Path(key), min, max, v.dump());
    const double x = v.get<double>();
    if (x < min) Fail("{}: {} must be >= {}, got {}", source_, Path(key), min, x);
    if (x > max) Fail("{}: {} must be <= {}, got {}", source_, Path(key), max, x);
    return static_cast<int>(x);
  }
  void CheckUnknownKeys() const {
    for (const auto& item : in_->items()) {
      if (!consumed_.count(path_ + "/" + item.key())) {
        std::vector<std::string> known;
        for (const auto& k : consumed_)
          if (k.rfind(path_ + "/", 0) == 0 && k.find('/', path_.size() + 1) == std::string::npos)
            known.push_back(k.substr(path_.size() + 1));
        Fail("{}: unknown field '{}'{}", source_, Path(item.key()),
             known.empty() ? std::string() : fmt::format(" (fields read here: {})", fmt::join(known, ", ")));
      }
    }
  }

  const json* in_;
  json* out_;
  std::string source_;
  std::string path_;
  std::set<std::string> consumed_;
};

void BindCamera(CameraSpec& c, Binder& b) {
  b.Integer("width", c.width, 16, 20000);
  b.Integer("height", c.height, 16, 20000);
  b.Number("pixel_size_um", c.pixel_size_um, 0.5, 50.0);
  b.Number("focal_length_mm", c.focal_length_mm, 1.0, 500.0);
  b.Distortion("distortion", c.distortion);
  b.Tuple("principal_point_offset_px", c.principal_point_offset_px, -2000.0, 2000.0);
}

void BindScene(SceneConfig& s, Binder& b) {
  if (b.reading()) {
    // `camera` sets the given fields of both cameras; left_camera/right_camera one.
    b.Section("camera", [&] { BindCamera(s.left_camera, b); });
    b.Section("camera", [&] { BindCamera(s.right_camera, b); });
  }
  b.Section("left_camera", [&] { BindCamera(s.left_camera, b); });
  b.Section("right_camera", [&] { BindCamera(s.right_camera, b); });
  b.Section("rig", [&] {
    b.Number("baseline_mm", s.rig.baseline_mm, 1.0, 2000.0);
    b.Number("working_distance_mm", s.rig.working_distance_mm, 10.0, 5000.0);
    b.Tuple("roll_deg", s.rig.roll_deg, -45.0, 45.0);
    b.Tuple("right_aim_offset_mm", s.rig.right_aim_offset_mm, -100.0, 100.0);
  });
  b.Section("plane", [&] {
    b.Number("tilt_deg", s.plane.tilt_deg, 0.0, 30.0);
    b.Number("tilt_azimuth_deg", s.plane.tilt_azimuth_deg, -360.0, 360.0);
  });
  b.Section("lighting", [&] {
    b.Number("backlight_grey", s.lighting.backlight_grey, 0.0, 255.0);
    b.Number("vignetting", s.lighting.vignetting, 0.0, 0.9);
    b.Number("part_grey", s.lighting.part_grey, 0.0, 255.0);
    b.Number("marker_grey", s.lighting.marker_grey, 0.0, 255.0);
    b.Number("board_white_grey", s.lighting.board_white_grey, 0.0, 255.0);
    b.Number("board_black_grey", s.lighting.board_black_grey, 0.0, 255.0);
    b.Number("background_grey", s.lighting.background_grey, 0.0, 255.0);
  });
  b.Section("optics", [&] {
    b.Number("blur_sigma_px", s.optics.blur_sigma_px, 0.0, 10.0);
    b.Integer("blur_subpixels", s.optics.blur_subpixels, 1, 4);
    b.Number("noise_sigma_grey", s.optics.noise_sigma_grey, 0.0, 50.0);
  });
  b.Section("image_effects", [&] {
    ImageEffectsSpec& e = s.image_effects;
    b.RangeField("backlight_gradient", e.backlight_gradient, 0.0, 0.9);
    b.RangeField("exposure_drift", e.exposure_drift, -0.9, 0.9);
    b.IntRange("dust_specks", e.dust_specks, 0, 1000);
    b.RangeField("dust_diameter_um", e.dust_diameter_um, 1.0, 5000.0);
    b.Number("dust_touching_fraction", e.dust_touching_fraction, 0.0, 1.0);
    b.RangeField("halo_gain", e.halo_gain, 0.0, 2.0);
    b.Number("halo_width_px", e.halo_width_px, 0.1, 50.0);
    b.Number("shot_noise", e.shot_noise, 0.0, 10.0);
    b.RangeField("motion_um", e.motion_um, 0.0, 1000.0);
    b.RangeField("f_number", e.f_number, 0.0, 64.0);
    b.RangeField("focus_error_mm", e.focus_error_mm, -100.0, 100.0);
  });
  b.Section("markers", [&] {
    b.Number("inner_radius_mm", s.markers.inner_radius_mm, 0.05, 100.0);
    b.Number("outer_radius_mm", s.markers.outer_radius_mm, 0.1, 200.0);
    b.Number("inset", s.markers.inset, 0.1, 1.0);
  });
  b.Section("board", [&] {
    b.Tuple("inner_corners", s.board.inner_corners, 2, 100);
    b.Number("square_mm", s.board.square_mm, 0.1, 500.0);
    b.Number("margin_squares", s.board.margin_squares, 0.5, 10.0);
    b.Integer("poses", s.board.poses, 0, 200);
    b.Number("max_tilt_deg", s.board.max_tilt_deg, 0.0, 60.0);
    b.RangeField("distance_offset_mm", s.board.distance_offset_mm, -1000.0, 1000.0);
  });
  b.Section("part", [&] {
    PartSpec& p = s.part;
    b.RangeField("width_mm", p.width_mm, 0.5, 1000.0);
    b.RangeField("height_mm", p.height_mm, 0.5, 1000.0);
    b.RangeField("corner_radius_mm", p.corner_radius_mm, 0.0, 500.0);
    b.IntRange("holes", p.holes, 0, 20);
    b.RangeField("hole_radius_mm", p.hole_radius_mm, 0.05, 100.0);
    b.IntRange("notches", p.notches, 0, 8);
    b.RangeField("notch_size_mm", p.notch_size_mm, 0.05, 100.0);
    b.RangeField("thickness_mm", p.thickness_mm, 0.0, 5.0);
    b.RangeField("wall_height_mm", p.wall_height_mm, 0.0, 10.0);
    b.SideFaces("side_faces", p.side_faces);
    b.RangeField("bending_mm", p.bending_mm, -5.0, 5.0);
    b.RangeField("twist_mm", p.twist_mm, -5.0, 5.0);
    b.Number("random_warp_mm", p.random_warp_mm, 0.0, 5.0);
    b.RangeField("flatness_mm", p.flatness_mm, 0.0, 5.0);
    b.IntRange("burrs", p.burrs, 0, 100);
    b.RangeField("burr_size_um", p.burr_size_um, 1.0, 1000.0);
    b.Number("burr_under_rim_fraction", p.burr_under_rim_fraction, 0.0, 1.0);
    b.RangeField("waviness_um", p.waviness_um, 0.0, 100.0);
    b.RangeField("waviness_wavelength_mm", p.waviness_wavelength_mm, 0.2, 100.0);
    b.RangeField("rotation_deg", p.rotation_deg, -360.0, 360.0);
    b.Number("jitter_mm", p.jitter_mm, 0.0, 10.0);
    b.Number("jitter_deg", p.jitter_deg, 0.0, 10.0);
  });
  b.Section("dataset", [&] {
    b.Integer("parts", s.dataset.parts, 0, 100000);
    b.Integer("shots", s.dataset.shots, 1, 10000);
    b.Boolean("markers_in_part_images", s.dataset.markers_in_part_images);
  });
}

void CheckConsistency(const SceneConfig& s, const std::string& source) {
  if (s.markers.inner_radius_mm >= s.markers.outer_radius_mm)
    ThrowInputError("{}: markers.inner_radius_mm ({}) must be smaller than markers.outer_radius_mm ({})",
                    source, s.markers.inner_radius_mm, s.markers.outer_radius_mm);
  if (s.lighting.part_grey >= s.lighting.backlight_grey)
    ThrowInputError("{}: lighting.part_grey ({}) must be darker than lighting.backlight_grey ({})", source,
                    s.lighting.part_grey, s.lighting.backlight_grey);
  for (const CameraSpec* c : {&s.left_camera, &s.right_camera})
    if (c->distortion.size() != 4 && c->distortion.size() != 5 && c->distortion.size() != 8)
      ThrowInputError("{}: camera.distortion must have 4, 5 or 8 coefficients", source);
  const Range& n = s.image_effects.f_number;
  if (n.hi > 0 && n.lo < 0.7)  // faster than f/0.7 no lens is; 0 alone means no defocus
    ThrowInputError("{}: image_effects.f_number must be 0 (no defocus) or apertures from f/0.7 (got [{}, {}])", source,
                    n.lo, n.hi);
  CheckDefocusOnWholePixels(source, s.optics.blur_subpixels, n.hi > 0);
}

// cv::FileNode tree -> json, so YAML and JSON scene files share one validator.
json FileNodeToJson(const cv::FileNode& node) {
  if (node.isMap()) {
    json out = json::object();
    for (const cv::FileNode& child : node) out[child.name()] = FileNodeToJson(child);
    return out;
  }
  if (node.isSeq()) {
    json out = json::array();
    for (const cv::FileNode& child : node) out.push_back(FileNodeToJson(child));
    return out;
  }
  if (node.isInt()) return static_cast<int>(node);
  if (node.isReal()) return static_cast<double>(node);
  if (node.isString()) {
    const std::string s = static_cast<std::string>(node);
    if (s == "true" || s == "false") return s == "true";
    // OpenCV's YAML reader turns an empty value into "..."; YAML's null spellings too.
    if (s.empty() || s == "..." || s == "~" || s == "null") return nullptr;
    return s;
  }
  return nullptr;  // empty value
}

}  // namespace

std::vector<std::string> ScenePresetNames() { return {"paper", "compact"}; }

SceneConfig ScenePreset(const std::string& name) {
  SceneConfig s;  // the struct defaults, made slightly imperfect as a real rig is
  s.name = name;
  s.left_camera.principal_point_offset_px = {2.0, -1.5};
  s.right_camera.principal_point_offset_px = {-3.0, 2.5};
  s.rig.roll_deg = {0.2, -0.15};
  s.plane.tilt_deg = 2.0;
  s.plane.tilt_azimuth_deg = 20.0;
  if (name == "paper") return s;
  if (name == "compact") {
    for (CameraSpec* c : {&s.left_camera, &s.right_camera}) {
      c->width = 1920;
      c->height = 1200;
      c->pixel_size_um = 3.45;
      c->focal_length_mm = 12.0;
      c->distortion = {-0.21, 0.15, 0.0004, -0.0003, -0.03};
    }
    s.right_camera.principal_point_offset_px = {6.0, -4.0};
    s.rig.baseline_mm = 40.0;
    s.rig.working_distance_mm = 150.0;
    s.rig.roll_deg = {0.4, -0.3};
    s.plane.tilt_deg = 3.0;
    s.plane.tilt_azimuth_deg = 35.0;
    s.optics.blur_sigma_px = 0.8;
    s.optics.noise_sigma_grey = 2.5;
    s.board.square_mm = 4.0;
    s.markers.inner_radius_mm = 1.5;
    s.markers.outer_radius_mm = 3.5;
    return s;
  }
  ThrowInputError("unknown preset '{}' (expected one of: {})", name, fmt::join(ScenePresetNames(), ", "));
}

void CheckDefocusOnWholePixels(const std::string& source, int blur_subpixels, bool defocus) {
  if (defocus && blur_subpixels != 1)
    ThrowInputError("{}: optics.blur_subpixels {} with image_effects.f_number: the varying blur is rendered on whole "
                    "pixels only (expected blur_subpixels 1)",
                    source, blur_subpixels);
}

SceneConfig ApplySceneDocument(SceneConfig base, const json& doc, const std::string& source) {
  if (!doc.is_object()) ThrowInputError("{}: a scene file must be a mapping of sections, got {}", source, doc.dump());
  json body = doc;
  body.erase("preset");
  body.erase("name");  // written by SceneToJson; the file's own name is used
  Binder reader(&body, nullptr, source);
  BindScene(base, reader);
  reader.Finish();
  CheckConsistency(base, source);
  return base;
}

SceneConfig LoadSceneFile(const std::filesystem::path& path) {
  const std::string source = path.string();
  std::ifstream in(path);
  if (!in) ThrowInputError("{}: cannot open scene file (expected a readable YAML or JSON file)", source);
  std::stringstream buffer;
  buffer << in.rdbuf();
  const std::string text = buffer.str();
  json doc;
  const std::string ext = path.extension().string();
  if (ext == ".json") {
    try {
      doc = json::parse(text);
    } catch (const json::exception& e) {  // parse_error, and out_of_range for numbers like 1e999
      ThrowInputError("{}: not valid JSON ({})", source, e.what());
    }
  } else {
    if (const auto why = FileStorageLimitExceeded(text, /*yaml=*/true)) ThrowInputError("{}: not valid YAML ({})", source, *why);
    try {
      std::string yaml = text;
      if (yaml.rfind("%YAML", 0) != 0) yaml = (yaml.rfind("---", 0) == 0 ? "%YAML:1.0\n" : "%YAML:1.0\n---\n") + yaml;
      cv::FileStorage fs(yaml, cv::FileStorage::READ | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_YAML);
      doc = FileNodeToJson(fs.root());
    } catch (const cv::Exception& e) {
      ThrowInputError("{}: not valid YAML ({})", source, e.msg);
    } catch (const std::length_error& e) {  // OpenCV's YAML parser on some malformed files (fuzz/)
      ThrowInputError("{}: not valid YAML ({})", source, e.what());
    }
  }
  std::string preset = "paper";
  if (doc.is_object() && doc.contains("preset")) {
    if (!doc["preset"].is_string()) ThrowInputError("{}: preset must be a preset name (expected one of: {})", source, fmt::join(ScenePresetNames(), ", "));
    preset = doc["preset"].get<std::string>();
  }
  SceneConfig scene = ScenePreset(preset);
  scene.name = path.stem().string();
  return ApplySceneDocument(scene, doc, source);
}

json SceneToJson(const SceneConfig& scene) {
  json out = json::object();
  SceneConfig copy = scene;
  Binder writer(nullptr, &out, "");
  BindScene(copy, writer);
  out["name"] = scene.name;
  return out;
}

}  // namespace flatscan
