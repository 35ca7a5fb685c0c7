#pragma once
// Test helpers: simulated part pairs rendered in memory (the digital twin's truth for
// the stage tests of boundary, reconstruction and inspection).
#include <cstdint>
#include <utility>

#include <opencv2/core.hpp>

#include "flatscan/simulation/dataset.h"

namespace flatscan::testing {

struct RenderedPair {
  SimulatedPart part;  // geometry and its one shot (pose and truth)
  cv::Mat1b left, right;
};

// Both cameras' images of `geometry` at `support_from_part`, noise seeds `seed` (left)
// and `seed` + 1 (right), no markers.
std::pair<cv::Mat1b, cv::Mat1b> RenderPair(const Station& station, const PartGeometry& geometry,
                                           const Rigid3d& support_from_part, uint64_t seed);
// A part drawn from the station's scene at a random pose, rendered.
RenderedPair RenderRandomPart(const Station& station, int id, Random& rng, uint64_t seed);

}  // namespace flatscan::testing
