#pragma once
// Matching boundary crossings along rectified rows (paper section 2.3).
//
// For each left crossing the candidates are the right crossings on the same row
// whose boundary runs the same way (the normal's x component has the same sign) and
// whose disparity lies in the range a part on the support plane can produce. Each
// candidate gets the fused cost (eq. 2.10)
//   S = alpha C_SSD + beta C_dir + gamma C_dis
// with
//   C_SSD  sum of squared grey differences over N x N windows centred on the two
//          crossings, sampled from the raw images through the rectification (a local
//          affine map per crossing), divided by N^2 h_L h_R so it is scale free;
//   C_dir  eq. 2.7 on the step heights h and normals:
//          |h_L - h_R| / (k (h_L + h_R) (cos<n_L, n_R> + sigma));
//   C_dis  eq. 2.9: |x_L - x_R - d_ref| / (beta0 + n delta_beta), d_ref the mean
//          disparity of the n matches already made within N rows on the same left
//          contour (lambda (x_L - x_R) when there are none, lambda = 1: no penalty).
// Winner takes all, then a left-right check keeps only mutual best matches.
// Crossings where the boundary runs within asin(min_abs_nx) of the rows are not
// matched: there the row crossing is ill-conditioned (docs/design.md section 6.6).
#include <functional>
#include <vector>

#include <opencv2/core.hpp>

#include "flatscan/boundary/boundary.h"
#include "flatscan/calibration/rectification.h"

namespace flatscan {

struct MatchingParams {
  double alpha = 1.0;
  double beta = 1.0;
  double gamma = 1.0;
  int window = 5;             // N
  double k = 1.0;
  double sigma = 2.0;         // > 1 keeps the C_dir denominator positive
  double beta0 = 1.0;         // px
  double delta_beta = 0.25;   // px per matched neighbour
  // Skip boundaries within asin(min_abs_nx) of the rows (2.3 degrees). Measured on
  // parts turned 4 degrees to the baseline (16 paper-preset parts): 0.08 (4.6 degrees)
  // left two sides to the warp prior (coverage 0.44, |error| p95 12.1 um, max 45 um);
  // 0.04 measures them (coverage 0.96, p95 3.9 um, max 10 um).
  double min_abs_nx = 0.04;
  bool left_right_check = true;
};

struct StereoMatch {
  int left = -1, right = -1;  // indices into the crossing lists
  double cost = 0;
};

// Disparity range allowed at a left crossing (x, row): [lo, hi].
using DisparityRange = std::function<std::pair<double, double>(double x, int row)>;

// `left`, `right`: the crossings of each image with the rectified rows (CrossRows
// through `left_rectifier` / `right_rectifier`, which also map the matching windows
// back into the raw images). Returns the mutual best matches, in left crossing order.
std::vector<StereoMatch> MatchCrossings(const std::vector<RowCrossing>& left, const std::vector<RowCrossing>& right,
                                        const cv::Mat1b& left_image, const cv::Mat1b& right_image,
                                        const PointRectifier& left_rectifier, const PointRectifier& right_rectifier,
                                        const DisparityRange& range, const MatchingParams& params = {});

}  // namespace flatscan
