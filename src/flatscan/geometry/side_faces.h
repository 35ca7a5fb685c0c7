#pragma once
// How a cut sheet's side faces stand: the direction S of the face from its bottom
// edge to its top edge, at each point of the outline (docs/design.md section 6.4).
//
// A sheet is cut square (faces perpendicular to the sheet) and then warped; bending
// keeps the material's normals normal to its mid-surface, and resting on the support
// is a rigid motion, so the faces stay perpendicular to the LOCAL sheet: at a rim
// point where the sheet slopes by g (the warp's gradient) the face leans by atan |g|
// from the sheet's normal at the part's centre. Against a backlight a camera whose
// silhouette is the top edge sees B + t S (B the bottom edge, t the side height), so
// a wrong S moves the triangulated rim: by about (Z / B) t (d . n_out) / |n_x| in
// height (Z / B the depth-to-baseline ratio, d the error of S's horizontal part, n_out
// the rim's outward normal, |n_x| how steeply the rim crosses the rows).
#include <string>

namespace flatscan {

enum class SideFaceModel {
  kLocalNormal,    // "local": perpendicular to the sheet at each point (real cut sheets)
  kCentreNormal,   // "centre": along the sheet's normal at the part's centre (exact for a flat, tilted sheet)
  kSupportNormal,  // "support": along the support plane's normal (a flat part lying flat)
};

// "local" / "centre" / "support"; Parse throws InputError naming the accepted values.
std::string SideFaceModelName(SideFaceModel model);
SideFaceModel ParseSideFaceModel(const std::string& name);

}  // namespace flatscan
