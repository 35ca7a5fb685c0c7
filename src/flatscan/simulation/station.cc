#include "flatscan/simulation/station.h"

#include <cmath>

#include <Eigen/Geometry>

#include "flatscan/util/error.h"

namespace flatscan {
namespace {

constexpr double kDeg = M_PI / 180.0;

Camera MakeCamera(const CameraSpec& spec) {
  Camera c;
  c.width = spec.width;
  c.height = spec.height;
  c.fx = c.fy = spec.focal_length_mm / (spec.pixel_size_um * 1e-3);
  c.cx = (spec.width - 1) / 2.0 + spec.principal_point_offset_px[0];
  c.cy = (spec.height - 1) / 2.0 + spec.principal_point_offset_px[1];
  for (size_t i = 0; i < spec.distortion.size() && i < c.dist.size(); ++i) c.dist[i] = spec.distortion[i];
  return c;
}

// Camera at `centre` looking at `aim`, image x along +x of the frame, then rolled.
Rigid3d LookAt(const Eigen::Vector3d& centre, const Eigen::Vector3d& aim, double roll_deg) {
  const Eigen::Vector3d z = (aim - centre).normalized();
  const Eigen::Vector3d x = (Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitX().dot(z) * z).normalized();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d cam_from_frame;
  cam_from_frame.row(0) = x;
  cam_from_frame.row(1) = y;
  cam_from_frame.row(2) = z;
  cam_from_frame = Eigen::AngleAxisd(roll_deg * kDeg, Eigen::Vector3d::UnitZ()).toRotationMatrix() * cam_from_frame;
  return {cam_from_frame, -cam_from_frame * centre};
}

std::vector<Eigen::Vector3d> RectangleOutline(double hx, double hy, int per_side) {
  std::vector<Eigen::Vector3d> out;
  for (int i = 0; i <= per_side; ++i) {
    const double t = -1.0 + 2.0 * i / per_side;
    out.emplace_back(t * hx, -hy, 0);
    out.emplace_back(t * hx, hy, 0);
    out.emplace_back(-hx, t * hy, 0);
    out.emplace_back(hx, t * hy, 0);
  }
  return out;
}

}  // namespace

bool Station::VisibleInBoth(const std::vector<Eigen::Vector3d>& points, double margin_px) const {
  for (const RigSide cam : {RigSide::kLeft, RigSide::kRight})
    for (const Eigen::Vector3d& p : points) {
      const Eigen::Vector3d pc = CamFromSupport(cam) * p;
      if (pc.z() <= 0 || !GetCamera(cam).InImage(GetCamera(cam).Project(pc), margin_px)) return false;
    }
  return true;
}

Station BuildStation(const SceneConfig& scene) {
  Station st;
  st.scene = scene;
  st.rig.left = MakeCamera(scene.left_camera);
  st.rig.right = MakeCamera(scene.right_camera);
  const double b = scene.rig.baseline_mm, h = scene.rig.working_distance_mm;
  const Eigen::Vector3d aim2(scene.rig.right_aim_offset_mm[0], scene.rig.right_aim_offset_mm[1], 0);
  const Rigid3d cam1_from_nominal = LookAt({-b / 2, 0, h}, Eigen::Vector3d::Zero(), scene.rig.roll_deg[0]);
  const Rigid3d cam2_from_nominal = LookAt({b / 2, 0, h}, aim2, scene.rig.roll_deg[1]);
  // The support plane tilted about an in-plane axis through the plane centre.
  const double az = scene.plane.tilt_azimuth_deg * kDeg;
  Rigid3d nominal_from_support;
  nominal_from_support.rotation =
      Eigen::AngleAxisd(scene.plane.tilt_deg * kDeg, Eigen::Vector3d(std::cos(az), std::sin(az), 0)).toRotationMatrix();
  st.cam1_from_support = cam1_from_nominal * nominal_from_support;
  st.cam2_from_support = cam2_from_nominal * nominal_from_support;
  st.rig.cam2_from_cam1 = st.cam2_from_support * st.cam1_from_support.Inverse();
  st.rig.ComputeRectification();

  // Common field of view: bisection on the scale of a centred rectangle with the
  // image's aspect ratio.
  const double aspect = static_cast<double>(st.rig.left.height) / st.rig.left.width;
  double lo = 0.0, hi = 4.0 * h;
  for (int iter = 0; iter < 50; ++iter) {
    const double mid = 0.5 * (lo + hi);
    (st.VisibleInBoth(RectangleOutline(mid, mid * aspect, 32), 16.0) ? lo : hi) = mid;
  }
  if (lo < 1e-3) ThrowInputError("scene '{}': the two cameras share no view of the plane centre (check rig.baseline_mm, rig.working_distance_mm and plane.tilt_deg)", scene.name);
  st.common_half_size = {lo, lo * aspect};

  const double inset = scene.markers.inset;
  for (double sy : {-1.0, 1.0})
    for (double sx : {-1.0, 1.0})
      st.markers.emplace_back(sx * inset * st.common_half_size.x(), sy * inset * st.common_half_size.y());
  // Support-plane truth in the camera-1 frame.
  st.plane.normal = st.cam1_from_support.rotation * Eigen::Vector3d::UnitZ();
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const Eigen::Vector2d& m : st.markers) {
    st.plane.markers.push_back(st.cam1_from_support * Eigen::Vector3d(m.x(), m.y(), 0));
    st.plane.residuals_mm.push_back(0.0);
    centroid += st.plane.markers.back();
  }
  st.plane.point = centroid / static_cast<double>(st.markers.size());
  return st;
}

}  // namespace flatscan
