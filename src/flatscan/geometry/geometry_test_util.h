#pragma once
// Test helpers for camera models.
#include <vector>

#include <Eigen/Core>

#include "flatscan/geometry/camera.h"

namespace flatscan::testing {

// Points on a (steps + 1) x (steps + 1) grid covering the whole raw image, its outer
// corners (-0.5, -0.5) and (width - 0.5, height - 0.5) included.
std::vector<Eigen::Vector2d> GridOverImage(const Camera& camera, int steps);

}  // namespace flatscan::testing
