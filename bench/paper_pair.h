#pragma once
// One paper-preset part (seed 7) rendered by both cameras (2 x 2592 x 1944), and the
// recipe that measures it: the pair the station and camera benchmarks feed.
#include <opencv2/core.hpp>

#include "flatscan/simulation/dataset.h"
#include "flatscan/station/recipe.h"

namespace flatscan {

struct PaperPair {
  cv::Mat1b left, right;
  LoadedRecipe recipe;
};

inline PaperPair RenderPaperPair() {
  const Station station = BuildStation(ScenePreset("paper"));
  Random rng(7);
  const SimulatedPart part = SampleSimulatedPart(station, 0, rng);
  const auto pose = part.shots[0].truth.support_from_part;
  PaperPair pair;
  pair.left = RenderPartImage(station, RigSide::kLeft, part.geometry, pose, 1, false);
  pair.right = RenderPartImage(station, RigSide::kRight, part.geometry, pose, 2, false);
  pair.recipe.recipe.name = "bench";
  pair.recipe.recipe.params.thickness_mm = part.geometry.SideHeight();
  pair.recipe.rig = station.rig;
  pair.recipe.plane = station.plane;
  return pair;
}

}  // namespace flatscan
