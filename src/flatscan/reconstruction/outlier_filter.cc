#include "flatscan/reconstruction/outlier_filter.h"

#include <nanoflann.hpp>

namespace flatscan {
namespace {

struct PointCloudAdaptor {
  const std::vector<Eigen::Vector3d>& points;
  size_t kdtree_get_point_count() const { return points.size(); }
  double kdtree_get_pt(size_t i, size_t dim) const { return points[i][static_cast<int>(dim)]; }
  template <class Box>
  bool kdtree_get_bbox(Box&) const {
    return false;
  }
};

using KdTree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, PointCloudAdaptor>,
                                                   PointCloudAdaptor, 3, size_t>;

}  // namespace

std::vector<bool> RadiusOutlierFilter(const std::vector<Eigen::Vector3d>& points, double radius_mm,
                                      int min_neighbours) {
  return RadiusOutlierFilter(points, std::vector<double>(points.size(), radius_mm), min_neighbours);
}

std::vector<bool> RadiusOutlierFilter(const std::vector<Eigen::Vector3d>& points, const std::vector<double>& radii_mm,
                                      int min_neighbours) {
  std::vector<bool> keep(points.size(), false);
  if (points.empty()) return keep;
  const PointCloudAdaptor cloud{points};
  KdTree tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(10));
  tree.buildIndex();
  std::vector<std::pair<size_t, double>> found;
  const nanoflann::SearchParams params(32, 0.0f, false);
  for (size_t i = 0; i < points.size(); ++i) {
    found.clear();
    const size_t n = tree.radiusSearch(points[i].data(), radii_mm[i] * radii_mm[i], found, params);
    keep[i] = static_cast<int>(n) - 1 >= min_neighbours;  // the point itself is found too
  }
  return keep;
}

}  // namespace flatscan
