#pragma once
// Ghosal-Mehrotra sub-pixel edge operator from Zernike moments (paper eq. 2.1-2.5).
//
// On a 7x7 window whose inscribed circle (radius N/2 = 3.5 px) is the unit disc, with
// area-exact masks for
//   M   = integral of f (x, y) dA      (the first-order moment Z11, up to 2/pi)
//   M20 = integral of f (2 rho^2 - 1) dA  (Z20, up to 3/pi)
// an ideal step of height h whose edge line lies at distance l (unit-disc units) from
// the centre along the unit normal (cos theta, sin theta) (pointing to the bright
// side) gives exactly
//   theta = atan2(M_y, M_x),  |M| = (2/3) h (1 - l^2)^{3/2},  M20 = l |M|,
// so l = M20 / |M|, h = 3 |M| / (2 (1 - l^2)^{3/2}) and the edge point is
//   centre + 3.5 l (cos theta, sin theta).
// theta comes from the first-order moment (Z11): taking it from Z31, as some public
// code does, is wrong. Under blur the operator underestimates |l| (docs/design.md section 6.1).
#include <opencv2/core.hpp>

namespace flatscan {

struct ZernikeEdge {
  double nx = 0, ny = 0;  // unit normal, dark -> bright
  double offset_px = 0;   // signed distance of the edge from the window centre along n
  double step = 0;        // step height h, grey levels
  bool valid = false;     // |l| < 1 and a non-zero gradient
};

// The operator at integer pixel (u, v); requires 3 <= u < cols - 3, 3 <= v < rows - 3.
ZernikeEdge ZernikeEdgeAt(const cv::Mat1b& image, int u, int v);

}  // namespace flatscan
