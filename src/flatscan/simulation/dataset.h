#pragma once
// `flatscan simulate`: renders a whole inspection dataset into a folder.
//
//   rig.yml                   the true rig (docs/conventions.md format)
//   plane_true.yml            the true support plane (camera-1 frame)
//   scene.json                the fully resolved scene parameters
//   calib/left_NN.png ...     front-lit chessboard pairs; calib/board.json: pattern,
//                             inner corners, square size and each view's true pose
//   markers/left.png, right.png   the empty backlight with the 4 ring markers
//   parts/part_III[_shot_SS]_{left,right}.png   backlit part pairs
//   pairs.csv                 id,left,right for every part pair (paths relative to it)
//   truth.json                plane, markers, and per part its flatness values,
//                             geometry, warp, poses and bottom rim
// The folder appears only when complete (built as <dir>.partial-PID, then renamed).
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "flatscan/simulation/image_defects.h"
#include "flatscan/simulation/part_model.h"
#include "flatscan/simulation/station.h"

namespace flatscan {

struct SimulateOptions {
  SceneConfig scene;
  uint64_t seed = 1;
  std::filesystem::path output_dir;
  bool replace_any_folder = false;  // replace output_dir also if flatscan did not write it
  bool calibration_images = true;
  bool marker_images = true;
};

struct PlacedShot {
  double rotation_deg = 0.0;
  Eigen::Vector2d position = Eigen::Vector2d::Zero();
  PartTruth truth;
};

struct SimulatedPart {
  int id = 0;
  PartGeometry geometry;
  std::vector<PlacedShot> shots;
};

struct SimulateSummary {
  std::filesystem::path output_dir;
  int calibration_pairs = 0;
  int parts = 0;
  int part_pairs = 0;
  std::vector<std::string> files;  // relative to output_dir
};

// Samples a part and `shots` placements (the first at a random pose inside the
// common field of view, the rest jittered by part.jitter_mm / jitter_deg). Throws
// InputError when the part cannot fit in the common field of view.
SimulatedPart SampleSimulatedPart(const Station& station, int id, Random& rng);
// The same for a given part geometry (placement and shots only).
SimulatedPart PlaceSimulatedPart(const Station& station, int id, PartGeometry geometry, Random& rng);

// One 8-bit image of one camera, with the pair's image defects (simulation/image_defects.h;
// none by default).
cv::Mat1b RenderPartImage(const Station& station, RigSide camera, const PartGeometry& geometry,
                          const Rigid3d& support_from_part, uint64_t noise_seed, bool with_markers,
                          const ImageDefects& defects = {});
cv::Mat1b RenderMarkerImage(const Station& station, RigSide camera, uint64_t noise_seed);
cv::Mat1b RenderBoardImage(const Station& station, RigSide camera, const Rigid3d& support_from_board,
                           uint64_t noise_seed);
// Random board poses fully visible in both cameras (board frame: origin at the
// first square's outer corner, x along the inner-corner columns, z toward the cameras).
std::vector<Rigid3d> SampleBoardPoses(const Station& station, Random& rng);

SimulateSummary SimulateDataset(const SimulateOptions& options,
                                const std::function<void(const std::string&)>& progress = {});

}  // namespace flatscan
