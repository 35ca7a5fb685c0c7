#pragma once
// The three flatness quantities of docs/conventions.md, over the bottom rim points of a
// part, all in mm.
//   flatness_mm : max over points of the height above the support plane (the
//                 paper's quantity; seating-plane height, JEDEC JESD22-B108).
//   lsq_pv_mm   : peak-to-valley of the points about their least-squares plane
//                 (total least squares: the plane minimizing squared orthogonal
//                 distances).
//   minzone_mm  : ISO 1101 flatness: the smallest distance between two parallel planes
//                 enclosing all points (exact, by linear programming, refined until
//                 the plane's tilt no longer changes the width by more than 1e-12 mm).
//                 The refinement starts at the TLS plane and stops at a strict local
//                 minimum of the width over normals; a distant, lower minimum would beat
//                 it by at most width * tan^2(angle between the normals) / 2, which is
//                 negligible for flat point sets (see MinimumZoneFlatness in the .cc).
// All functions throw std::invalid_argument for fewer than 3 points.
#include <vector>

#include <Eigen/Core>

#include "flatscan/geometry/plane_fit.h"

namespace flatscan {

// Peak-to-valley of the orthogonal distances about the TLS plane.
double LeastSquaresPeakToValley(const std::vector<Eigen::Vector3d>& points);

// Minimum-zone flatness; optionally returns the normal of the two enclosing planes.
double MinimumZoneFlatness(const std::vector<Eigen::Vector3d>& points,
                           Eigen::Vector3d* zone_normal = nullptr);

struct FlatnessValues {
  double flatness_mm = 0.0;
  double lsq_pv_mm = 0.0;
  double minzone_mm = 0.0;
};

// heights[i] is points[i]'s height above the support plane (for flatness_mm).
// Throws std::invalid_argument if the sizes differ.
FlatnessValues ComputeFlatness(const std::vector<Eigen::Vector3d>& points,
                               const std::vector<double>& heights);

}  // namespace flatscan
