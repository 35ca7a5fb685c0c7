#include "flatscan/reconstruction/rectified_stereo.h"

#include <Eigen/Dense>
#include <opencv2/core/eigen.hpp>

#include "flatscan/util/error.h"

namespace flatscan {

RectifiedStereo RectifiedStereo::FromRig(const StereoRig& rig) {
  FLATSCAN_CHECK(!rig.rectification.empty());
  const Rectification& r = rig.rectification;
  RectifiedStereo s;
  s.f = r.P1.at<double>(0, 0);
  s.cx1 = r.P1.at<double>(0, 2);
  s.cy = r.P1.at<double>(1, 2);
  s.cx2 = r.P2.at<double>(0, 2);
  s.tx = r.P2.at<double>(0, 3) / r.P2.at<double>(0, 0);
  FLATSCAN_CHECK(std::abs(r.P2.at<double>(1, 3)) < 1e-9 * std::abs(r.P2.at<double>(0, 3)));  // horizontal rig
  cv::cv2eigen(r.R1, s.rect1_from_cam1);
  return s;
}

double RectifiedStereo::Disparity(const Eigen::Vector3d& x) const {
  return (f * x.x() / x.z() + cx1) - (f * (x.x() + tx) / x.z() + cx2);
}

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

BottomPoint TriangulateBottomPoint(const RectifiedStereo& s, double u_left, double u_right, double row,
                                   const Eigen::Vector2d& normal_left, const Eigen::Vector3d& up,
                                   double thickness) {
  BottomPoint out;
  const Eigen::Vector3d naive = TriangulateRow(s, u_left, u_right, row);
  if (!(naive.z() > 0) || !naive.allFinite()) return out;
  // The boundary's 3D tangent and outward normal: the image tangent and normal lifted
  // onto the plane parallel to the support through the naive point.
  const double eps = 0.5;
  const Eigen::Vector2d tangent_2d(-normal_left.y(), normal_left.x());
  const Eigen::Vector3d p0 = LiftToPlane(s, u_left, row, naive, up);
  Eigen::Vector3d tangent = LiftToPlane(s, u_left + eps * tangent_2d.x(), row + eps * tangent_2d.y(), naive, up) - p0;
  Eigen::Vector3d outward = LiftToPlane(s, u_left + eps * normal_left.x(), row + eps * normal_left.y(), naive, up) - p0;
  tangent.normalize();
  outward = (outward - outward.dot(tangent) * tangent).normalized();
  // Which edge forms each silhouette: the bottom edge if the camera is on the outer
  // side of the side face.
  out.left_edge = (Eigen::Vector3d::Zero() - naive).dot(outward) > 0 ? 0 : 1;
  out.right_edge = (s.RightCentre() - naive).dot(outward) > 0 ? 0 : 1;
  // lambda_L dL - lambda_R dR + s T = C2 + (delta_L - delta_R) t N   (B = lambda_L dL - delta_L t N)
  const Eigen::Vector3d dl = s.LeftRay(u_left, row), dr = s.RightRay(u_right, row);
  Eigen::Matrix3d a;
  a.col(0) = dl;
  a.col(1) = -dr;
  a.col(2) = tangent;
  const Eigen::Vector3d rhs = s.RightCentre() + (out.left_edge - out.right_edge) * thickness * up;
  const Eigen::Vector3d x = a.partialPivLu().solve(rhs);
  if (!x.allFinite()) return out;
  out.rect1 = x[0] * dl - out.left_edge * thickness * up;
  out.valid = out.rect1.z() > 0;
  return out;
}

}  // namespace flatscan
