#include "flatscan/reconstruction/rectified_stereo.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include <Eigen/Dense>


namespace flatscan {

Eigen::Vector3d TriangulateRow(const RectifiedStereo& s, double u_left, double u_right, double row) {
  // u_L - u_R = -f tx / Z + (cx1 - cx2)
  const double d = (u_left - s.cx1) - (u_right - s.cx2);
  const double z = -s.f * s.tx / d;
  return {(u_left - s.cx1) * z / s.f, (row - s.cy) * z / s.f, z};
}

namespace {

// Intersection of the left ray through rectified (u, v) with the plane through
// `point` with normal `n`.
Eigen::Vector3d LiftToPlane(const RectifiedStereo& s, double u, double v, const Eigen::Vector3d& point,
                            const Eigen::Vector3d& n) {
  const Eigen::Vector3d d = s.LeftRay(u, v);
  return d * (n.dot(point) / n.dot(d));
}

}  // namespace

namespace {

Eigen::Vector2d ProjectRight(const RectifiedStereo& s, const Eigen::Vector3d& x) {
  return {s.f * (x.x() + s.tx) / x.z() + s.cx2, s.f * x.y() / x.z() + s.cy};
}

struct EdgeSeen {
  SilhouetteEdge edge = SilhouetteEdge::kBottom;
  double facing = 0;       // sine of the angle between the line of sight and the side face
  double generator = 0;    // mm
};

// Which edge of the side face at `p` (outward normal `outward`, face direction
// `side`) forms the silhouette seen from the camera centre `c`.
EdgeSeen Seen(const Eigen::Vector3d& c, const Eigen::Vector3d& p, const Eigen::Vector3d& outward,
              const Eigen::Vector3d& side, double thickness) {
  const Eigen::Vector3d v = c - p;
  const double along = v.dot(side);
  EdgeSeen e;
  e.facing = v.dot(outward) / v.norm();
  e.edge = e.facing > 0 ? SilhouetteEdge::kBottom : SilhouetteEdge::kTop;
  e.generator = thickness * (v - along * side).norm() / std::max(along, 1e-9);
  return e;
}

// Depth (z, rectified frame 1) of the left-ray point X = lambda d_L such that
// X + delta projects onto the right silhouette polyline, starting near z0; NaN if
// the polyline does not cross the image of that line.
double SolveOnRightSilhouette(const RectifiedStereo& s, const Eigen::Vector3d& dl, const Eigen::Vector3d& delta,
                              std::span<const Eigen::Vector2d> silhouette, double z0) {
  const Eigen::Vector2d p0 = ProjectRight(s, z0 * dl + delta);
  const Eigen::Vector2d e = ProjectRight(s, 1.02 * z0 * dl + delta) - p0;  // the image of a 3D line is a line
  double best_a = std::numeric_limits<double>::infinity();
  Eigen::Vector2d q(0, 0);
  for (size_t i = 0; i + 1 < silhouette.size(); ++i) {
    const Eigen::Vector2d& a = silhouette[i];
    const Eigen::Vector2d ab = silhouette[i + 1] - a;
    const double det = -e.x() * ab.y() + e.y() * ab.x();
    if (std::abs(det) < 1e-12) continue;
    const Eigen::Vector2d r = a - p0;
    const double alpha = (-r.x() * ab.y() + r.y() * ab.x()) / det;
    const double beta = (e.x() * r.y() - e.y() * r.x()) / det;
    if (beta < -1e-9 || beta > 1 + 1e-9 || std::abs(alpha) >= std::abs(best_a)) continue;
    best_a = alpha;
    q = a + beta * ab;
  }
  if (!std::isfinite(best_a)) return std::numeric_limits<double>::quiet_NaN();
  // lambda d_L + delta = C2 + mu d_R (they meet: q is the image of a point of the line).
  const Eigen::Vector3d dr = s.RightRay(q.x(), q.y());
  // Least squares for (lambda, mu) by the 2 x 2 normal equations (the rays are far from
  // parallel: the baseline subtends degrees).
  const Eigen::Vector3d rhs = s.RightCentre() - delta;
  const double a11 = dl.dot(dl), a12 = -dl.dot(dr), a22 = dr.dot(dr);
  const double b1 = dl.dot(rhs), b2 = -dr.dot(rhs);
  const double lambda = (a22 * b1 - a12 * b2) / (a11 * a22 - a12 * a12);
  return lambda * dl.z();
}

}  // namespace

BottomPoint TriangulateBottomPoint(const RectifiedStereo& s, double u_left, double row,
                                   const Eigen::Vector2d& normal_left,
                                   std::span<const Eigen::Vector2d> right_silhouette, double u_right,
                                   const Eigen::Vector3d& side, double thickness) {
  BottomPoint out;
  const Eigen::Vector3d naive = TriangulateRow(s, u_left, u_right, row);
  if (!(naive.z() > 0) || !naive.allFinite()) return out;
  const Eigen::Vector3d dl = s.LeftRay(u_left, row);  // naive = z dl (dl.z = 1)
  Eigen::Vector3d bottom = naive;
  // The rim's outward normal across the side face: the image tangent and normal lifted
  // onto the plane across the face (normal `side`). Lifting onto that plane through a
  // point X scales every lifted point by side . X, so the directions do not depend on
  // which point: they are taken once, through the naive point (side . X keeps its sign
  // while the point moves by micrometres).
  const double eps = 0.5;
  const Eigen::Vector2d tangent_2d(-normal_left.y(), normal_left.x());
  const Eigen::Vector3d p0 = LiftToPlane(s, u_left, row, naive, side);
  Eigen::Vector3d tangent = LiftToPlane(s, u_left + eps * tangent_2d.x(), row + eps * tangent_2d.y(), naive, side) - p0;
  Eigen::Vector3d outward = LiftToPlane(s, u_left + eps * normal_left.x(), row + eps * normal_left.y(), naive, side) - p0;
  tangent.normalize();
  outward = (outward - outward.dot(tangent) * tangent).normalized();
  std::optional<SilhouetteEdge> left_edge, right_edge;  // none before the first pass
  for (int pass = 0; pass < 3; ++pass) {
    const EdgeSeen l = Seen(Eigen::Vector3d::Zero(), bottom, outward, side, thickness);
    const EdgeSeen r = Seen(s.RightCentre(), bottom, outward, side, thickness);
    out.facing_left = l.facing;
    out.facing_right = r.facing;
    out.generator_left_mm = l.generator;
    out.generator_right_mm = r.generator;
    if (l.edge == left_edge && r.edge == right_edge) break;
    left_edge = l.edge;
    right_edge = r.edge;
    const double left_rise = EdgeRise(l.edge), right_rise = EdgeRise(r.edge);
    double z = naive.z();
    if (l.edge != r.edge)
      z = SolveOnRightSilhouette(s, dl, (right_rise - left_rise) * thickness * side, right_silhouette, naive.z());
    if (!(z > 0)) return out;
    bottom = z * dl - left_rise * thickness * side;
  }
  out.rect1 = bottom;
  out.left_edge = *left_edge;
  out.right_edge = *right_edge;
  out.valid = bottom.allFinite() && bottom.z() > 0;
  return out;
}

}  // namespace flatscan
