#include "flatscan/simulation/truth_file.h"

#include <cmath>
#include <fstream>

#include "flatscan/io/atomic_output.h"
#include "flatscan/io/image_io.h"
#include "flatscan/io/pairs_csv.h"
#include "flatscan/util/error.h"

namespace flatscan {
namespace {

using nlohmann::json;

// Rim samples rounded to 1 nm: the file stays readable and the truth is exact enough.
json PointsJson(const std::vector<Eigen::Vector3d>& points) {
  json out = json::array();
  for (const Eigen::Vector3d& p : points)
    out.push_back({std::round(p.x() * 1e6) / 1e6, std::round(p.y() * 1e6) / 1e6, std::round(p.z() * 1e6) / 1e6});
  return out;
}

json VectorJson(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

// Reads truth.json's keys with messages naming the file and the key.
class TruthReader {
 public:
  explicit TruthReader(std::string file) : file_(std::move(file)) {}
  const json& At(const json& j, const char* key, const char* expected) const {
    if (!j.is_object() || !j.contains(key))
      ThrowInputError("{}: missing key '{}' (expected {})", file_, key, expected);
    return j.at(key);
  }
  double Number(const json& j, const char* key) const {
    const json& v = At(j, key, "a number");
    if (!v.is_number()) ThrowInputError("{}: key '{}' must be a number, found {}", file_, key, v.dump());
    return v.get<double>();
  }
  std::string String(const json& j, const char* key) const {
    const json& v = At(j, key, "a string");
    if (!v.is_string()) ThrowInputError("{}: key '{}' must be a string, found {}", file_, key, v.dump());
    return v.get<std::string>();
  }
  const json& Array(const json& j, const char* key) const {
    const json& v = At(j, key, "an array");
    if (!v.is_array()) ThrowInputError("{}: key '{}' must be an array, found {}", file_, key, v.dump());
    return v;
  }
  Rigid3d Pose(const json& j, const char* key) const {
    const json& v = At(j, key, "a pose {rotation, translation_mm}");
    const json& r = Array(v, "rotation");
    const json& t = Array(v, "translation_mm");
    if (r.size() != 3 || t.size() != 3) ThrowInputError("{}: key '{}' must hold a 3x3 rotation and 3 translations", file_, key);
    Rigid3d pose;
    for (int i = 0; i < 3; ++i) {
      if (!r[i].is_array() || r[i].size() != 3) ThrowInputError("{}: key '{}.rotation' must be 3 rows of 3", file_, key);
      for (int k = 0; k < 3; ++k) pose.rotation(i, k) = r[i][k].get<double>();
      pose.translation(i) = t[i].get<double>();
    }
    return pose;
  }

 private:
  std::string file_;
};

}  // namespace

json PoseToJson(const Rigid3d& pose) {
  json r = json::array();
  for (int i = 0; i < 3; ++i) r.push_back({pose.rotation(i, 0), pose.rotation(i, 1), pose.rotation(i, 2)});
  return {{"rotation", r}, {"translation_mm", VectorJson(pose.translation)}};
}

json PartTruthJson(const Station& st, const std::string& id, const SimulatedPart& part,
                   const std::vector<ShotFiles>& files) {
  const PartTruth& t0 = part.shots.front().truth;
  json pj;
  pj["id"] = id;
  pj["flatness_mm"] = t0.flatness_mm;
  pj["lsq_pv_mm"] = t0.lsq_pv_mm;
  pj["minzone_mm"] = t0.minzone_mm;
  pj["thickness_mm"] = part.geometry.thickness;
  pj["side_height_mm"] = part.geometry.SideHeight();
  pj["geometry"] = PartGeometryToJson(part.geometry);
  pj["shots"] = json::array();
  for (size_t s = 0; s < part.shots.size(); ++s) {
    const PlacedShot& shot = part.shots[s];
    pj["shots"].push_back({{"id", files[s].id},
                           {"left", files[s].left},
                           {"right", files[s].right},
                           {"rotation_deg", shot.rotation_deg},
                           {"position_mm", {shot.position.x(), shot.position.y()}},
                           {"cam1_from_part", PoseToJson(st.cam1_from_support * shot.truth.support_from_part)}});
  }
  // Bottom rim in the camera-1 frame for the first shot (other shots: apply their
  // cam1_from_part to rim_part_mm).
  const std::vector<Eigen::Vector3d> rim_part = part.geometry.SampleRim(0.1);
  std::vector<Eigen::Vector3d> rim_cam1;
  const Rigid3d cam1_from_part = st.cam1_from_support * t0.support_from_part;
  for (const Eigen::Vector3d& p : rim_part) rim_cam1.push_back(cam1_from_part * p);
  pj["rim_part_mm"] = PointsJson(rim_part);
  pj["rim_cam1_mm"] = PointsJson(rim_cam1);
  return pj;
}

json TruthFileJson(const Station& st, uint64_t seed, json parts) {
  json truth;
  truth["seed"] = seed;
  truth["scene"] = st.scene.name;
  truth["frame"] = "camera 1 (left), mm";
  truth["plane"] = {{"normal", VectorJson(st.plane.normal)}, {"point", VectorJson(st.plane.point)},
                    {"markers", PointsJson(st.plane.markers)}};
  truth["parts"] = std::move(parts);
  return truth;
}

std::vector<TruthPart> ReadTruthFile(const std::filesystem::path& dir) {
  const std::filesystem::path path = dir / "truth.json";
  const TruthReader in(path.string());
  std::ifstream file(path);
  if (!file) ThrowInputError("{}: cannot open the dataset's truth (expected the truth.json of a simulated dataset)", path.string());
  json truth;
  try {
    truth = json::parse(file);
  } catch (const json::exception& e) {
    ThrowInputError("{}: not JSON ({})", path.string(), e.what());
  }
  std::vector<TruthPart> parts;
  for (const json& pj : in.Array(truth, "parts")) {
    TruthPart p;
    p.id = in.String(pj, "id");
    p.flatness_mm = in.Number(pj, "flatness_mm");
    p.lsq_pv_mm = in.Number(pj, "lsq_pv_mm");
    p.minzone_mm = in.Number(pj, "minzone_mm");
    p.thickness_mm = in.Number(pj, "thickness_mm");
    p.side_height_mm = in.Number(pj, "side_height_mm");
    for (const json& sj : in.Array(pj, "shots"))
      p.shots.push_back({in.String(sj, "id"), (dir / in.String(sj, "left")).string(),
                         (dir / in.String(sj, "right")).string(), in.Number(sj, "rotation_deg"),
                         in.Pose(sj, "cam1_from_part")});
    parts.push_back(std::move(p));
  }
  return parts;
}

void WritePartPairs(const std::filesystem::path& dir, const Station& station, uint64_t seed,
                    const std::vector<PartPair>& pairs) {
  StagedDirectory staged(dir);
  std::vector<PairEntry> csv;
  json parts = json::array();
  for (const PartPair& p : pairs) {
    const ShotFiles files{p.id, p.id + "_left.png", p.id + "_right.png"};
    WriteImage((staged.path() / files.left).string(), p.left);
    WriteImage((staged.path() / files.right).string(), p.right);
    csv.push_back({p.id, files.left, files.right, p.part.geometry.SideHeight(), {}});
    parts.push_back(PartTruthJson(station, p.id, p.part, {files}));
  }
  WriteTextFileAtomically(staged.path() / "pairs.csv", PairsCsvText(csv));
  WriteTextFileAtomically(staged.path() / "truth.json", TruthFileJson(station, seed, std::move(parts)).dump(1) + "\n");
  staged.Commit();
}

}  // namespace flatscan
