#include "flatscan/simulation/part_model.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <Eigen/Geometry>

#include "flatscan/flatness/flatness_metrics.h"
#include "flatscan/simulation/rest_pose.h"

namespace flatscan {
namespace {

double BoxSdf(const Eigen::Vector2d& p, const Eigen::Vector2d& center, const Eigen::Vector2d& half) {
  return RoundedRectSdf(p - center, half.x(), half.y(), 0.0);
}

// Minimum of f over the ray segment [a, b] (ray parameters), from f at both ends, the
// middle, and the vertex of the parabola through them (the segment crosses a sheet a
// fraction of a millimetre thick, short next to the outline's curvature, so this is
// accurate to its cubic term).
template <typename F>
double SegmentMinimum(const F& f, double a, double b) {
  const double fa = f(a);
  if (std::abs(b - a) < 1e-15) return fa;
  const double fb = f(b), fm = f(0.5 * (a + b));
  double best = std::min({fa, fb, fm});
  // Parabola through the three values: f(t) = fa + b1 t + b2 t^2, t in [0, 1].
  const double b2 = 2 * (fa - 2 * fm + fb);
  if (b2 > 1e-15) {
    const double b1 = 4 * fm - 3 * fa - fb;
    const double t = -b1 / (2 * b2);
    if (t > 0 && t < 1) best = std::min(best, f(a + t * (b - a)));
  }
  return best;
}

// The waviness's wave vector k (rad per mm) and phase k . p + phase at p.
Eigen::Vector2d WaveVector(const Warp& w) {
  return 2 * M_PI / w.wave_length_mm * Eigen::Vector2d(std::cos(w.wave_direction_rad), std::sin(w.wave_direction_rad));
}
double WavePhase(const Warp& w, const Eigen::Vector2d& p) { return WaveVector(w).dot(p) + w.wave_phase_rad; }

}  // namespace

double PartGeometry::OuterSdf(const Eigen::Vector2d& p) const {
  double d = RoundedRectSdf(p, half_width, half_height, corner_radius);
  for (const Notch& n : notches) d = std::max(d, -BoxSdf(p, n.center, n.half_size));
  for (const Burr& b : burrs)
    if (!b.under_rim) d = std::min(d, CircleSdf(p, b.centre, b.size_mm));
  return d;
}

double PartGeometry::FootprintSdf(const Eigen::Vector2d& p) const {
  double d = OuterSdf(p);
  for (const Hole& h : holes) d = std::max(d, -CircleSdf(p, h.center, h.radius));
  return d;
}

double PartGeometry::WarpZ(const Eigen::Vector2d& p) const {
  const double X = p.x() / half_width, Y = p.y() / half_height;
  const Warp& c = warp;
  const double smooth = c.bend_x * X * X + c.bend_y * Y * Y + c.twist * X * Y + c.c30 * X * X * X +
                        c.c21 * X * X * Y + c.c12 * X * Y * Y + c.c03 * Y * Y * Y;
  if (c.wave_mm == 0) return smooth;
  return smooth + c.wave_mm * std::sin(WavePhase(c, p));
}

Eigen::Vector2d PartGeometry::WarpGradient(const Eigen::Vector2d& p) const {
  const double X = p.x() / half_width, Y = p.y() / half_height;
  const Warp& c = warp;
  const double dX = 2 * c.bend_x * X + c.twist * Y + 3 * c.c30 * X * X + 2 * c.c21 * X * Y + c.c12 * Y * Y;
  const double dY = 2 * c.bend_y * Y + c.twist * X + c.c21 * X * X + 2 * c.c12 * X * Y + 3 * c.c03 * Y * Y;
  Eigen::Vector2d gradient(dX / half_width, dY / half_height);
  if (c.wave_mm != 0) gradient += c.wave_mm * std::cos(WavePhase(c, p)) * WaveVector(c);
  return gradient;
}

Eigen::Vector3d PartGeometry::FaceDirection(const Eigen::Vector2d& q) const {
  if (side_faces == SideFaceModel::kCentreNormal) return Eigen::Vector3d::UnitZ();
  const Eigen::Vector2d g = WarpGradient(q);
  return Eigen::Vector3d(-g.x(), -g.y(), 1.0).normalized();
}

Eigen::Vector3d PartGeometry::SheetPoint(const Eigen::Vector2d& q, double s) const {
  return Eigen::Vector3d(q.x(), q.y(), WarpZ(q)) + s * FaceDirection(q);
}

Eigen::Vector2d PartGeometry::SheetCoordinates(const Eigen::Vector3d& x, double* s, const Eigen::Vector2d* start) const {
  // x = B(q) + s S(q): s = (x_z - w(q)) / S_z(q), q = x_xy - s S_xy(q), a fixed point
  // that contracts by about |s| times S's rate of change plus the squared slope
  // (below 0.02 for slopes up to 0.12): a few steps from q = x_xy to 1e-10 mm, far
  // below what the measurement can see.
  Eigen::Vector2d q = start ? *start : Eigen::Vector2d(x.head<2>());
  for (int iter = 0; iter < 12; ++iter) {
    const Eigen::Vector3d f = FaceDirection(q);
    *s = (x.z() - WarpZ(q)) / f.z();
    const Eigen::Vector2d next = x.head<2>() - *s * f.head<2>();
    const bool settled = (next - q).squaredNorm() < 1e-20;  // 1e-10 mm
    q = next;
    if (settled) break;
  }
  return q;
}

namespace {

// The arc of burr b that stands out of the outline, counter-clockwise about its centre
// (the outline's own direction), points at most `spacing` and half the burr's size apart.
std::vector<Eigen::Vector2d> BurrArc(const PartGeometry& g, const Burr& b, double spacing) {
  const int n = std::max(16, static_cast<int>(std::ceil(2 * M_PI * b.size_mm / std::min(spacing, b.size_mm / 2))));
  std::vector<Eigen::Vector2d> circle(n);
  std::vector<bool> on(n);
  for (int i = 0; i < n; ++i) {
    const double a = 2 * M_PI * i / n;
    circle[i] = b.centre + b.size_mm * Eigen::Vector2d(std::cos(a), std::sin(a));
    on[i] = std::abs(g.OuterSdf(circle[i])) < 1e-9;
  }
  int start = 0;  // the first point on the outline after one that is not
  while (start < n && !(on[start] && !on[(start + n - 1) % n])) ++start;
  std::vector<Eigen::Vector2d> arc;
  for (int k = 0; k < n && start < n && on[(start + k) % n]; ++k) arc.push_back(circle[(start + k) % n]);
  return arc;
}

}  // namespace

std::vector<Eigen::Vector2d> PartGeometry::SampleOuterOutline(double spacing) const {
  const std::vector<Eigen::Vector2d> plain = SampleOutlineWithoutBurrs(spacing);
  bool any = false;
  for (const Burr& b : burrs) any = any || !b.under_rim;
  if (!any) return plain;
  // The outline points a burr covers are inside the part now; its arc (points at most
  // half its size apart) takes their place, in the outline's order.
  std::vector<Eigen::Vector2d> out;
  std::vector<bool> placed(burrs.size(), false);
  for (const Eigen::Vector2d& p : plain) {
    if (OuterSdf(p) > -1e-9) {
      out.push_back(p);
      continue;
    }
    for (size_t k = 0; k < burrs.size(); ++k) {
      const Burr& b = burrs[k];
      if (b.under_rim || placed[k] || CircleSdf(p, b.centre, b.size_mm) >= 0) continue;
      const std::vector<Eigen::Vector2d> arc = BurrArc(*this, b, spacing);
      out.insert(out.end(), arc.begin(), arc.end());
      placed[k] = true;
    }
  }
  // A burr narrower than the spacing may fall between two outline points: its arc goes
  // after the nearest one.
  for (size_t k = 0; k < burrs.size(); ++k) {
    if (burrs[k].under_rim || placed[k] || out.empty()) continue;
    size_t nearest = 0;
    for (size_t i = 1; i < out.size(); ++i)
      if ((out[i] - burrs[k].centre).squaredNorm() < (out[nearest] - burrs[k].centre).squaredNorm()) nearest = i;
    const std::vector<Eigen::Vector2d> arc = BurrArc(*this, burrs[k], spacing);
    out.insert(out.begin() + static_cast<std::ptrdiff_t>(nearest) + 1, arc.begin(), arc.end());
  }
  return out;
}

std::vector<Eigen::Vector2d> PartGeometry::SampleOutlineWithoutBurrs(double spacing) const {
  std::vector<Eigen::Vector2d> out;
  const double r = corner_radius;
  const double sx = half_width - r, sy = half_height - r;
  // Rounded rectangle, counter-clockwise from (a, -sy): straight edges and quarter arcs.
  auto add_segment = [&](Eigen::Vector2d p, Eigen::Vector2d q) {
    const int n = std::max(1, static_cast<int>(std::ceil((q - p).norm() / spacing)));
    for (int i = 0; i < n; ++i) out.push_back(p + (q - p) * (static_cast<double>(i) / n));
  };
  auto add_arc = [&](Eigen::Vector2d c, double a0) {
    if (r <= 0) {
      out.push_back(c);
      return;
    }
    const int n = std::max(1, static_cast<int>(std::ceil(r * M_PI / 2 / spacing)));
    for (int i = 0; i < n; ++i) {
      const double a = a0 + (M_PI / 2) * i / n;
      out.push_back(c + r * Eigen::Vector2d(std::cos(a), std::sin(a)));
    }
  };
  add_segment({half_width, -sy}, {half_width, sy});
  add_arc({sx, sy}, 0.0);
  add_segment({sx, half_height}, {-sx, half_height});
  add_arc({-sx, sy}, M_PI / 2);
  add_segment({-half_width, sy}, {-half_width, -sy});
  add_arc({-sx, -sy}, M_PI);
  add_segment({-sx, -half_height}, {sx, -half_height});
  add_arc({sx, -sy}, 3 * M_PI / 2);
  if (notches.empty()) return out;
  // Remove what the notches cut away, then add the notches' own edges inside the part.
  std::vector<Eigen::Vector2d> kept;
  auto in_notch = [&](const Eigen::Vector2d& p, const Notch* except) {
    for (const Notch& n : notches)
      if (&n != except && BoxSdf(p, n.center, n.half_size) < 0) return true;
    return false;
  };
  for (const Eigen::Vector2d& p : out)
    if (!in_notch(p, nullptr)) kept.push_back(p);
  for (const Notch& n : notches) {
    const Eigen::Vector2d lo = n.center - n.half_size, hi = n.center + n.half_size;
    std::vector<Eigen::Vector2d> edge;
    const Eigen::Vector2d corners[4] = {lo, {hi.x(), lo.y()}, hi, {lo.x(), hi.y()}};
    for (int i = 0; i < 4; ++i) {
      const Eigen::Vector2d p = corners[i], q = corners[(i + 1) % 4];
      const int m = std::max(1, static_cast<int>(std::ceil((q - p).norm() / spacing)));
      for (int k = 0; k < m; ++k) {
        const Eigen::Vector2d s = p + (q - p) * (static_cast<double>(k) / m);
        if (RoundedRectSdf(s, half_width, half_height, r) < 0 && !in_notch(s, &n)) kept.push_back(s);
      }
    }
  }
  return kept;
}

std::vector<Eigen::Vector3d> PartGeometry::SampleRim(double spacing) const {
  std::vector<Eigen::Vector3d> rim;
  for (const Eigen::Vector2d& p : SampleOuterOutline(spacing)) rim.push_back(RimPoint(p));
  return rim;
}

std::vector<Eigen::Vector3d> PartGeometry::SampleBottomSurface(double spacing) const {
  std::vector<Eigen::Vector3d> points = SampleRim(spacing);
  for (const Burr& b : burrs)  // the tip of a burr under the rim
    if (b.under_rim) points.push_back(SheetPoint(b.centre, -wall_height - b.size_mm));
  if (wall_height > 0) return points;  // the lid's underside is H above the rim
  for (const Hole& h : holes) {
    const int n = std::max(8, static_cast<int>(std::ceil(2 * M_PI * h.radius / spacing)));
    for (int i = 0; i < n; ++i) {
      const double a = 2 * M_PI * i / n;
      const Eigen::Vector2d p = h.center + h.radius * Eigen::Vector2d(std::cos(a), std::sin(a));
      if (FootprintSdf(p) <= 1e-9) points.emplace_back(p.x(), p.y(), WarpZ(p));
    }
  }
  const double step = std::max(spacing, 0.25);
  for (double y = -half_height + step / 2; y < half_height; y += step)
    for (double x = -half_width + step / 2; x < half_width; x += step) {
      const Eigen::Vector2d p(x, y);
      if (FootprintSdf(p) < 0) points.emplace_back(x, y, WarpZ(p));
    }
  return points;
}

Eigen::Vector3d PartGeometry::CenterOfMass() const {
  // Midpoint-rule integral over a 0.1 mm grid: the sheet at mid-thickness, and the
  // walls (outer band of width t) at mid-height.
  const double step = 0.1;
  const double sheet = thickness > 0 ? thickness : 1.0;  // a zero-thickness sheet: by area
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  double mass = 0.0;
  for (double y = -half_height + step / 2; y < half_height; y += step)
    for (double x = -half_width + step / 2; x < half_width; x += step) {
      const Eigen::Vector2d p(x, y);
      const double d = FootprintSdf(p);
      if (d >= 0) continue;
      const double w = WarpZ(p);
      double m = sheet;
      double z = w + thickness / 2;
      if (wall_height > 0 && OuterSdf(p) > -thickness) {
        z = (sheet * (w + thickness / 2) + wall_height * (w - wall_height / 2)) / (sheet + wall_height);
        m += wall_height;
      }
      sum += m * Eigen::Vector3d(x, y, z);
      mass += m;
    }
  return sum / mass;
}

PartGeometry SamplePartGeometry(const PartSpec& spec, Random& rng) {
  auto pick = [&](const Range& r) { return rng.Uniform(r.lo, r.hi); };
  auto pick_int = [&](const std::array<int, 2>& r) {
    return r[0] + static_cast<int>(std::floor(rng.Uniform() * (r[1] - r[0] + 1)));
  };
  PartGeometry g;
  g.half_width = pick(spec.width_mm) / 2;
  g.half_height = pick(spec.height_mm) / 2;
  const double min_half = std::min(g.half_width, g.half_height);
  g.corner_radius = std::min(pick(spec.corner_radius_mm), 0.9 * min_half);
  g.thickness = pick(spec.thickness_mm);
  g.wall_height = pick(spec.wall_height_mm);
  // Holes inside the footprint, clear of the edge (and of the walls) and each other.
  const int holes = pick_int(spec.holes);
  for (int i = 0, tries = 0; i < holes && tries < 200; ++tries) {
    Hole h;
    h.radius = std::min(pick(spec.hole_radius_mm), 0.3 * min_half);
    h.center = {rng.Uniform(-g.half_width, g.half_width), rng.Uniform(-g.half_height, g.half_height)};
    const double clearance = h.radius + 1.0 + g.thickness;
    bool ok = g.OuterSdf(h.center) < -clearance;
    for (const Hole& o : g.holes) ok = ok && (o.center - h.center).norm() > o.radius + h.radius + 1.0;
    if (!ok) continue;
    g.holes.push_back(h);
    ++i;
  }
  // Notches on the straight part of random edges.
  const int notches = pick_int(spec.notches);
  for (int i = 0, tries = 0; i < notches && tries < 200; ++tries) {
    const double size = pick(spec.notch_size_mm);
    const int side = static_cast<int>(std::floor(rng.Uniform() * 4));
    const bool vertical_edge = side < 2;
    const double edge_half = (vertical_edge ? g.half_height : g.half_width) - g.corner_radius - size;
    if (edge_half <= 0) continue;
    const double along = rng.Uniform(-edge_half, edge_half);
    const double depth = 0.6 * size;
    Notch n;
    if (vertical_edge) {
      n.center = {side == 0 ? g.half_width : -g.half_width, along};
      n.half_size = {depth, size / 2};
    } else {
      n.center = {along, side == 2 ? g.half_height : -g.half_height};
      n.half_size = {size / 2, depth};
    }
    bool ok = true;
    for (const Notch& o : g.notches) ok = ok && (o.center - n.center).cwiseAbs().maxCoeff() > size + 1.0;
    for (const Hole& h : g.holes) ok = ok && BoxSdf(h.center, n.center, n.half_size) > h.radius + 1.0;
    if (!ok) continue;
    g.notches.push_back(n);
    ++i;
  }
  g.side_faces = spec.side_faces;
  g.warp.bend_x = pick(spec.bending_mm);
  g.warp.bend_y = pick(spec.bending_mm);
  g.warp.twist = pick(spec.twist_mm);
  const double r = spec.random_warp_mm;
  g.warp.bend_x += rng.Uniform(-r, r);
  g.warp.bend_y += rng.Uniform(-r, r);
  g.warp.c30 = rng.Uniform(-r, r);
  g.warp.c21 = rng.Uniform(-r, r);
  g.warp.c12 = rng.Uniform(-r, r);
  g.warp.c03 = rng.Uniform(-r, r);
  if (spec.flatness_mm.hi > 0) return WithFlatness(g, rng.Uniform(spec.flatness_mm.lo, spec.flatness_mm.hi));
  return g;
}

PartOccluder::PartOccluder(const PartGeometry& geometry, const Rigid3d& support_from_part)
    : geometry_(geometry), support_from_part_(support_from_part), part_from_support_(support_from_part.Inverse()) {
  if (geometry.side_faces == SideFaceModel::kCentreNormal) return;
  // The largest horizontal part of S over the footprint (a 41 x 41 grid; the cubic's
  // slope is smooth), times the faces' reach either side of the bottom surface, with a
  // margin for what the grid misses. A wave's slope is not smooth on that grid (its
  // wavelength may be a few grid steps): its largest, A |k| = 2 pi A / L, is added whole.
  double lean = 0;
  for (int i = 0; i <= 40; ++i)
    for (int j = 0; j <= 40; ++j) {
      const Eigen::Vector2d q(geometry.half_width * (i / 20.0 - 1), geometry.half_height * (j / 20.0 - 1));
      lean = std::max(lean, geometry.FaceDirection(q).head<2>().norm());
    }
  lean += std::abs(geometry.warp.wave_mm) * WaveVector(geometry.warp).norm();
  lean_ = 1.2 * lean * std::max(geometry.thickness, geometry.wall_height) + 1e-6;
}

double PartOccluder::IntersectSurface(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double offset) const {
  double s = (offset - o.z()) / d.z();
  for (int iter = 0; iter < 20; ++iter) {
    const Eigen::Vector2d xy(o.x() + s * d.x(), o.y() + s * d.y());
    const double h = o.z() + s * d.z() - geometry_.WarpZ(xy) - offset;
    const double dh = d.z() - geometry_.WarpGradient(xy).dot(d.head<2>());
    const double step = h / dh;
    s -= step;
    if (std::abs(step * d.z()) < 1e-12) break;
  }
  return s;
}

double PartOccluder::RefineToLevel(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double offset, double l) const {
  // Newton steps on s(o + l d) = offset from the vertical offset's solution (within
  // offset times the squared slope of it): S is the bottom surface's normal, so
  // ds / dl = S . d to first order.
  Eigen::Vector2d q = (o + l * d).head<2>();
  for (int iter = 0; iter < 8; ++iter) {
    double s = 0;
    q = geometry_.SheetCoordinates(o + l * d, &s, &q);
    const double step = (s - offset) / geometry_.FaceDirection(q).dot(d);
    l -= step;
    if (std::abs(step) * d.norm() < 1e-10) break;
  }
  return l;
}

double PartOccluder::RaySignedDistance(const Ray& ray) const {
  const Eigen::Vector3d o = part_from_support_ * ray.origin;
  const Eigen::Vector3d d = part_from_support_.rotation * ray.direction;
  const PartGeometry& g = geometry_;
  const bool walls = g.wall_height > 0;
  // Where the ray meets the bottom surface and its vertical offsets to the top and to
  // the walls' rim (the levels of faces along z).
  const double l_bottom = IntersectSurface(o, d, 0.0);
  const double l_top = g.thickness > 0 ? IntersectSurface(o, d, g.thickness) : l_bottom;
  const double l_rim = walls ? IntersectSurface(o, d, -g.wall_height) : l_bottom;
  // The footprint point q under the ray's point at parameter l: the point's own (x, y)
  // for faces along z, else its sheet coordinates (successive points lie close together
  // on the ray: each starts from the last q).
  bool vertical = true, started = false;
  Eigen::Vector2d last_q = o.head<2>();
  auto q_at = [&](double l) {
    if (vertical) return Eigen::Vector2d(o.x() + l * d.x(), o.y() + l * d.y());
    double s = 0;
    last_q = g.SheetCoordinates(o + l * d, &s, started ? &last_q : nullptr);
    started = true;
    return last_q;
  };
  // Sheet: between its top and bottom levels the ray is inside the solid wherever it is
  // over the footprint; walls: the outer band of width t, from the sheet's bottom down
  // to the rim.
  auto footprint = [&](double l) { return g.FootprintSdf(q_at(l)); };
  auto wall = [&](double l) {
    const double outer = g.OuterSdf(q_at(l));
    return std::max(outer, -g.thickness - outer);
  };
  auto distance = [&](double top, double rim) {
    double d_min = SegmentMinimum(footprint, top, l_bottom);
    if (walls) d_min = std::min(d_min, SegmentMinimum(wall, l_bottom, rim));
    return d_min;
  };
  const double along_z = distance(l_top, l_rim);
  if (g.side_faces == SideFaceModel::kCentreNormal) return along_z;
  // Sheet coordinates move a point by at most lean_ from where it is, so away from the
  // outline the distance with faces along z, less lean_, is a conservative answer (most
  // of the renderer's block tests); only rays near the outline pay for the exact one.
  if (std::abs(along_z) > 2 * lean_) return along_z - std::copysign(lean_, along_z);
  vertical = false;
  return distance(g.thickness > 0 ? RefineToLevel(o, d, g.thickness, l_top) : l_bottom,
                  walls ? RefineToLevel(o, d, -g.wall_height, l_rim) : l_bottom);
}

std::vector<Eigen::Vector3d> PartOccluder::BoundingPoints() const {
  const PartGeometry& g = geometry_;
  double z_lo = std::numeric_limits<double>::infinity(), z_hi = -z_lo, reach = 0;
  double burr_reach = 0;  // a burr's arc stands this far out, and then leans like the rest
  for (const Burr& b : g.burrs) burr_reach = std::max(burr_reach, b.size_mm);
  for (const Eigen::Vector2d& p : g.SampleOuterOutline(0.5)) {
    const Eigen::Vector3d rim = g.RimPoint(p), top = g.SheetPoint(p, g.thickness);
    z_lo = std::min(z_lo, rim.z());
    z_hi = std::max(z_hi, top.z());
    // Faces along the local normal lean out of the footprint by up to this much.
    reach = std::max({reach, (rim.head<2>() - p).norm(), (top.head<2>() - p).norm()});
  }
  std::vector<Eigen::Vector3d> out;
  for (double z : {z_lo, z_hi})
    for (double sx : {-1.0, 1.0})
      for (double sy : {-1.0, 1.0})
        out.push_back(support_from_part_ * Eigen::Vector3d(sx * (g.half_width + reach + burr_reach),
                                                           sy * (g.half_height + reach + burr_reach), z));
  return out;
}

PartTruth RestAndPlacePart(const PartGeometry& geometry, double rotation_deg, const Eigen::Vector2d& position) {
  const RestPose rest = ComputeRestPose(geometry.SampleBottomSurface(0.1), geometry.CenterOfMass());
  Rigid3d placement;
  placement.rotation = Eigen::AngleAxisd(rotation_deg * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  placement.translation = Eigen::Vector3d(position.x(), position.y(), 0.0);
  PartTruth truth;
  truth.support_from_part = placement * rest.support_from_part;
  truth.contacts = rest.contacts;
  std::vector<double> heights;
  for (const Eigen::Vector3d& p : geometry.SampleRim(0.05)) {
    truth.rim.push_back(truth.support_from_part * p);
    heights.push_back(truth.rim.back().z());
  }
  const FlatnessValues values = ComputeFlatness(truth.rim, heights);
  truth.flatness_mm = values.flatness_mm;
  truth.lsq_pv_mm = values.lsq_pv_mm;
  truth.minzone_mm = values.minzone_mm;
  return truth;
}

PartGeometry WithBurrs(PartGeometry g, const PartSpec& spec, uint64_t seed) {
  if (spec.burrs[1] <= 0) return g;
  Random rng(seed);
  const int n = spec.burrs[0] + static_cast<int>(std::floor(rng.Uniform() * (spec.burrs[1] - spec.burrs[0] + 1)));
  const int under = static_cast<int>(std::lround(spec.burr_under_rim_fraction * n));
  const std::vector<Eigen::Vector2d> outline = g.SampleOuterOutline(0.05);
  for (int i = 0; i < n && !outline.empty(); ++i) {
    Burr b;
    b.centre = outline[std::min(outline.size() - 1, static_cast<size_t>(rng.Uniform() * outline.size()))];
    b.size_mm = 1e-3 * rng.Uniform(spec.burr_size_um.lo, spec.burr_size_um.hi);
    b.under_rim = i < under;
    g.burrs.push_back(b);
  }
  return g;
}

PartGeometry WithWaviness(PartGeometry g, const PartSpec& spec, uint64_t seed) {
  if (spec.waviness_um.hi <= 0) return g;
  Random rng(seed);
  g.warp.wave_mm = 1e-3 * rng.Uniform(spec.waviness_um.lo, spec.waviness_um.hi);
  g.warp.wave_length_mm = rng.Uniform(spec.waviness_wavelength_mm.lo, spec.waviness_wavelength_mm.hi);
  g.warp.wave_direction_rad = rng.Uniform(0, M_PI);
  g.warp.wave_phase_rad = rng.Uniform(0, 2 * M_PI);
  return g;
}

namespace {

// The smooth warp scaled; the waviness kept as drawn.
Warp ScaledWarp(Warp w, double s) {
  for (double* c : {&w.bend_x, &w.bend_y, &w.twist, &w.c30, &w.c21, &w.c12, &w.c03}) *c *= s;
  return w;
}

}  // namespace

PartGeometry WithFlatness(PartGeometry geometry, double flatness_mm) {
  if (!(flatness_mm >= 0)) throw std::invalid_argument("WithFlatness: expected a flatness >= 0 mm");
  const Warp base = geometry.warp;
  const auto flatness_at = [&](double scale) {
    geometry.warp = ScaledWarp(base, scale);
    return RestAndPlacePart(geometry, 0.0, Eigen::Vector2d::Zero()).flatness_mm;
  };
  double scale = 1.0, flatness = flatness_at(scale);
  if (flatness < 1e-9) {
    geometry.warp.bend_x = 0.1;
    return WithFlatness(geometry, flatness_mm);
  }
  for (int i = 0; i < 12 && std::abs(flatness - flatness_mm) > 1e-8; ++i) {
    scale *= flatness_mm / flatness;
    flatness = flatness_at(scale);
  }
  return geometry;
}

nlohmann::json PartGeometryToJson(const PartGeometry& g) {
  nlohmann::json j;
  j["width_mm"] = 2 * g.half_width;
  j["height_mm"] = 2 * g.half_height;
  j["corner_radius_mm"] = g.corner_radius;
  j["thickness_mm"] = g.thickness;
  j["wall_height_mm"] = g.wall_height;
  j["side_faces"] = SideFaceModelName(g.side_faces);
  j["holes"] = nlohmann::json::array();
  for (const Hole& h : g.holes) j["holes"].push_back({{"centre_mm", {h.center.x(), h.center.y()}}, {"radius_mm", h.radius}});
  j["notches"] = nlohmann::json::array();
  for (const Notch& n : g.notches)
    j["notches"].push_back({{"centre_mm", {n.center.x(), n.center.y()}}, {"half_size_mm", {n.half_size.x(), n.half_size.y()}}});
  if (!g.burrs.empty()) {  // only when the scene asks for burrs: truth files without them stay as they were
    j["burrs"] = nlohmann::json::array();
    for (const Burr& b : g.burrs)
      j["burrs"].push_back({{"centre_mm", {b.centre.x(), b.centre.y()}}, {"size_mm", b.size_mm}, {"under_rim", b.under_rim}});
  }
  j["warp_mm"] = {{"bend_x", g.warp.bend_x}, {"bend_y", g.warp.bend_y}, {"twist", g.warp.twist},
                  {"c30", g.warp.c30},       {"c21", g.warp.c21},       {"c12", g.warp.c12},
                  {"c03", g.warp.c03}};
  if (g.warp.wave_mm != 0)  // only when the scene asks for waviness, as with burrs
    j["warp_mm"]["waviness"] = {{"amplitude_mm", g.warp.wave_mm},
                                {"wavelength_mm", g.warp.wave_length_mm},
                                {"direction_rad", g.warp.wave_direction_rad},
                                {"phase_rad", g.warp.wave_phase_rad}};
  return j;
}

}  // namespace flatscan
