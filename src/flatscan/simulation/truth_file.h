#pragma once
// truth.json: what the parts of a simulated dataset really are, computed from their
// geometry, never from the images (docs/simulator.md). One schema for every dataset
// folder the simulator writes (`flatscan simulate`, the demo, `evaluate --save-worst`):
//
//   seed, scene, frame ("camera 1 (left), mm")
//   plane     {normal, point, markers}            the true support plane, camera-1 frame
//   parts     [{id, flatness_mm, lsq_pv_mm, minzone_mm,
//               thickness_mm      the sheet,
//               side_height_mm    the side face's height: the sheet plus any folded wall,
//                                 what `flatscan inspect --thickness` wants,
//               geometry, shots: [{id, left, right, rotation_deg, position_mm,
//                                  cam1_from_part {rotation, translation_mm}}],
//               rim_part_mm, rim_cam1_mm (the first shot's)}]
// Image paths are relative to the dataset folder.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "flatscan/geometry/rigid3.h"
#include "flatscan/simulation/dataset.h"

namespace flatscan {

// The id and image files (relative to the dataset folder) of one shot.
struct ShotFiles {
  std::string id, left, right;
};

// The "parts" entry of one part whose shots were written as `files` (one per shot).
nlohmann::json PartTruthJson(const Station& station, const std::string& id, const SimulatedPart& part,
                             const std::vector<ShotFiles>& files);
// The whole file, around the parts' entries.
nlohmann::json TruthFileJson(const Station& station, uint64_t seed, nlohmann::json parts);

// A pose as {"rotation": 3x3 rows, "translation_mm": [x, y, z]}.
nlohmann::json PoseToJson(const Rigid3d& pose);

struct TruthShot {
  std::string id, left, right;  // image paths resolved against the dataset folder
  double rotation_deg = 0;
  Rigid3d cam1_from_part;
};
struct TruthPart {
  std::string id;
  double flatness_mm = 0, lsq_pv_mm = 0, minzone_mm = 0;
  double thickness_mm = 0, side_height_mm = 0;
  std::vector<TruthShot> shots;
};
// Reads `dir`/truth.json; throws InputError naming the file and the key when it is
// missing or malformed.
std::vector<TruthPart> ReadTruthFile(const std::filesystem::path& dir);

// A folder holding the given part pairs (`id`_left.png, `id`_right.png, one shot each),
// pairs.csv and truth.json, so that they can be inspected again with `flatscan inspect`
// (for example a study's worst parts). Built as <dir>.partial-PID and renamed.
struct PartPair {
  std::string id;
  SimulatedPart part;  // geometry and its one shot
  cv::Mat1b left, right;
};
void WritePartPairs(const std::filesystem::path& dir, const Station& station, uint64_t seed,
                    const std::vector<PartPair>& pairs);

}  // namespace flatscan
