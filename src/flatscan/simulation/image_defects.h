#pragma once
// Defects of real backlit images (docs/simulator.md, "Image defects"): what one part
// pair gets of the effects its scene turns on (SceneConfig::image_effects), drawn once
// per pair so that both cameras see the same dust and the same motion.
#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "flatscan/geometry/camera.h"
#include "flatscan/geometry/rigid3.h"
#include "flatscan/simulation/coverage_renderer.h"
#include "flatscan/simulation/part_model.h"
#include "flatscan/simulation/scene_config.h"

namespace flatscan {

// A speck of dust on the backlight: an opaque disc on the support plane (z = 0).
struct DustSpeck {
  Eigen::Vector2d centre_mm;
  double radius_mm = 0;
  bool touching = false;  // placed touching the part's outline
};

struct ImageDefects {
  // Per camera (left, right): the backlight's brightness factor 1 + gradient . r, r the
  // pixel's offset from the image centre over the half diagonal.
  std::array<Eigen::Vector2d, 2> gradient = {Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero()};
  double right_exposure = 1.0;  // camera 2's brightness relative to camera 1's
  std::vector<DustSpeck> specks;
  double halo_gain = 0, halo_width_px = 2.0;
  double shot_noise = 0;  // noise variance per grey level of signal
  Eigen::Vector3d right_motion_mm = Eigen::Vector3d::Zero();  // the part's displacement in camera 2's exposure
  double f_number = 0;  // the lenses' aperture (f/N); 0: no defocus (the lens blur alone)
  std::array<double, 2> focus_error_mm = {0, 0};  // per camera: focus distance minus the support plane's

  bool Any() const;
};

// Draws one pair's defects from `spec` for a part at `support_from_part`
// (deterministic for `seed`).
ImageDefects SampleImageDefects(const ImageEffectsSpec& spec, const PartGeometry& geometry,
                                const Rigid3d& support_from_part, uint64_t seed);

// The backlight's brightness factor over a width x height image: vignetting
// (1 - vignetting r^2), the defects' gradient for `camera_index` (0 left, 1 right) and,
// for the right camera, its exposure.
cv::Mat1f IlluminationImage(int width, int height, double vignetting, const ImageDefects& defects, int camera_index);

// Adds the halo around a part's silhouette to `radiance` (linear grey, before blur):
// radiance += gain * backlight_grey * exp(-d / width) * (1 - coverage), d the distance in
// pixels from the silhouette (coverage >= 0.5). Returns the region it changed.
cv::Rect AddHalo(cv::Mat1f& radiance, const CoverageTile& part, double backlight_grey, double gain, double width_px);

// Depth of field: the blur's sigma (px) at each pixel of `rect` of a camera whose lens
// (focal length f = lens.focal_length_mm, pixels lens.pixel_size_um) at aperture f/N is
// focused `focus_error_mm` beyond the support plane's depth at the principal point (z_f;
// InputError if that is not beyond the focal length).
// A thin lens images a point at depth z as a disc of diameter
//   c = (f / N) f |z - z_f| / (z (z_f - f))          (mm on the sensor)
// and a uniform disc of diameter c has the second moment of a Gaussian of sigma c / 4,
// added in quadrature to the lens's own blur sigma0_px. z is the depth of the support
// plane seen at the pixel (the part stands at most a millimetre above it, small against
// the depth of field), so the blur varies across the part as the plane's depth does.
cv::Mat1f DefocusSigma(const Camera& camera, const Rigid3d& cam_from_support, const CameraSpec& lens, double sigma0_px,
                       double f_number, double focus_error_mm, const cv::Rect& rect);

}  // namespace flatscan
