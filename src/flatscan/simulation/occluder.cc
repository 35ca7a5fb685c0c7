#include "flatscan/simulation/occluder.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace flatscan {

PlanarOccluder::PlanarOccluder(const Rigid3d& plane_from_support, Sdf2d sdf,
                               std::vector<Eigen::Vector2d> outline)
    : plane_from_support_(plane_from_support), sdf_(std::move(sdf)), outline_(std::move(outline)) {}

double PlanarOccluder::RaySignedDistance(const Ray& ray) const {
  const Eigen::Vector3d o = plane_from_support_ * ray.origin;
  const Eigen::Vector3d d = plane_from_support_.rotation * ray.direction;
  if (std::abs(d.z()) < 1e-12) return std::numeric_limits<double>::infinity();
  const double s = -o.z() / d.z();
  if (s <= 0) return std::numeric_limits<double>::infinity();
  return sdf_(Eigen::Vector2d(o.x() + s * d.x(), o.y() + s * d.y()));
}

std::vector<Eigen::Vector3d> PlanarOccluder::BoundingPoints() const {
  const Rigid3d support_from_plane = plane_from_support_.Inverse();
  std::vector<Eigen::Vector3d> out;
  out.reserve(outline_.size());
  for (const Eigen::Vector2d& p : outline_) out.push_back(support_from_plane * Eigen::Vector3d(p.x(), p.y(), 0));
  return out;
}

double RoundedRectSdf(const Eigen::Vector2d& p, double half_width, double half_height, double radius) {
  const double qx = std::abs(p.x()) - (half_width - radius);
  const double qy = std::abs(p.y()) - (half_height - radius);
  const double outside = std::hypot(std::max(qx, 0.0), std::max(qy, 0.0));
  const double inside = std::min(std::max(qx, qy), 0.0);
  return outside + inside - radius;
}

double CircleSdf(const Eigen::Vector2d& p, const Eigen::Vector2d& center, double radius) {
  return (p - center).norm() - radius;
}

double AnnulusSdf(const Eigen::Vector2d& p, const Eigen::Vector2d& center, double inner_radius,
                  double outer_radius) {
  const double r = (p - center).norm();
  return std::max(r - outer_radius, inner_radius - r);
}

double CheckerSdf(const Eigen::Vector2d& p, int cols, int rows, double square) {
  // Outside the squared area everything is "white" (the board margin).
  const double w = cols * square, h = rows * square;
  const double box = std::max({-p.x(), p.x() - w, -p.y(), p.y() - h});
  if (box >= 0) return std::max(box, 1e-9);
  const double fx = p.x() / square, fy = p.y() / square;
  const int i = std::clamp(static_cast<int>(std::floor(fx)), 0, cols - 1);
  const int j = std::clamp(static_cast<int>(std::floor(fy)), 0, rows - 1);
  const double dx = std::min(fx - i, i + 1 - fx) * square;
  const double dy = std::min(fy - j, j + 1 - fy) * square;
  const double d = std::min(dx, dy);
  const bool black = ((i + j) % 2) == 0;
  return black ? -d : d;
}

}  // namespace flatscan
