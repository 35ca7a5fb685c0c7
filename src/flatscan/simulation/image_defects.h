#pragma once
// Defects of real backlit images (docs/simulator.md, "Image defects"): what one part
// pair gets of the effects its scene turns on (SceneConfig::image_effects), drawn once
// per pair so that both cameras see the same dust and the same motion.
#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

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

}  // namespace flatscan
