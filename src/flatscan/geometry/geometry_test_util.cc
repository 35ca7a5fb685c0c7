#include "flatscan/geometry/geometry_test_util.h"

namespace flatscan::testing {

std::vector<Eigen::Vector2d> GridOverImage(const Camera& camera, int steps) {
  std::vector<Eigen::Vector2d> out;
  for (int j = 0; j <= steps; ++j)
    for (int i = 0; i <= steps; ++i)
      out.emplace_back(-0.5 + camera.width * i / double(steps), -0.5 + camera.height * j / double(steps));
  return out;
}

}  // namespace flatscan::testing
