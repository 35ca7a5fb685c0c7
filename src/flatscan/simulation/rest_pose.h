#pragma once
// How a warped part rests on a flat support under gravity.
//
// The part touches the support at the three vertices of its lower convex hull whose
// facet is crossed by the vertical through its centre of mass. With the part frame's
// z roughly up, this is the linear program (LP duality):
//   maximize the height at the centre of mass of a plane z = a x + b y + c that lies
//   below every point;
// its dual writes the centre of mass's (x, y) as a convex combination of the points
// minimizing the weighted height, whose optimal basis is the three contacts. Because
// tilting the part onto that facet changes the direction of gravity in the part
// frame, the LP is repeated in the facet's frame until the facet stops changing.
#include <array>
#include <vector>

#include <Eigen/Core>

#include "flatscan/geometry/rigid3.h"

namespace flatscan {

struct RestPose {
  // Maps part-frame points to the support frame: support plane z = 0, +z up. Every
  // input point gets z >= 0 and the three contacts z = 0 (to round-off). There is no
  // spin about z, and the centre of mass lands at x = y = 0.
  Rigid3d support_from_part;
  std::array<int, 3> contacts{};           // indices into the input points
  // Centre of mass (its vertical projection) in the contact triangle: all > 0, or = 0
  // when it lies over an edge of the triangle (a degenerate, e.g. symmetric, part).
  std::array<double, 3> barycentric{};
};

// `points`: samples of the part's bottom surface in the part frame (mm), z roughly up.
// Throws std::invalid_argument with a message if fewer than 3 points, if the points
// are collinear seen from above, or if the centre of mass is not above the points'
// convex hull (initially, or after tilting onto the support facet: the part tips).
RestPose ComputeRestPose(const std::vector<Eigen::Vector3d>& points,
                         const Eigen::Vector3d& center_of_mass);

}  // namespace flatscan
