#pragma once
// The simulated inspection station: two cameras above a backlight (the support
// plane), built from a SceneConfig. The support frame has the backlight's top
// surface at z = 0 and +z toward the cameras; both cameras sit at the working
// distance above it, the baseline apart along x, each turned toward the plane centre
// (a convergent rig), before the plane is tilted by plane.tilt_deg.
#include <vector>

#include <Eigen/Core>

#include "flatscan/calibration/stereo_rig.h"
#include "flatscan/geometry/rigid3.h"
#include "flatscan/simulation/scene_config.h"
#include "flatscan/support_plane/support_plane.h"

namespace flatscan {

struct Station {
  SceneConfig scene;
  StereoRig rig;                 // the true rig (with rectification)
  Rigid3d cam1_from_support;
  Rigid3d cam2_from_support;
  // Largest support-plane rectangle [-x, x] x [-y, y] seen by both cameras with a
  // 16 px margin (mm).
  Eigen::Vector2d common_half_size;
  std::vector<Eigen::Vector2d> markers;  // marker centres on the support plane (mm)
  SupportPlane plane;                     // the true plane in the camera-1 frame

  const Rigid3d& CamFromSupport(RigSide side) const { return side == RigSide::kLeft ? cam1_from_support : cam2_from_support; }
  const Camera& GetCamera(RigSide side) const { return rig.camera(side); }
  // True when every point (support frame) projects inside both images, `margin_px`
  // away from the border.
  bool VisibleInBoth(const std::vector<Eigen::Vector3d>& points, double margin_px) const;
};

// Throws InputError when the scene cannot be built (e.g. markers outside the view).
Station BuildStation(const SceneConfig& scene);

}  // namespace flatscan
