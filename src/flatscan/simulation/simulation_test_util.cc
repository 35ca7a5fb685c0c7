#include "flatscan/simulation/simulation_test_util.h"

#include <tuple>

namespace flatscan::testing {

std::pair<cv::Mat1b, cv::Mat1b> RenderPair(const Station& station, const PartGeometry& geometry,
                                           const Rigid3d& support_from_part, uint64_t seed) {
  return {RenderPartImage(station, RigSide::kLeft, geometry, support_from_part, seed, false),
          RenderPartImage(station, RigSide::kRight, geometry, support_from_part, seed + 1, false)};
}

RenderedPair RenderRandomPart(const Station& station, int id, Random& rng, uint64_t seed) {
  RenderedPair r;
  r.part = SampleSimulatedPart(station, id, rng);
  std::tie(r.left, r.right) = RenderPair(station, r.part.geometry, r.part.shots[0].truth.support_from_part, seed);
  return r;
}

}  // namespace flatscan::testing
