#pragma once
// The simulated part: a warped sheet of thickness t with an outline (rounded
// rectangle with optional round holes and rectangular edge notches) and optional
// folded-down walls along its outer edge.
//
// Part frame (mm): the footprint lies in (x, y) centred on the origin, z up. The
// sheet's bottom surface is B(q) = (q, w(q)) over the footprint's points q, and the
// sheet is {B(q) + s S(q) : 0 <= s <= t}, S(q) the side-face direction
// (geometry/side_faces.h): the unit normal (-grad w, 1) / |.| of the bottom surface
// (side_faces local: a square cut sheet, then warped; its top is the offset surface
// and its side faces stand perpendicular to the local sheet) or +z (centre: the
// sheet's normal at the origin, where grad w = 0; top z = w + t, faces along z). With
// walls of height H the outer band of width t (the wall) extends down to s = -H, so
// the part rests on the walls' bottom edges. The warp, with X = x / a and Y = y / b
// (a, b the half sizes), is
//   w = bend_x X^2 + bend_y Y^2 + twist X Y + c30 X^3 + c21 X^2 Y + c12 X Y^2 + c03 Y^3,
// each coefficient in mm (constant and linear terms are rigid motions and omitted),
// plus an optional waviness, a plane wave across the sheet (a rolled strip's):
//   wave_mm sin(2 pi (x cos(a) + y sin(a)) / wave_length_mm + phase).
//
// The bottom rim is the outer outline's bottom edge: the curve the part stands on,
// and the set over which flatness is defined (docs/conventions.md).
#include <array>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "flatscan/geometry/rigid3.h"
#include "flatscan/geometry/side_faces.h"
#include "flatscan/simulation/occluder.h"
#include "flatscan/simulation/scene_config.h"
#include "flatscan/util/random.h"

namespace flatscan {

struct Hole {
  Eigen::Vector2d center;
  double radius = 0.0;
};

// Axis-aligned box cut into the outline, centred on an edge.
struct Notch {
  Eigen::Vector2d center;
  Eigen::Vector2d half_size;
};

// A burr left by the cutting at an outer outline point (docs/simulator.md, "Burrs"): a
// half-disc of radius size_mm standing out of the outline in the sheet's plane, or
// (under_rim) a sliver standing size_mm below the bottom rim there, which the part may
// rest on.
struct Burr {
  Eigen::Vector2d centre;  // on the outline without burrs
  double size_mm = 0.0;
  bool under_rim = false;
};

struct Warp {
  double bend_x = 0, bend_y = 0, twist = 0;
  double c30 = 0, c21 = 0, c12 = 0, c03 = 0;
  // Waviness (see the top of this file): amplitude (0: none), wavelength, direction a
  // of the wave's travel in the part frame, and phase.
  double wave_mm = 0, wave_length_mm = 2.0, wave_direction_rad = 0, wave_phase_rad = 0;
};

struct PartGeometry {
  double half_width = 5.0;   // a, mm
  double half_height = 5.0;  // b, mm
  double corner_radius = 0.5;
  std::vector<Hole> holes;
  std::vector<Notch> notches;
  std::vector<Burr> burrs;
  double thickness = 0.2;    // t, mm
  double wall_height = 0.0;  // H, mm (0: flat sheet)
  Warp warp;
  SideFaceModel side_faces = SideFaceModel::kLocalNormal;  // local or centre (see the top of this file)

  // Signed distance (mm, negative inside) to the outer outline (rounded rectangle
  // minus notches, plus the burrs in the sheet's plane), and to the footprint (also
  // minus holes).
  double OuterSdf(const Eigen::Vector2d& p) const;
  double FootprintSdf(const Eigen::Vector2d& p) const;
  // w(x, y) and its gradient.
  double WarpZ(const Eigen::Vector2d& p) const;
  Eigen::Vector2d WarpGradient(const Eigen::Vector2d& p) const;
  // S(q): unit side-face direction over footprint point q (bottom edge to top edge).
  Eigen::Vector3d FaceDirection(const Eigen::Vector2d& q) const;
  // B(q) + s S(q), and its inverse: the (q, s) of a point x near the sheet (s returned
  // through `s`; to 1e-10 mm for |s| S's curvature << 1).
  Eigen::Vector3d SheetPoint(const Eigen::Vector2d& q, double s) const;
  // `start`: a guess of q (default: x's own (x, y)); a close one saves steps.
  Eigen::Vector2d SheetCoordinates(const Eigen::Vector3d& x, double* s, const Eigen::Vector2d* start = nullptr) const;
  // The bottom rim's point over outline point p: B(p) - H S(p) (B(p) without walls).
  Eigen::Vector3d RimPoint(const Eigen::Vector2d& p) const { return SheetPoint(p, -wall_height); }
  // Total height of the silhouette-forming side face: t + H.
  double SideHeight() const { return thickness + wall_height; }

  // Points on the outer outline, about `spacing` mm apart (part frame, 2D); a burr's
  // arc more densely (a quarter of its size apart).
  std::vector<Eigen::Vector2d> SampleOuterOutline(double spacing) const;
  std::vector<Eigen::Vector2d> SampleOutlineWithoutBurrs(double spacing) const;
  // Bottom rim points (3D, part frame).
  std::vector<Eigen::Vector3d> SampleRim(double spacing) const;
  // Samples of the whole bottom surface (rim, hole edges, interior), for the rest pose.
  std::vector<Eigen::Vector3d> SampleBottomSurface(double spacing) const;
  // Centre of mass (uniform sheet and walls).
  Eigen::Vector3d CenterOfMass() const;
};

// Random part from the scene's part ranges (and its side-face model).
PartGeometry SamplePartGeometry(const PartSpec& spec, Random& rng);

// `geometry` with burrs drawn from spec.burrs at random outline points (none when
// spec.burrs is [0, 0]). Deterministic for `seed`; the part's shape is otherwise unchanged.
PartGeometry WithBurrs(PartGeometry geometry, const PartSpec& spec, uint64_t seed);

// `geometry` with a waviness drawn from spec.waviness_um and spec.waviness_wavelength_mm
// (a uniform direction and phase; none when spec.waviness_um.hi is 0). Deterministic
// for `seed`, which is all it draws from: the same parts with and without it.
PartGeometry WithWaviness(PartGeometry geometry, const PartSpec& spec, uint64_t seed);

// A part placed on the support: support_from_part includes the rest pose.
class PartOccluder : public Occluder {
 public:
  PartOccluder(const PartGeometry& geometry, const Rigid3d& support_from_part);
  double RaySignedDistance(const Ray& ray) const override;
  std::vector<Eigen::Vector3d> BoundingPoints() const override;

 private:
  // Ray parameter where the ray o + l d (part frame) meets z = w(x, y) + offset, and
  // where it meets the sheet's level s = offset, from the former's `l`.
  double IntersectSurface(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double offset) const;
  double RefineToLevel(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double offset, double l) const;
  const PartGeometry& geometry_;
  double lean_ = 0;  // largest |q - x_xy| of a point x of the part (sheet coordinates), mm
  Rigid3d support_from_part_;
  Rigid3d part_from_support_;
};

// Truth of a placed part (docs/design.md section 5): computed from the geometry only.
struct PartTruth {
  Rigid3d support_from_part;         // rest pose and placement
  std::array<int, 3> contacts{};     // indices into the bottom-surface samples
  std::vector<Eigen::Vector3d> rim;  // bottom rim, support frame
  double flatness_mm = 0.0;
  double lsq_pv_mm = 0.0;
  double minzone_mm = 0.0;
};

// Rests the part on the support (three contact points of its lower convex hull under
// its centre of mass) and places it: rotation about the support normal by
// `rotation_deg`, then its centre of mass's footprint moved to `position` (mm).
PartTruth RestAndPlacePart(const PartGeometry& geometry, double rotation_deg,
                           const Eigen::Vector2d& position);

// The same part with its warp scaled so that its true flatness_mm (at rest, docs/design.md
// section 5) is `flatness_mm` to within 1e-7 mm. Scaling the warp scales every rim
// height about the same three contacts, so a few secant steps converge. A part with
// no warp first gets a unit bend in x. Throws std::invalid_argument for a negative
// target.
PartGeometry WithFlatness(PartGeometry geometry, double flatness_mm);

nlohmann::json PartGeometryToJson(const PartGeometry& geometry);

}  // namespace flatscan
