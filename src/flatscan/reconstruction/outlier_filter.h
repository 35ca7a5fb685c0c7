#pragma once
// Radius-neighbour outlier removal (paper section 2.1): a point with fewer than
// `min_neighbours` other points within `radius_mm` is an outlier. Exact radius search
// on a k-d tree (nanoflann).
#include <vector>

#include <Eigen/Core>

namespace flatscan {

// Returns one flag per point: true = keep.
std::vector<bool> RadiusOutlierFilter(const std::vector<Eigen::Vector3d>& points, double radius_mm,
                                      int min_neighbours);
// The same with a radius per point (points sampled more sparsely need a larger one to
// find their true neighbours).
std::vector<bool> RadiusOutlierFilter(const std::vector<Eigen::Vector3d>& points, const std::vector<double>& radii_mm,
                                      int min_neighbours);

}  // namespace flatscan
