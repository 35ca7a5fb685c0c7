#pragma once
// Sub-pixel boundary detection (docs/design.md, Step 2; paper section 2.2).
//
// Pipeline: Canny gives integer edge pixels (our fused implementation, canny.h, with
// cv::Canny's decisions), restricted to a band around the part found on a 4x reduced
// image (so cost grows with the boundary's length, not the image's area); the pixels
// are chained into ordered contours (outer boundary and holes, each its own id); each
// pixel's position is refined along the grid direction nearest its Sobel normal with
// a model of the blurred edge (see edge_refinement.h; the 7x7 Zernike-moment operator
// of Ghosal-Mehrotra is the reference method kZernike), the pieces one edge was left in
// (chains ending at a spur) are joined (chain_linking.h), and the chain is smoothed by
// local circle fits with a curvature correction.
//
// Conventions: pixel (u, v) integer coordinates are pixel centres. The normal
// (nx, ny) is a unit vector pointing from dark to bright; `step` is the grey-level
// step height (bright minus dark) of the edge.
#include <functional>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace flatscan {

struct EdgePoint {
  double x = 0, y = 0;    // px
  double nx = 0, ny = 0;  // unit normal, dark -> bright
  double step = 0;        // grey levels
  int contour = -1;       // contour id
};

struct ContourInfo {
  int begin = 0, end = 0;  // range in BoundaryResult::points
  bool closed = false;
  double length_px = 0.0;
};

enum class EdgeMethod {
  kCannyPixel,  // integer Canny pixels (reference row)
  kZernike,     // plain Ghosal-Mehrotra 7x7 operator (the paper's refinement; reference row)
  kBlurModel,   // ours: Sobel direction + blurred-edge model refinement
};

struct BoundaryOptions {
  EdgeMethod method = EdgeMethod::kBlurModel;
  // Canny hysteresis thresholds on the L2 Sobel gradient magnitude (3x3 aperture).
  double canny_low = 40.0;
  double canny_high = 100.0;
  // Find the part's region on a reduced image and work only in a band around its
  // boundary (backlit images). False: the whole image (e.g. textured scenes).
  bool restrict_to_part = true;
  // Gaussian blur of the lens (px) if known; <= 0: estimated from the image.
  double blur_sigma_px = 0.0;
  // Contours with fewer points are dropped (dust, noise).
  int min_contour_points = 8;
};

struct BoundaryResult {
  std::vector<EdgePoint> points;       // grouped by contour, each in chain order
  std::vector<ContourInfo> contours;
  double blur_sigma_px = 0.0;          // used or estimated
  std::vector<cv::Rect> regions;       // where Canny ran
  int edge_pixels = 0;                 // Canny pixels considered
  // With restrict_to_part: grey levels of the dark (part) and bright (backlight)
  // classes and the fraction of saturated samples, for exposure checks.
  double dark_level = 0, bright_level = 0, saturated_fraction = 0;
};

// `image`: 8-bit single channel. Throws InputError if empty, not 8-bit grey, or
// smaller than the 7x7 operator window.
BoundaryResult DetectBoundary(const cv::Mat& image, const BoundaryOptions& options = {});

// Crossings of the contours with the rows of a frame the caller maps points into
// (identity: the image rows; or rectified rows). Consecutive chain points are mapped,
// and every integer row y = k between two of them gets a crossing by linear
// interpolation along the chain (paper section 2.2.1); normals are interpolated and
// mapped through the local Jacobian of the map. A segment with an end the map takes to
// NaN gives no crossing.
struct RowCrossing {
  double x = 0;         // in the mapped frame
  int row = 0;          // integer row in the mapped frame
  double nx = 0, ny = 0;  // unit normal in the mapped frame, dark -> bright
  double step = 0;
  int contour = -1;
  int index = 0;        // chain index of the point before the crossing
  double raw_x = 0, raw_y = 0;  // the same crossing in the image (interpolated likewise)
};
using PointMap = std::function<Eigen::Vector2d(const Eigen::Vector2d&)>;
// `mapped_chains`, if given, receives every contour's chain points mapped (one vector
// per contour, in chain order; empty for contours of fewer than 2 points).
std::vector<RowCrossing> CrossRows(const BoundaryResult& boundary, const PointMap& map = {},
                                   std::vector<std::vector<Eigen::Vector2d>>* mapped_chains = nullptr);

}  // namespace flatscan
