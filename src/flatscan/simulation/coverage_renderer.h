#pragma once
// Exact area coverage of an occluder in a camera image.
//
// Pixel (u, v) covers the square [u - 0.5, u + 0.5] x [v - 0.5, v + 0.5] (pixel centres
// at integers, docs/conventions.md). Its coverage is the fraction of that square whose
// rays, through the distorted camera model, hit the occluder.
//
// Pixels far from the silhouette (|signed distance| larger than the pixel's extent,
// checked on 8x8 blocks first) are 0 or 1. At the silhouette the square is cut into
// 4 strips across the boundary's dominant direction; on each strip edge the
// boundary crossing is found by ray casting and root finding to 1e-7 px, and the
// covered fraction, a clamped linear function of the crossing between two strip
// edges, is integrated exactly. That is exact for a straight boundary and
// O(curvature / 16^2) otherwise. Pixels with more than one boundary (corners of a
// chessboard, slivers) fall back to 16 x 16 point samples.
#include <opencv2/core.hpp>

#include "flatscan/geometry/camera.h"
#include "flatscan/geometry/rigid3.h"
#include "flatscan/simulation/occluder.h"

namespace flatscan {

struct CoverageTile {
  cv::Rect roi;            // in image pixels, clipped to the image
  cv::Mat1f coverage;      // roi-sized, values in [0, 1]
};

CoverageTile RenderCoverage(const Camera& camera, const Rigid3d& cam_from_support,
                            const Occluder& occluder, int margin_px = 4);

// Mean over tau in [0, 1] of clamp(a0 + (a1 - a0) tau, 0, 1).
double MeanOfClampedLinear(double a0, double a1);

}  // namespace flatscan
