#include "flatscan/station/recipe.h"

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include <Eigen/Eigenvalues>
#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <yaml-cpp/yaml.h>

#include "flatscan/util/error.h"
#include "flatscan/util/sha256.h"

namespace flatscan {
namespace {

const std::set<std::string> kTopKeys = {"name",         "thickness_mm", "tolerance_mm",  "rig",        "plane",
                                        "guard_band_mm", "rig_sha256",  "plane_sha256",  "part_length_mm",
                                        "side_faces",   "exposure",     "archive",       "camera"};
const std::set<std::string> kExposureKeys = {"min_backlight_grey", "max_saturated_fraction", "max_blur_sigma_px"};
const std::set<std::string> kCameraKeys = {"exposure_us", "gain_db"};
const std::set<std::string> kArchiveKeys = {"keep_pass_every", "quota_mb", "fail_retention_days"};

// Reads one mapping of a recipe, with messages "<file>: <key>: expected ..., found ...".
class RecipeReader {
 public:
  RecipeReader(std::string file, YAML::Node map, std::string prefix, const std::set<std::string>& allowed)
      : file_(std::move(file)), map_(std::move(map)), prefix_(std::move(prefix)) {
    if (!map_.IsMap()) Fail("", "a mapping of keys to values", Shown(map_));
    std::set<std::string> seen;
    for (const auto& item : map_) {
      if (!item.first.IsScalar()) Fail("", "keys that are names", "a key that is " + Shown(item.first));
      const std::string key = item.first.Scalar();
      if (!allowed.count(key))
        Fail(key, fmt::format("one of the recipe's keys ({})", fmt::join(allowed, ", ")), "an unknown key");
      if (!seen.insert(key).second) Fail(key, "each key once", "it twice (which one holds?)");
    }
  }
  bool Has(const std::string& key) const { return bool(map_[key]); }
  YAML::Node Node(const std::string& key) const { return map_[key]; }
  std::string Path(const std::string& key) const { return prefix_ + key; }

  std::string String(const std::string& key) const {
    const YAML::Node v = Required(key, "a string");
    if (!v.IsScalar() || v.Scalar().empty()) Fail(key, "a non-empty string", Shown(v));
    return v.Scalar();
  }
  // A number in [lo, hi] (in (lo, hi] when `open_low`).
  double Number(const std::string& key, double lo, double hi, bool open_low, const char* unit) const {
    const YAML::Node v = Required(key, "a number");
    const std::string expected = fmt::format("a number in {}{}, {}] {}", open_low ? "(" : "[", lo, hi, unit);
    double x = NAN;
    if (!v.IsScalar() || !YAML::convert<double>::decode(v, x) || !std::isfinite(x)) Fail(key, expected, Shown(v));
    if (x < lo || x > hi || (open_low && x == lo)) Fail(key, expected, Shown(v));
    return x;
  }
  double NumberOr(const std::string& key, double fallback, double lo, double hi, bool open_low, const char* unit) const {
    return Has(key) ? Number(key, lo, hi, open_low, unit) : fallback;
  }
  std::string Sha256Or(const std::string& key) const {
    if (!Has(key)) return "";
    const std::string s = String(key);
    if (!IsSha256Hex(s)) Fail(key, "64 lower-case hex digits (a SHA-256)", Shown(Node(key)));
    return s;
  }
  [[noreturn]] void Fail(const std::string& key, const std::string& expected, const std::string& found) const {
    ThrowInputError("{}: {}: expected {}, found {}", file_, key.empty() ? prefix_ + "(top level)" : Path(key),
                    expected, found);
  }

 private:
  YAML::Node Required(const std::string& key, const char* expected) const {
    const YAML::Node v = map_[key];
    if (!v) Fail(key, expected, "nothing (the key is missing)");
    return v;
  }
  static std::string Shown(const YAML::Node& v) {
    if (v.IsScalar()) return fmt::format("'{}'", v.Scalar());
    if (v.IsNull()) return "an empty value";
    return v.IsMap() ? "a mapping" : "a list";
  }
  std::string file_;
  YAML::Node map_;
  std::string prefix_;
};

YAML::Node ParseYaml(const std::filesystem::path& path, const std::string& text) {
  try {
    return YAML::Load(text);
  } catch (const YAML::Exception& e) {
    ThrowInputError("{}: line {}: not valid YAML ({})", path.string(), e.mark.line + 1, e.msg);
  }
}

std::string ReadText(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) ThrowInputError("{}: no such recipe file", path.string());
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  if (!in) ThrowInputError("{}: cannot read the recipe file", path.string());
  return s.str();
}

std::string CheckedName(const RecipeReader& top) {
  const std::string name = top.String("name");
  if (name.size() > 64 || name.find_first_not_of("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_.-") !=
                              std::string::npos)
    top.Fail("name", "1-64 characters from [A-Za-z0-9_.-]", fmt::format("'{}'", name));
  return name;
}

std::filesystem::path Resolved(const std::filesystem::path& recipe, const std::string& file) {
  const std::filesystem::path p(file);
  return (p.is_absolute() ? p : recipe.parent_path() / p).lexically_normal();
}

LengthRange ReadLengthRange(const RecipeReader& top, const std::string& key) {
  const YAML::Node v = top.Node(key);
  const char* expected = "a list [min, max] of two lengths in mm, 0 <= min < max";
  LengthRange r;
  if (!v.IsSequence() || v.size() != 2 || !YAML::convert<double>::decode(v[0], r.min_mm) ||
      !YAML::convert<double>::decode(v[1], r.max_mm) || !std::isfinite(r.min_mm) || !std::isfinite(r.max_mm) ||
      r.min_mm < 0 || r.max_mm <= r.min_mm)
    top.Fail(key, expected, v.IsSequence() ? fmt::format("a list of {}", v.size()) : "something else");
  return r;
}

void ReadExposure(const std::string& file, const YAML::Node& node, ImageAcceptance& a) {
  const RecipeReader r(file, node, "exposure.", kExposureKeys);
  a.min_backlight_grey = r.NumberOr("min_backlight_grey", a.min_backlight_grey, 1, 255, false, "grey levels");
  a.max_saturated_fraction = r.NumberOr("max_saturated_fraction", a.max_saturated_fraction, 0, 1, false, "");
  a.max_blur_sigma_px = r.NumberOr("max_blur_sigma_px", a.max_blur_sigma_px, 0, 6, true, "px");
}

ArchivePolicy ReadArchive(const std::string& file, const YAML::Node& node) {
  const RecipeReader r(file, node, "archive.", kArchiveKeys);
  ArchivePolicy p;
  const double every = r.NumberOr("keep_pass_every", p.keep_pass_every, 0, 1e6, false, "pairs");
  if (every != std::floor(every)) r.Fail("keep_pass_every", "a whole number of pairs", fmt::format("'{}'", every));
  p.keep_pass_every = static_cast<int>(every);
  p.quota_mb = r.NumberOr("quota_mb", p.quota_mb, 0, 1e9, true, "MB");
  p.fail_retention_days = r.NumberOr("fail_retention_days", p.fail_retention_days, 0, 36500, false, "days");
  return p;
}

CameraSettings ReadCamera(const std::string& file, const YAML::Node& node) {
  const RecipeReader r(file, node, "camera.", kCameraKeys);
  CameraSettings c;
  if (r.Has("exposure_us")) c.exposure_us = r.Number("exposure_us", 1, 1e7, false, "us");
  if (r.Has("gain_db")) c.gain_db = r.Number("gain_db", 0, 48, false, "dB");
  return c;
}

std::string CheckedHash(const std::filesystem::path& file, const char* key, const std::string& pin,
                        const Recipe& recipe) {
  const std::string actual = Sha256HexOfFile(file);
  if (!pin.empty() && actual != pin)
    ThrowInputError("{}: {}: the file {} has SHA-256 {}, the recipe pins {} (the file changed since the recipe "
                    "was written: check it, then update the pin)",
                    recipe.file.string(), key, file.string(), actual, pin);
  return actual;
}

}  // namespace

Recipe ReadRecipe(const std::filesystem::path& path) {
  const std::string text = ReadText(path);
  const std::string file = path.string();
  const RecipeReader top(file, ParseYaml(path, text), "", kTopKeys);
  Recipe r;
  r.file = path;
  r.sha256 = Sha256Hex(text);
  r.name = CheckedName(top);
  r.params.thickness_mm = top.Number("thickness_mm", 0, 5, true, "mm");
  r.spec.tolerance_mm = top.Number("tolerance_mm", 0, 5, true, "mm");
  r.spec.guard_band_mm = top.NumberOr("guard_band_mm", 0, 0, 1, false, "mm");
  r.rig_file = Resolved(path, top.String("rig"));
  r.plane_file = Resolved(path, top.String("plane"));
  r.rig_sha256_pin = top.Sha256Or("rig_sha256");
  r.plane_sha256_pin = top.Sha256Or("plane_sha256");
  if (top.Has("part_length_mm")) r.part_length_mm = ReadLengthRange(top, "part_length_mm");
  if (top.Has("side_faces")) {
    try {
      r.params.side_faces = ParseSideFaceModel(top.String("side_faces"));
    } catch (const InputError& e) {
      top.Fail("side_faces", "local, centre or support", fmt::format("'{}'", top.String("side_faces")));
    }
  }
  if (top.Has("exposure")) ReadExposure(file, top.Node("exposure"), r.params.acceptance);
  if (top.Has("archive")) r.archive = ReadArchive(file, top.Node("archive"));
  if (top.Has("camera")) r.camera = ReadCamera(file, top.Node("camera"));
  return r;
}

LoadedRecipe LoadRecipe(const std::filesystem::path& path) {
  LoadedRecipe loaded{ReadRecipe(path), {}, {}, {}};
  const Recipe& r = loaded.recipe;
  for (const auto& [key, file] : {std::pair{"rig", r.rig_file}, std::pair{"plane", r.plane_file}})
    if (!std::filesystem::is_regular_file(file))
      ThrowInputError("{}: {}: no such file {}", path.string(), key, file.string());
  InspectionInputs& in = loaded.inputs;
  in.rig_file = r.rig_file.string();
  in.plane_file = r.plane_file.string();
  in.rig_sha256 = CheckedHash(r.rig_file, "rig_sha256", r.rig_sha256_pin, r);
  in.plane_sha256 = CheckedHash(r.plane_file, "plane_sha256", r.plane_sha256_pin, r);
  loaded.rig = ReadRigFile(r.rig_file);
  const PlaneFile plane_file = ReadPlaneFile(r.plane_file);
  if (!plane_file.rig_sha256.empty() && plane_file.rig_sha256 != in.rig_sha256)
    ThrowInputError("{}: plane: {} was calibrated with another rig file (rig_sha256 {}...) than the recipe's rig {} "
                    "(SHA-256 {}...): recalibrate the plane with this rig (`flatscan calibrate-plane`)",
                    path.string(), r.plane_file.string(), plane_file.rig_sha256.substr(0, 12), r.rig_file.string(),
                    in.rig_sha256.substr(0, 12));
  in.plane_rig = CheckPlaneAgainstRig(plane_file, r.plane_file, loaded.rig, r.rig_file, in.rig_sha256, false);
  if (in.plane_rig == PlaneRigMatch::kUnknown)
    spdlog::warn("{}: the plane file {} does not say which rig it was calibrated with; recalibrate it with "
                 "`flatscan calibrate-plane` to have it checked",
                 path.string(), r.plane_file.string());
  loaded.plane = plane_file.plane;
  return loaded;
}

std::string DescribeRecipe(const LoadedRecipe& loaded) {
  const Recipe& r = loaded.recipe;
  const InspectionInputs& in = loaded.inputs;
  const ImageAcceptance& a = r.params.acceptance;
  std::string s = fmt::format("recipe {} ({}, sha256 {})\n", r.name, r.file.string(), r.sha256);
  s += fmt::format("  measures with rig {} (sha256 {}{})\n", in.rig_file, in.rig_sha256,
                   r.rig_sha256_pin.empty() ? ", not pinned" : ", pinned");
  s += fmt::format("           and plane {} (sha256 {}{}; calibrated with this rig: {})\n", in.plane_file,
                   in.plane_sha256, r.plane_sha256_pin.empty() ? ", not pinned" : ", pinned",
                   in.plane_rig == PlaneRigMatch::kMatches ? "yes" : "the plane file does not say");
  s += fmt::format("  side faces {:.3f} mm high, standing {}\n", r.params.thickness_mm,
                   SideFaceModelName(r.params.side_faces));
  s += fmt::format("  judges: fail when flatness > {:.4f} mm; marginal within {:.4f} mm of it (or the part's U)\n",
                   r.spec.tolerance_mm, r.spec.guard_band_mm);
  s += r.part_length_mm ? fmt::format("  a part whose length is outside [{:.2f}, {:.2f}] mm is not measured\n",
                                      r.part_length_mm->min_mm, r.part_length_mm->max_mm)
                        : std::string("  any part length is accepted (no part_length_mm)\n");
  s += fmt::format("  images: backlight at least grey {:.0f}, at most {:.0f}% saturated, edge blur at most {:.2f} px\n",
                   a.min_backlight_grey, 100 * a.max_saturated_fraction, a.max_blur_sigma_px);
  const auto setting = [](const std::optional<double>& v, const char* unit) {
    return v ? fmt::format("{:g} {}", *v, unit) : std::string("the camera's own");
  };
  s += fmt::format("  cameras (--source cameras:..): exposure {}, gain {}\n", setting(r.camera.exposure_us, "us"),
                   setting(r.camera.gain_db, "dB"));
  s += fmt::format("  archive (--archive): every fail and not-measured pair, {}; quota {:.0f} MB; fails kept at "
                   "least {:.0f} days\n",
                   r.archive.keep_pass_every == 0 ? std::string("no pass pairs")
                                                  : fmt::format("one pass pair in {}", r.archive.keep_pass_every),
                   r.archive.quota_mb, r.archive.fail_retention_days);
  return s;
}

double PartLengthMm(const InspectionResult& result) {
  if (result.points.size() < 2) return 0;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const InspectedPoint& p : result.points) mean += p.cam1;
  mean /= double(result.points.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const InspectedPoint& p : result.points) scatter += (p.cam1 - mean) * (p.cam1 - mean).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(scatter);
  const Eigen::Vector3d axis = solver.eigenvectors().col(2);  // largest eigenvalue last
  double lo = INFINITY, hi = -INFINITY;
  for (const InspectedPoint& p : result.points) {
    const double t = axis.dot(p.cam1 - mean);
    lo = std::min(lo, t);
    hi = std::max(hi, t);
  }
  return hi - lo;
}

std::optional<std::string> WrongPartReason(const Recipe& recipe, const InspectionResult& result) {
  if (!recipe.part_length_mm) return std::nullopt;
  const double length = PartLengthMm(result);
  const LengthRange& range = *recipe.part_length_mm;
  if (length >= range.min_mm && length <= range.max_mm) return std::nullopt;
  return fmt::format("wrong part: its length is {:.2f} mm, recipe '{}' expects {:.2f}-{:.2f} mm (part_length_mm); "
                     "check the part in the nest and the active recipe",
                     length, recipe.name, range.min_mm, range.max_mm);
}

}  // namespace flatscan
