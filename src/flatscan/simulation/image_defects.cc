#include "flatscan/simulation/image_defects.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "flatscan/util/error.h"
#include "flatscan/util/random.h"

namespace flatscan {
namespace {

double Draw(Random& rng, const Range& r) { return r.lo == r.hi ? r.lo : rng.Uniform(r.lo, r.hi); }

Eigen::Vector2d RandomUnit2(Random& rng) {
  const double a = rng.Uniform(0, 2 * M_PI);
  return {std::cos(a), std::sin(a)};
}

Eigen::Vector3d RandomUnit3(Random& rng) {
  const double z = rng.Uniform(-1, 1), a = rng.Uniform(0, 2 * M_PI), s = std::sqrt(1 - z * z);
  return {s * std::cos(a), s * std::sin(a), z};
}

// Specks: the first round(fraction * n) touch the outline (centre one radius outside a
// random outline point, along its outward normal, less 20% so that they overlap it);
// the others lie anywhere within 2 mm of the part's bounding box.
std::vector<DustSpeck> DrawSpecks(const ImageEffectsSpec& spec, const PartGeometry& g, const Rigid3d& support_from_part,
                                  Random& rng) {
  const int n = spec.dust_specks[0] + static_cast<int>(rng.Uniform() * (spec.dust_specks[1] - spec.dust_specks[0] + 1));
  const int touching = static_cast<int>(std::lround(spec.dust_touching_fraction * n));
  const std::vector<Eigen::Vector2d> outline = g.SampleOuterOutline(0.05);
  std::vector<DustSpeck> specks;
  for (int i = 0; i < n && outline.size() >= 3; ++i) {
    DustSpeck s;
    s.radius_mm = 0.5e-3 * Draw(rng, spec.dust_diameter_um);
    s.touching = i < touching;
    if (s.touching) {
      const size_t k = std::min(outline.size() - 1, static_cast<size_t>(rng.Uniform() * outline.size()));
      const Eigen::Vector2d tangent = outline[(k + 1) % outline.size()] - outline[(k + outline.size() - 1) % outline.size()];
      Eigen::Vector2d normal(tangent.y(), -tangent.x());
      normal.normalize();
      if (g.OuterSdf(outline[k] + 0.01 * normal) < 0) normal = -normal;  // outward
      const Eigen::Vector2d local = outline[k] + 0.8 * s.radius_mm * normal;
      s.centre_mm = (support_from_part * Eigen::Vector3d(local.x(), local.y(), 0)).head<2>();
    } else {
      const Eigen::Vector2d local(rng.Uniform(-1, 1) * (g.half_width + 2), rng.Uniform(-1, 1) * (g.half_height + 2));
      s.centre_mm = (support_from_part * Eigen::Vector3d(local.x(), local.y(), 0)).head<2>();
    }
    specks.push_back(s);
  }
  return specks;
}

}  // namespace

bool ImageDefects::Any() const {
  return !gradient[0].isZero() || !gradient[1].isZero() || right_exposure != 1.0 || !specks.empty() || halo_gain > 0 ||
         shot_noise > 0 || !right_motion_mm.isZero() || f_number > 0;
}

ImageDefects SampleImageDefects(const ImageEffectsSpec& spec, const PartGeometry& geometry,
                                const Rigid3d& support_from_part, uint64_t seed) {
  Random rng(seed);
  ImageDefects d;
  for (Eigen::Vector2d& g : d.gradient) g = Draw(rng, spec.backlight_gradient) * RandomUnit2(rng);
  d.right_exposure = 1.0 + Draw(rng, spec.exposure_drift);
  d.specks = DrawSpecks(spec, geometry, support_from_part, rng);
  d.halo_gain = Draw(rng, spec.halo_gain);
  d.halo_width_px = spec.halo_width_px;
  d.shot_noise = spec.shot_noise;
  d.right_motion_mm = 1e-3 * Draw(rng, spec.motion_um) * RandomUnit3(rng);
  d.f_number = Draw(rng, spec.f_number);  // drawn last: the draws above do not change
  for (double& e : d.focus_error_mm) e = Draw(rng, spec.focus_error_mm);
  return d;
}

cv::Mat1f IlluminationImage(int width, int height, double vignetting, const ImageDefects& defects, int camera_index) {
  cv::Mat1f image(height, width);
  const double cx = (width - 1) / 2.0, cy = (height - 1) / 2.0;
  const double inv_r = 1.0 / std::hypot(cx, cy);
  const Eigen::Vector2d g = defects.gradient[camera_index];
  const double exposure = camera_index == 1 ? defects.right_exposure : 1.0;
  for (int v = 0; v < height; ++v) {
    float* row = image.ptr<float>(v);
    const double y = (v - cy) * inv_r;
    for (int u = 0; u < width; ++u) {
      const double x = (u - cx) * inv_r;
      row[u] = static_cast<float>(exposure * (1.0 - vignetting * (x * x + y * y)) * (1.0 + g.x() * x + g.y() * y));
    }
  }
  return image;
}

cv::Rect AddHalo(cv::Mat1f& radiance, const CoverageTile& part, double backlight_grey, double gain, double width_px) {
  if (part.roi.empty() || gain <= 0) return {};
  const int grow = static_cast<int>(std::ceil(6 * width_px));
  const cv::Rect area = cv::Rect(part.roi.x - grow, part.roi.y - grow, part.roi.width + 2 * grow,
                                 part.roi.height + 2 * grow) &
                        cv::Rect(0, 0, radiance.cols, radiance.rows);
  cv::Mat1f coverage(area.size(), 0.0f);
  part.coverage.copyTo(coverage(part.roi - area.tl()));
  cv::Mat1b outside = coverage < 0.5f;
  cv::Mat1f distance;
  cv::distanceTransform(outside, distance, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  for (int y = 0; y < area.height; ++y) {
    float* r = radiance.ptr<float>(area.y + y) + area.x;
    const float* c = coverage.ptr<float>(y);
    const float* d = distance.ptr<float>(y);
    for (int x = 0; x < area.width; ++x)
      r[x] += static_cast<float>(gain * backlight_grey * std::exp(-std::max(0.0f, d[x] - 0.5f) / width_px) * (1 - c[x]));
  }
  return area;
}

namespace {

// The ray (x, y, 1) through pixel (u, v) without the distortion.
Eigen::Vector2d PinholeRay(const Camera& camera, double u, double v) {
  return {(u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy};
}

// Depth (mm, along the optical axis) of the support plane seen through pixel (u, v);
// `guess` carries the previous pixel's undistorted ray to start Newton from. Where the
// distortion model cannot be inverted the pinhole ray stands in (the depth varies
// slowly: the blur there is close).
double SupportPlaneDepth(const Camera& camera, const Eigen::Vector3d& normal_cam, double offset, double u, double v,
                         Eigen::Vector2d& guess) {
  const Eigen::Vector2d xy = camera.PixelToNormalized({u, v}, guess);
  guess = std::isfinite(xy.x()) && std::isfinite(xy.y()) ? xy : PinholeRay(camera, u, v);
  return offset / normal_cam.dot(Eigen::Vector3d(guess.x(), guess.y(), 1.0));
}

}  // namespace

cv::Mat1f DefocusSigma(const Camera& camera, const Rigid3d& cam_from_support, const CameraSpec& lens, double sigma0_px,
                       double f_number, double focus_error_mm, const cv::Rect& rect) {
  cv::Mat1f sigma(rect.size(), static_cast<float>(sigma0_px));
  if (f_number <= 0) return sigma;
  // The plane z = 0 of the support frame in the camera frame: n . X = offset.
  const Eigen::Vector3d normal = cam_from_support.rotation * Eigen::Vector3d::UnitZ();
  const double offset = normal.dot(cam_from_support.translation);
  const double f = lens.focal_length_mm, aperture = f / f_number, pitch = 1e-3 * lens.pixel_size_um;
  const double z_focus = offset / normal.z() + focus_error_mm;  // the principal point's ray is (0, 0, 1)
  if (!(z_focus > 1.01 * f))
    ThrowInputError("image_effects.focus_error_mm: {} mm puts the focus {:.1f} mm from the lens, not beyond its focal "
                    "length of {} mm (expected a focus error that keeps the focus on the far side of the lens)",
                    focus_error_mm, z_focus, f);
  for (int y = 0; y < rect.height; ++y) {
    Eigen::Vector2d guess = PinholeRay(camera, rect.x, rect.y + y);
    float* row = sigma.ptr<float>(y);
    for (int x = 0; x < rect.width; ++x) {
      const double z = SupportPlaneDepth(camera, normal, offset, rect.x + x, rect.y + y, guess);
      const double c_px = aperture * f * std::abs(z - z_focus) / (z * (z_focus - f)) / pitch;
      row[x] = static_cast<float>(std::hypot(sigma0_px, c_px / 4));
    }
  }
  return sigma;
}

}  // namespace flatscan
