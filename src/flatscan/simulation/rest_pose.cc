#include "flatscan/simulation/rest_pose.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <fmt/format.h>

#include "flatscan/geometry/small_lp.h"

namespace flatscan {
namespace {

constexpr int kMaxFacetChanges = 100;
// A new facet must raise the support plane's height at the centre of mass by more than
// this times the part's extent to replace the current one (otherwise it is a tie).
constexpr double kImprovementTol = 1e-12;

// The rotation by the smallest angle taking the unit vector `up` to +z (its axis is
// horizontal, up x z: no spin about z).
Eigen::Matrix3d MinimalRotationToZ(const Eigen::Vector3d& up) {
  return Eigen::Quaterniond::FromTwoVectors(up, Eigen::Vector3d::UnitZ())
      .normalized()
      .toRotationMatrix();
}

}  // namespace

RestPose ComputeRestPose(const std::vector<Eigen::Vector3d>& points,
                         const Eigen::Vector3d& center_of_mass) {
  const int n = static_cast<int>(points.size());
  if (n < 3) {
    throw std::invalid_argument(
        fmt::format("ComputeRestPose: need at least 3 points to rest on, got {}", n));
  }
  double extent = 0.0;
  for (const Eigen::Vector3d& p : points) extent = std::max(extent, (p - center_of_mass).norm());
  const double improvement_tol = kImprovementTol * extent;

  // In the frame where `up` (the current facet's upward normal in the part frame, at
  // first the part's +z) is vertical and the centre of mass is the origin, solve
  //   minimize sum_i z_i w_i  s.t.  sum_i w_i (x_i, y_i, 1) = (0, 0, 1),  w >= 0,
  // the dual of "the highest plane z = p0 x + p1 y + p2 below every point, measured at
  // the centre of mass (p2)". The optimal basis is the support facet's three vertices
  // and w their barycentric weights. Tilting onto that facet changes the vertical, so
  // repeat in the facet's frame; each change lowers the centre of mass's distance to
  // the support plane (the vertical gap shrinks and the perpendicular one is that
  // times cos(tilt)), so there are finitely many changes.
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  std::array<int, 3> contacts{};
  bool have_facet = false;
  Eigen::MatrixXd a(3, n);
  Eigen::VectorXd c(n);
  const Eigen::Vector3d b(0.0, 0.0, 1.0);
  for (int change = 0; change <= kMaxFacetChanges; ++change) {
    const Eigen::Matrix3d rotation = MinimalRotationToZ(up);
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d q = rotation * (points[i] - center_of_mass);
      a.col(i) << q.x(), q.y(), 1.0;
      c(i) = q.z();
    }
    const StandardFormLpResult lp = SolveStandardFormLp(a, b, c);
    if (lp.status == StandardFormLpResult::Status::kInfeasible) {
      if (!have_facet) {
        throw std::invalid_argument(fmt::format(
            "ComputeRestPose: the centre of mass ({}, {}, {}) is not above the convex hull "
            "of the {} points (seen along the part frame's z axis): the part cannot rest",
            center_of_mass.x(), center_of_mass.y(), center_of_mass.z(), n));
      }
      throw std::invalid_argument(fmt::format(
          "ComputeRestPose: after tilting onto its support facet the centre of mass ({}, {}, "
          "{}) is no longer above the convex hull of the {} points: the part tips over",
          center_of_mass.x(), center_of_mass.y(), center_of_mass.z(), n));
    }
    if (lp.status != StandardFormLpResult::Status::kOptimal) {
      // The weights lie in a simplex: the LP is bounded whenever it is feasible.
      throw std::logic_error("ComputeRestPose: support LP unbounded");
    }
    if (lp.basis.size() != 3) {
      throw std::invalid_argument(fmt::format(
          "ComputeRestPose: the {} points are collinear seen from above: no support facet",
          n));
    }
    if (have_facet) {
      // The previous facet is horizontal in this frame, at the height of its contacts.
      double previous = 0.0;
      for (int k : contacts) previous += c(k) / 3.0;
      const bool improved = lp.objective > previous + improvement_tol;
      // On a tie (several coplanar points, or the centre of mass over a facet edge)
      // keep this LP's contacts: their triangle contains the centre of mass in the
      // current frame.
      std::copy(lp.basis.begin(), lp.basis.end(), contacts.begin());
      if (!improved) break;
    } else {
      std::copy(lp.basis.begin(), lp.basis.end(), contacts.begin());
      have_facet = true;
    }
    // Upward normal of the facet through the contacts, in the part frame.
    const Eigen::Vector3d p0 = points[contacts[0]];
    Eigen::Vector3d facet_normal =
        (points[contacts[1]] - p0).cross(points[contacts[2]] - p0).normalized();
    if (facet_normal.dot(up) < 0.0) facet_normal = -facet_normal;
    up = facet_normal;
  }

  // Recompute the facet normal from the final contacts so that they land on z = 0.
  const Eigen::Vector3d p0 = points[contacts[0]];
  Eigen::Vector3d facet_normal =
      (points[contacts[1]] - p0).cross(points[contacts[2]] - p0).normalized();
  if (facet_normal.dot(up) < 0.0) facet_normal = -facet_normal;
  RestPose pose;
  pose.contacts = contacts;
  pose.support_from_part.rotation = MinimalRotationToZ(facet_normal);
  pose.support_from_part.translation = -pose.support_from_part.rotation * center_of_mass;
  double contact_height = 0.0;
  for (int k : contacts) contact_height += (pose.support_from_part * points[k]).z() / 3.0;
  pose.support_from_part.translation.z() -= contact_height;

  // Barycentric coordinates of the centre of mass's vertical projection (x = y = 0) in
  // the contact triangle.
  Eigen::Matrix3d m;
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector3d q = pose.support_from_part * points[contacts[k]];
    m.col(k) << q.x(), q.y(), 1.0;
  }
  Eigen::Vector3d w = m.fullPivLu().solve(Eigen::Vector3d(0.0, 0.0, 1.0));
  // Round-off (or a centre of mass exactly over an edge) can leave a weight a hair
  // below zero: clamp and renormalize.
  w = w.cwiseMax(0.0);
  w /= w.sum();
  for (int k = 0; k < 3; ++k) pose.barycentric[k] = w(k);
  return pose;
}

}  // namespace flatscan
