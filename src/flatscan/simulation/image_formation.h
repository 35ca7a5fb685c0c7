#pragma once
// From scene radiance to an 8-bit image: irradiance (linear grey levels), lens blur
// (Gaussian PSF), sensor noise (Gaussian), rounding and clipping to 8 bits.
#include <cstdint>
#include <functional>
#include <vector>

#include <opencv2/core.hpp>

#include "flatscan/simulation/coverage_renderer.h"
#include "flatscan/simulation/scene_config.h"

namespace flatscan {

// Backlight irradiance: grey * (1 - vignetting * r^2), r the distance from the image
// centre divided by the half diagonal.
cv::Mat1f BacklightImage(int width, int height, double grey, double vignetting);

// Blends `tile` into `image`: image = image * (1 - c) + grey * c inside tile.roi.
void BlendCoverage(cv::Mat1f& image, const CoverageTile& tile, double grey);

// Blurs `image` in place with a Gaussian of sigma `sigma_px`, only inside `regions`
// grown by 4 sigma (elsewhere the image is smooth and blur would not change it by
// more than 1e-4 grey). Empty regions: the whole image.
void BlurRegions(cv::Mat1f& image, double sigma_px, const std::vector<cv::Rect>& regions);

// The blur's sigma (px) at every pixel of a rectangle of the image.
using SigmaMap = std::function<cv::Mat1f(const cv::Rect&)>;

// Space-varying Gaussian blur (a lens whose defocus changes across the image), inside
// `regions` as BlurRegions: the pixel p takes the blur of sigma sigma_px(p). Each region
// is blurred at sigma levels at most 0.05 px apart spanning the map's range there, and
// each pixel blends the two levels around its sigma linearly (exact at a level; between
// two levels s1, s2 the blend's second moment is off by at most (s2 - s1)^2 / 4 =
// 0.0006 px^2); two levels are in memory at a time. The map must vary slowly (over many
// kernel widths), and over a region be largest at one of its corners (as a map varying
// monotonically across it is): the region is grown by the kernel's reach there.
void BlurRegionsVarying(cv::Mat1f& image, const SigmaMap& sigma_px, const std::vector<cv::Rect>& regions);

// Adds Gaussian noise (deterministic for `seed`, independent of the number of
// threads), rounds and clips to 8 bits. The noise's variance at a pixel of value I is
// noise_sigma^2 + shot_noise * I (grey levels; shot_noise > 0 adds photon noise).
cv::Mat1b QuantizeWithNoise(const cv::Mat1f& image, double noise_sigma, uint64_t seed, double shot_noise = 0.0);

}  // namespace flatscan
