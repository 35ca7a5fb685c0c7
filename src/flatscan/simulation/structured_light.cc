#include "flatscan/simulation/structured_light.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <tbb/parallel_for.h>

#include "flatscan/simulation/image_formation.h"
#include "flatscan/util/error.h"

namespace flatscan {
namespace {

constexpr double kSupportAlbedo = 0.6;
constexpr float kUnlit = -1e4f;  // a projector coordinate far outside its image

// Camera looking from `centre` at `target`, its image x along the support's `x_hint`.
Rigid3d LookAt(const Eigen::Vector3d& centre, const Eigen::Vector3d& target, const Eigen::Vector3d& x_hint) {
  const Eigen::Vector3d z = (target - centre).normalized();
  const Eigen::Vector3d x = (x_hint - x_hint.dot(z) * z).normalized();
  Eigen::Matrix3d support_from_cam;
  support_from_cam << x, z.cross(x), z;
  return Rigid3d{support_from_cam, centre}.Inverse();
}

// Ray parameter where o + l d (part frame) meets the sheet's top (s = thickness) over the
// footprint, or NaN. Newton on s(o + l d) - t: moving along d changes the sheet
// coordinate s by about d . S(q).
double HitTop(const PartGeometry& g, const Eigen::Vector3d& o, const Eigen::Vector3d& d) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  double l = (g.thickness - o.z()) / d.z();
  Eigen::Vector2d q = (o + l * d).head<2>();
  l = (g.WarpZ(q) + g.thickness - o.z()) / d.z();
  q = (o + l * d).head<2>();
  for (int iteration = 0; iteration < 20; ++iteration) {
    double s = 0;
    q = g.SheetCoordinates(o + l * d, &s, &q);
    const double step = (s - g.thickness) / d.dot(g.FaceDirection(q));
    l -= step;
    if (std::abs(step) < 1e-9) return g.FootprintSdf(q) < 0 ? l : nan;
  }
  return nan;
}

struct PlacedPart {
  const PartGeometry& geometry;
  Rigid3d support_from_part, part_from_support;
  double reach_mm;  // beyond this distance from the part's origin (xy), no ray meets it

  // Ray parameter of the top-surface hit of the support-frame ray, or NaN.
  double HitTopFromSupport(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction) const {
    return HitTop(geometry, part_from_support * origin, part_from_support.rotation * direction);
  }
  bool Near(const Eigen::Vector3d& x_support) const {
    return (part_from_support * x_support).head<2>().norm() < reach_mm;
  }
  bool Covers(const Eigen::Vector3d& x_support) const {
    return geometry.FootprintSdf((part_from_support * x_support).head<2>()) < 0;
  }
  Eigen::Vector3d TopNormal(const Eigen::Vector3d& x_support) const {
    const Eigen::Vector2d g = geometry.WarpGradient((part_from_support * x_support).head<2>());
    return support_from_part.rotation * Eigen::Vector3d(-g.x(), -g.y(), 1).normalized();
  }
};

struct PixelTrace {
  Eigen::Vector3d point = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  bool on_part = false, lit = false;
};

PixelTrace TraceRay(const PlacedPart& part, const Eigen::Vector3d& camera_centre,
                    const Eigen::Vector3d& projector_centre, const Eigen::Vector3d& direction) {
  PixelTrace t;
  const Eigen::Vector3d on_support = camera_centre - camera_centre.z() / direction.z() * direction;
  if (!part.Near(on_support)) {
    t.point = on_support;
    t.lit = true;
    return t;
  }
  const double l = part.HitTopFromSupport(camera_centre, direction);
  if (std::isfinite(l)) {
    t.point = camera_centre + l * direction;
    t.normal = part.TopNormal(t.point);
    t.on_part = t.lit = true;
    return t;
  }
  if (part.Covers(on_support)) return t;  // the part's side or under it: dark
  t.point = on_support;
  // Shadowed when the projector's ray to the point meets the part's top first.
  const double shadow = part.HitTopFromSupport(projector_centre, on_support - projector_centre);
  t.lit = !(shadow > 0 && shadow < 1 - 1e-9);
  return t;
}

double ReflectedGain(const StructuredLightRig& rig, const PixelTrace& t, const Eigen::Vector3d& camera_centre,
                     const Eigen::Vector3d& projector_centre) {
  const SurfaceFinish finish = t.on_part ? rig.spec.finish : SurfaceFinish{kSupportAlbedo, 0.0, 1.0};
  const Eigen::Vector3d l = (projector_centre - t.point).normalized();
  const Eigen::Vector3d v = (camera_centre - t.point).normalized();
  const Eigen::Vector3d h = (l + v).normalized();
  const double diffuse = finish.albedo * std::max(t.normal.dot(l), 0.0);
  const double specular = finish.specular * std::pow(std::max(t.normal.dot(h), 0.0), finish.shininess);
  return rig.spec.exposure_grey * (diffuse + specular);
}

// The largest n' <= n that cv::dft takes without padding (2^a 3^b 5^c). OpenCV's PSP phase
// (SinusoidalPattern::computePhaseMap) pads other sizes with zeros, whose dark band rings
// through its band-pass filter (78 um at 720 x 560 px against 5 um at 720 x 576), and then
// reads the shadow mask over the padded size, past the mask's end.
int DftFriendly(int n) {
  while (n > 1 && cv::getOptimalDFTSize(n) != n) --n;
  return n;
}

void CheckSpec(const StructuredLightSpec& s) {
  if (!(s.triangulation_deg > 5 && s.triangulation_deg < 60))
    ThrowFieldError("structured_light.triangulation_deg", "expected 5 to 60 degrees, got {}", s.triangulation_deg);
  if (s.roi_width < 64 || s.roi_height < 64)
    ThrowFieldError("structured_light.roi_width", "expected a region of at least 64x64 px, got {}x{}", s.roi_width,
                    s.roi_height);
  if (s.fringe_periods < 2 || s.projector_width % s.fringe_periods != 0)
    ThrowFieldError("structured_light.fringe_periods", "expected a divisor of the projector width {} (>= 2), got {}",
                    s.projector_width, s.fringe_periods);
  if (!(s.projector_field_mm >= 0))
    ThrowFieldError("structured_light.projector_field_mm", "expected a value >= 0 mm, got {}", s.projector_field_mm);
}

}  // namespace

StructuredLightRig BuildStructuredLightRig(const Station& station, const StructuredLightSpec& spec) {
  CheckSpec(spec);
  StructuredLightRig rig;
  rig.spec = spec;
  rig.camera = station.GetCamera(RigSide::kLeft);
  const int roi_width = DftFriendly(std::min(spec.roi_width, rig.camera.width));
  const int roi_height = DftFriendly(std::min(spec.roi_height, rig.camera.height));
  rig.camera.cx -= 0.5 * (rig.camera.width - roi_width);
  rig.camera.cy -= 0.5 * (rig.camera.height - roi_height);
  rig.camera.width = roi_width;
  rig.camera.height = roi_height;
  const double d = station.scene.rig.working_distance_mm;
  const double field_mm = spec.projector_field_mm > 0 ? spec.projector_field_mm : 1.2 * roi_width * d / rig.camera.fx;
  rig.cam_from_support = LookAt({0, 0, d}, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX());
  const Eigen::Vector3d projector_centre(d * std::tan(spec.triangulation_deg * M_PI / 180), 0, d);
  rig.projector_from_support = LookAt(projector_centre, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX());
  Camera& p = rig.projector;
  p.width = spec.projector_width;
  p.height = spec.projector_height;
  p.fx = p.fy = spec.projector_width * projector_centre.norm() / field_mm;
  p.cx = 0.5 * (p.width - 1);
  p.cy = 0.5 * (p.height - 1);
  rig.noise_sigma_grey = station.scene.optics.noise_sigma_grey;
  rig.camera_blur_px = 0.5 * station.scene.optics.blur_sigma_px;
  return rig;
}

ProjectorView TraceProjectorView(const StructuredLightRig& rig, const PartGeometry& geometry,
                                 const Rigid3d& support_from_part) {
  const Camera& cam = rig.camera;
  const Rigid3d support_from_cam = rig.cam_from_support.Inverse();
  const Eigen::Vector3d camera_centre = support_from_cam.translation;
  const Eigen::Vector3d projector_centre = rig.projector_from_support.Inverse().translation;
  double reach = 0;
  for (const Eigen::Vector2d& p : geometry.SampleOuterOutline(1.0)) reach = std::max(reach, p.norm());
  const PlacedPart part{geometry, support_from_part, support_from_part.Inverse(), reach + 2.0};

  ProjectorView view{cv::Mat2f(cam.height, cam.width), cv::Mat1f(cam.height, cam.width, 0.f),
                     cv::Mat1b(cam.height, cam.width, uchar{0}), cv::Mat3f(cam.height, cam.width)};
  tbb::parallel_for(0, cam.height, [&](int v) {
    for (int u = 0; u < cam.width; ++u) {
      const Eigen::Vector2d xy = cam.PixelToNormalized(Eigen::Vector2d(u, v));
      const Eigen::Vector3d direction = support_from_cam.rotation * Eigen::Vector3d(xy.x(), xy.y(), 1.0);
      const PixelTrace t = TraceRay(part, camera_centre, projector_centre, direction);
      view.point(v, u) = cv::Vec3f(t.point.x(), t.point.y(), t.point.z());
      view.on_part(v, u) = t.on_part ? 255 : 0;
      view.projector_px(v, u) = cv::Vec2f(kUnlit, kUnlit);
      if (!t.lit) continue;
      const Eigen::Vector3d in_projector = rig.projector_from_support * t.point;
      const Eigen::Vector2d px = rig.projector.Project(in_projector);
      if (!rig.projector.InImage(px)) continue;
      view.projector_px(v, u) = cv::Vec2f(static_cast<float>(px.x()), static_cast<float>(px.y()));
      view.gain(v, u) = static_cast<float>(ReflectedGain(rig, t, camera_centre, projector_centre));
    }
  });
  return view;
}

cv::Mat1b ImagePattern(const StructuredLightRig& rig, const ProjectorView& view, const cv::Mat1b& pattern,
                       uint64_t noise_seed) {
  cv::Mat1f projected;
  pattern.convertTo(projected, CV_32F, 1.0 / 255);
  if (rig.spec.projector_blur_px > 0) cv::GaussianBlur(projected, projected, cv::Size(), rig.spec.projector_blur_px);
  cv::Mat1f seen;
  cv::remap(projected, seen, view.projector_px, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_CONSTANT, 0);
  cv::Mat1f radiance = seen.mul(view.gain) + rig.spec.ambient_grey;
  if (rig.camera_blur_px > 0) cv::GaussianBlur(radiance, radiance, cv::Size(), rig.camera_blur_px);
  return QuantizeWithNoise(radiance, rig.noise_sigma_grey, noise_seed, rig.shot_noise);
}

}  // namespace flatscan
