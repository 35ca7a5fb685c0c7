#include "flatscan/inspection/rim_points.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <span>

#include "flatscan/reconstruction/outlier_filter.h"
#include "flatscan/reconstruction/rectified_stereo.h"
#include "flatscan/util/error.h"

namespace flatscan {
namespace {

// Footprint centre: the area centroid of the left outline's rays cut with the plane,
// put back on the plane (camera-1 frame); none for a degenerate outline.
std::optional<Eigen::Vector3d> FootprintCentre(const Camera& left, const SupportPlane& plane, const BoundaryResult& lb,
                                               const ContourInfo& outer) {
  const Eigen::Vector3d e1 = plane.normal.unitOrthogonal(), e2 = plane.normal.cross(e1);
  double area = 0;
  Eigen::Vector2d centroid(0, 0), prev(0, 0);
  for (int i = outer.begin; i <= outer.end; ++i) {
    const EdgePoint& e = lb.points[i < outer.end ? i : outer.begin];
    const Eigen::Vector2d xy = left.PixelToNormalized(Eigen::Vector2d(e.x, e.y));
    const Eigen::Vector3d d(xy.x(), xy.y(), 1.0);
    const Eigen::Vector3d on_plane = d * (plane.normal.dot(plane.point) / plane.normal.dot(d));
    const Eigen::Vector2d q(on_plane.dot(e1), on_plane.dot(e2));
    if (i > outer.begin) {
      const double cross = prev.x() * q.y() - q.x() * prev.y();
      area += cross;
      centroid += cross * (prev + q);
    }
    prev = q;
  }
  if (!(std::abs(area) > 0)) return std::nullopt;
  centroid /= 3 * area;
  Eigen::Vector3d centre = centroid.x() * e1 + centroid.y() * e2;
  return centre + (plane.point - centre).dot(plane.normal) * plane.normal;
}

// The right silhouette near each match, rectified, in chain order (for the
// thickness-aware triangulation, which needs the curve off the crossing's row): a
// window of its contour's rectified chain, which for a closed contour is padded with
// its own ends so that every window is contiguous. The spans stay valid as long as
// this object (each padded chain is built once, in one allocation).
class RightSilhouettes {
 public:
  explicit RightSilhouettes(const StereoOutline& outline) : outline_(outline), padded_(outline.right.contours.size()) {}
  std::span<const Eigen::Vector2d> Near(const RowCrossing& b) {
    constexpr int kReach = 24;  // chain points either side (about 1 px apart)
    std::vector<Eigen::Vector2d>& chain = padded_[b.contour];
    const ContourInfo& info = outline_.right.contours[b.contour];
    const int n = info.end - info.begin;
    const int pad = info.closed ? kReach : 0;
    if (chain.empty()) {
      const std::vector<Eigen::Vector2d>& rectified = outline_.right_chains[b.contour];
      chain.reserve(n + 2 * pad + 1);
      for (int k = -pad; k < n + pad + 1; ++k)
        if (info.closed || k < n) chain.push_back(rectified[((k % n) + n) % n]);
    }
    const int first = std::max(0, b.index - kReach + pad);
    const int last = std::min(static_cast<int>(chain.size()) - 1, b.index + 1 + kReach + pad);
    return std::span<const Eigen::Vector2d>(chain.data() + first, last - first + 1);
  }

 private:
  const StereoOutline& outline_;
  std::vector<std::vector<Eigen::Vector2d>> padded_;
};

// One triangulation of all matches, each with its own side-face direction.
struct Triangulation {
  std::vector<InspectedPoint> points;
  std::vector<double> weight;      // inverse variance: a crossing's x error grows as 1 / |n_x|
  std::vector<int> chain_index;    // the left crossing's chain index
  std::vector<int> row;            // the left crossing's rectified row
  std::vector<BottomPoint> seen;   // which edges, how the faces are seen
  std::vector<int> match;          // index in the matches
  std::vector<bool> keep;          // radius outlier filter
};

class Triangulator {
 public:
  Triangulator(const RectifiedStereo& stereo, const SupportPlane& plane, const StereoOutline& outline,
               const InspectionParams& params)
      : stereo_(stereo), plane_(plane), outline_(outline), params_(params), right_(outline) {
    if (!params.thickness_correction) return;
    silhouettes_.reserve(outline.matches.size());
    for (const StereoMatch& m : outline.matches) silhouettes_.push_back(right_.Near(outline.right_crossings[m.right]));
  }
  const RectifiedStereo& stereo() const { return stereo_; }

  // `side_cam1`: per match, the side faces' direction there, camera-1 frame. The radius
  // filter runs on the first call only: a change of the side-face direction moves
  // points by t times the change of tilt (micrometres), not across a 0.25 mm radius;
  // later calls keep the first call's verdict per match.
  Triangulation Run(const std::vector<Eigen::Vector3d>& side_cam1) {
    FLATSCAN_CHECK(side_cam1.size() == outline_.matches.size());
    const Eigen::Matrix3d cam1_from_rect1 = stereo_.rect1_from_cam1.transpose();
    Triangulation t;
    std::vector<Eigen::Vector3d> cam1;
    std::vector<double> radii;
    for (size_t mi = 0; mi < outline_.matches.size(); ++mi) {
      const StereoMatch& m = outline_.matches[mi];
      const RowCrossing& a = outline_.left_crossings[m.left];
      const RowCrossing& b = outline_.right_crossings[m.right];
      InspectedPoint p;
      BottomPoint bp;
      if (params_.thickness_correction) {
        bp = TriangulateBottomPoint(stereo_, a.x, a.row, Eigen::Vector2d(a.nx, a.ny), silhouettes_[mi], b.x,
                                    stereo_.rect1_from_cam1 * side_cam1[mi], params_.thickness_mm);
        if (!bp.valid) continue;
        p.left_edge = bp.left_edge;
        p.right_edge = bp.right_edge;
      } else {
        bp.rect1 = TriangulateRow(stereo_, a.x, b.x, a.row);
        if (!(bp.rect1.z() > 0)) continue;
      }
      p.cam1 = cam1_from_rect1 * bp.rect1;
      p.left_raw = Eigen::Vector2d(a.raw_x, a.raw_y);
      p.right_raw = Eigen::Vector2d(b.raw_x, b.raw_y);
      p.outer = a.contour == outline_.left_part;
      p.height_mm = plane_.Height(p.cam1);
      t.points.push_back(p);
      t.seen.push_back(bp);
      cam1.push_back(p.cam1);
      t.chain_index.push_back(a.index);
      t.row.push_back(a.row);
      t.match.push_back(static_cast<int>(mi));
      t.weight.push_back(a.nx * a.nx * b.nx * b.nx / (a.nx * a.nx + b.nx * b.nx));
      // Consecutive row crossings lie one row / |n_x| apart along the boundary: where it
      // runs near the rows they are sparse, and the radius must reach 2.5 spacings to
      // find the neighbours a point on a well-sampled stretch has.
      const double spacing_mm = p.cam1.z() / stereo_.f / std::max(std::abs(a.nx), 1e-3);
      radii.push_back(std::max(params_.outlier_radius_mm, 2.5 * spacing_mm));
    }
    if (keep_match_.empty()) {
      t.keep = RadiusOutlierFilter(cam1, radii, params_.outlier_min_neighbours);
      keep_match_.assign(outline_.matches.size(), 0);
      for (size_t i = 0; i < t.keep.size(); ++i) keep_match_[t.match[i]] = t.keep[i];
    } else {
      t.keep.resize(t.points.size());
      for (size_t i = 0; i < t.keep.size(); ++i) t.keep[i] = keep_match_[t.match[i]];
    }
    return t;
  }

 private:
  const RectifiedStereo& stereo_;
  const SupportPlane& plane_;
  const StereoOutline& outline_;
  const InspectionParams& params_;
  RightSilhouettes right_;
  std::vector<std::span<const Eigen::Vector2d>> silhouettes_;  // per match, into right_
  std::vector<char> keep_match_;
};

// The valid outer points of a triangulation in chain order (by the left crossing's
// chain index), as (chain index, index in the triangulation).
std::vector<std::pair<int, int>> OuterInChainOrder(const Triangulation& tri) {
  std::vector<std::pair<int, int>> order;
  for (size_t i = 0; i < tri.points.size(); ++i)
    if (tri.keep[i] && tri.points[i].outer) order.emplace_back(tri.chain_index[i], static_cast<int>(i));
  std::sort(order.begin(), order.end());
  return order;
}

// Flags (per triangulated point) the rim points whose silhouette is neither edge of
// the side face.
std::vector<bool> DropAtViewTurns(const Triangulation& tri, const std::vector<std::pair<int, int>>& chain_order,
                                  double pixel_scale, bool thickness_correction) {
  // Where a camera's view of the side face turns from outside to inside (its line of
  // sight grazes the face: a corner), its silhouette runs along the face's vertical
  // generator, which is neither edge: rim points within the generator's length (plus
  // the edge operator's reach) of such a turn are dropped. A side whose face the
  // camera sees edge-on all along (|facing| below kGrazing beyond the reach on both
  // sides of the turn) flips between the two edges with the noise of the normal; there
  // the two edges project onto one line and either solution moves the point along the
  // rim by at most the generator's length (a micrometre of height), so it is kept
  // (measured: up to 160 of 900 points of a 12 mm-lens part were dropped before).
  std::vector<bool> drop(tri.points.size(), false);
  if (thickness_correction && chain_order.size() > 2) {
    constexpr double kGrazing = 0.01;
    const int m = static_cast<int>(chain_order.size());
    auto point = [&](int j) -> const InspectedPoint& { return tri.points[chain_order[((j % m) + m) % m].second]; };
    auto seen = [&](int j) -> const BottomPoint& { return tri.seen[chain_order[((j % m) + m) % m].second]; };
    // Each camera's facing averaged over 9 neighbours along the rim: the normal's
    // noise (about +-0.004 here) would flip the sign of a face seen nearly edge-on.
    constexpr std::array<RigSide, 2> kSides = {RigSide::kLeft, RigSide::kRight};
    std::array<std::vector<double>, 2> mean_facing;  // by RigSide
    for (const RigSide side : kSides) {
      std::vector<double>& mean = mean_facing[static_cast<int>(side)];
      mean.resize(m);
      for (int j = 0; j < m; ++j) {
        double sum = 0;
        for (int k = j - 4; k <= j + 4; ++k) sum += seen(k).Facing(side);
        mean[j] = sum / 9;
      }
    }
    std::vector<int> stretch;
    for (int j = 0; j < m; ++j) {
      for (const RigSide side : kSides) {
        auto facing = [&](int k) { return mean_facing[static_cast<int>(side)][((k % m) + m) % m]; };
        auto generator = [&](int k) { return seen(k).GeneratorMm(side); };
        if ((facing(j) > 0) == (facing(j + 1) > 0)) continue;
        const double reach = std::max(generator(j), generator(j + 1)) + 2.5 * point(j).cam1.z() * pixel_scale;
        stretch.clear();
        double end_facing = 0;
        for (int dir : {-1, 1}) {
          const int start = dir < 0 ? j : j + 1;
          double arc = 0;
          int k = start;
          for (int steps = 0; steps < m; ++steps, k += dir) {
            arc += (point(k).cam1 - point(k == start ? start : k - dir).cam1).norm();
            if (arc > reach) break;
            stretch.push_back(k);
          }
          end_facing = std::max(end_facing, std::abs(facing(k)));
        }
        if (end_facing < kGrazing) continue;
        for (int k : stretch) drop[chain_order[((k % m) + m) % m].second] = true;
      }
    }
  }
  return drop;
}

// A short run of points left between two dropped stretches (a corner where both
// cameras' views turn) has no neighbours to check it: dropped too (measured: +16 um
// from one such point at a corner).
void DropShortRuns(const Triangulation& tri, const std::vector<std::pair<int, int>>& chain_order,
                   std::vector<bool>* dropped) {
  constexpr double kShortRunMm = 0.25;
  std::vector<bool>& drop = *dropped;
  if (!chain_order.empty()) {
    const int m = static_cast<int>(chain_order.size());
    int first_dropped = -1;
    for (int j = 0; j < m && first_dropped < 0; ++j)
      if (drop[chain_order[j].second]) first_dropped = j;
    if (first_dropped >= 0) {
      std::vector<int> run;
      double length = 0;
      for (int step = 1; step <= m; ++step) {
        const int j = (first_dropped + step) % m;
        const int i = chain_order[j].second;
        if (!drop[i]) {
          if (!run.empty()) length += (tri.points[i].cam1 - tri.points[chain_order[(j + m - 1) % m].second].cam1).norm();
          run.push_back(i);
          continue;
        }
        if (!run.empty() && length < kShortRunMm)
          for (int k : run) drop[k] = true;
        run.clear();
        length = 0;
      }
    }
  }
}

RimPoints CollectRim(const Triangulation& tri, double pixel_scale, bool thickness_correction) {
  const std::vector<std::pair<int, int>> chain_order = OuterInChainOrder(tri);
  std::vector<bool> drop = DropAtViewTurns(tri, chain_order, pixel_scale, thickness_correction);
  DropShortRuns(tri, chain_order, &drop);
  RimPoints out;
  std::vector<int> index_in_points(tri.points.size(), -1);
  for (size_t i = 0; i < tri.points.size(); ++i) {
    if (!tri.keep[i] || drop[i]) continue;
    index_in_points[i] = static_cast<int>(out.points.size());
    out.points.push_back(tri.points[i]);
    if (!tri.points[i].outer) {
      out.inner.Add(tri.points[i].cam1, tri.points[i].height_mm, tri.weight[i]);
      out.inner_match.push_back(tri.match[i]);
    }
  }
  for (const auto& [chain_index, i] : chain_order) {
    if (drop[i]) continue;
    out.rim.Add(tri.points[i].cam1, tri.points[i].height_mm, tri.weight[i]);
    out.rim_chain_index.push_back(chain_index);
    out.rim_row.push_back(tri.row[i]);
    out.rim_point.push_back(index_in_points[i]);
    out.rim_match.push_back(tri.match[i]);
  }
  return out;
}

// How each match's height depends on the side faces' direction (FaceCoupling,
// flatness/rim_heights.h): minus d height / d (S's horizontal part along e1, e2), from
// two more triangulations with every face turned by kProbeRad about each axis (at the
// directions `sides` of the triangulation `base`). The
// dependence is linear (Z / B t theta / |n_x|) except where a camera's edge flips
// between the runs (a view turn): such a match gets no gain.
std::vector<Eigen::Vector2d> HeightGains(Triangulator& triangulator, const Triangulation& base,
                                         const std::vector<Eigen::Vector3d>& sides, const SupportPlane& plane) {
  constexpr double kProbeRad = 1e-3;
  const auto [e1, e2] = PlaneAxes(plane);
  const size_t n = sides.size();
  std::vector<int> at(n, -1);
  for (size_t i = 0; i < base.points.size(); ++i) at[base.match[i]] = static_cast<int>(i);
  std::vector<Eigen::Vector2d> gain(n, Eigen::Vector2d::Zero());
  std::vector<char> linear(n, 1);
  for (int axis = 0; axis < 2; ++axis) {
    std::vector<Eigen::Vector3d> probe(n);
    for (size_t m = 0; m < n; ++m) probe[m] = (sides[m] + kProbeRad * (axis == 0 ? e1 : e2)).normalized();
    const Triangulation turned = triangulator.Run(probe);
    std::vector<char> seen(n, 0);
    for (size_t i = 0; i < turned.points.size(); ++i) {
      const int m = turned.match[i], j = at[m];
      if (j < 0) continue;
      seen[m] = 1;
      const bool same_edges = turned.seen[i].left_edge == base.seen[j].left_edge &&
                              turned.seen[i].right_edge == base.seen[j].right_edge;
      if (!same_edges) linear[m] = 0;
      // h = h_true + gain . (S_true - S_assumed): turning the assumed face by +kProbeRad
      // changes the height by -gain times that.
      gain[m][axis] = -(turned.points[i].height_mm - base.points[j].height_mm) / kProbeRad;
    }
    for (size_t m = 0; m < n; ++m)
      if (!seen[m]) linear[m] = 0;
  }
  for (size_t m = 0; m < n; ++m)
    if (!linear[m]) gain[m].setZero();
  return gain;
}

// The coupling of a rim's samples: each sample's gain and the direction it was
// triangulated with, by match.
FaceCoupling Coupling(const RimPoints& rim, const std::vector<Eigen::Vector2d>& gain,
                      const std::vector<Eigen::Vector3d>& sides, const SupportPlane& plane) {
  const auto axes = PlaneAxes(plane);  // not a structured binding: clang 14 cannot capture those
  const Eigen::Vector3d e1 = axes.first, e2 = axes.second;
  FaceCoupling c;
  auto add = [&](const std::vector<int>& matches, std::vector<Eigen::Vector2d>* g, std::vector<Eigen::Vector2d>* s) {
    for (int m : matches) {
      g->push_back(gain[m]);
      s->emplace_back(sides[m].dot(e1), sides[m].dot(e2));
    }
  };
  add(rim.rim_match, &c.rim_gain, &c.rim_assumed);
  add(rim.inner_match, &c.inner_gain, &c.inner_assumed);
  return c;
}

}  // namespace

SideFaceField::SideFaceField(const SupportPlane& plane) : model_(SideFaceModel::kSupportNormal), up_(plane.normal) {}

SideFaceField::SideFaceField(SideFaceModel model, const WarpSurface& warp, const std::optional<Eigen::Vector3d>& centre,
                             double max_tilt_rad)
    : model_(model), up_(warp.plane().normal), max_tilt_rad_(max_tilt_rad), warp_(warp) {
  if (model_ == SideFaceModel::kSupportNormal) return;
  if (centre) centre_normal_ = Capped(warp.SheetNormal(*centre));
  if (model_ == SideFaceModel::kCentreNormal && !centre) model_ = SideFaceModel::kSupportNormal;
}

Eigen::Vector3d SideFaceField::Capped(const Eigen::Vector3d& n) const {
  if (!n.allFinite()) return up_;
  const double tilt = std::acos(std::clamp(n.dot(up_), -1.0, 1.0));
  if (tilt <= max_tilt_rad_) return n;
  const Eigen::Vector3d across = n - n.dot(up_) * up_;
  return (std::cos(max_tilt_rad_) * up_ + std::sin(max_tilt_rad_) * across.normalized()).normalized();
}

Eigen::Vector3d SideFaceField::At(const Eigen::Vector3d& p) const {
  switch (model_) {
    case SideFaceModel::kSupportNormal: return up_;
    case SideFaceModel::kCentreNormal: return centre_normal_;
    case SideFaceModel::kLocalNormal: break;
  }
  // A match never triangulated has no place on the sheet: the centre's normal.
  if (!p.allFinite()) return centre_normal_.allFinite() ? centre_normal_ : up_;
  return Capped(warp_->SheetNormal(p));
}

double SideFaceField::Tilt(const Eigen::Vector3d& p) const {
  return std::acos(std::clamp(At(p).dot(up_), -1.0, 1.0));
}

// Side-face direction (geometry/side_faces.h). The first pass takes the faces along
// the support normal. A sheet cut square keeps its faces perpendicular to the local
// sheet, and where the two cameras see different edges a face leaning by theta
// across the rim moves the triangulated height by about (Z / B) t theta / |n_x|
// (tens of micrometres for a 0.3 mm sheet at the slopes of a warped part). The sheet
// (the warp surface: cubic, ridge on the curvature, none on the tilt: a tilt ridge
// biased the slopes the faces need, by 6 um on a part) is therefore fitted together
// with the faces it implies: with each height's measured dependence on its face's
// direction in the fit's design (FaceCoupling), the fit solves for the sheet whose
// normals, used as the faces, reproduce the measured heights. Each match then gets
// the surface's normal at its own point and is triangulated again, until the
// directions settle (one or two passes: the dependence is linear). Fitting the sheet
// to the heights alone and iterating converges to the same sheet but slowly: the
// heights' error feeds back into the fitted slope with the same sign (each pass left
// 0.5-0.6 of the last change, and on some parts a cubic mode drifted without
// settling). The centre model takes one direction, the surface's normal at the
// footprint centre, in two plain passes as earlier versions did.
RimPoints TriangulateRim(const StereoRectification& rectification, const SupportPlane& plane,
                         const StereoOutline& outline, const InspectionParams& params) {
  Triangulator triangulator(rectification.stereo(), plane, outline, params);
  const double pixel_scale = 1.0 / triangulator.stereo().f;  // mm per pixel per mm of depth
  const size_t n = outline.matches.size();
  std::vector<Eigen::Vector3d> sides(n, plane.normal);
  Triangulation tri = triangulator.Run(sides);
  RimPoints rim = CollectRim(tri, pixel_scale, params.thickness_correction);
  rim.faces = SideFaceField(plane);
  if (!params.thickness_correction || params.side_faces == SideFaceModel::kSupportNormal) return rim;
  rim.footprint_centre =
      FootprintCentre(rectification.left().camera(), plane, outline.left, outline.left.contours[outline.left_part]);
  const bool local = params.side_faces == SideFaceModel::kLocalNormal;
  // The gains are measured again at each pass's directions: a camera may see the other
  // edge of a face once the face leans (a view turn), and such a point's dependence
  // changes. Measured once, at the support normal, a strongly warped part (faces up to
  // 0.10 rad) on the 12 mm-lens rig turned 25-40 degrees read 4-6 um high with its
  // centre tilt at half its value (InspectPart.AStronglyWarpedPartsGainsFollowItsFaces).
  std::vector<Eigen::Vector2d> gain;
  // Each match's direction is taken where it was first triangulated: later passes move
  // a point by micrometres (the normal turns by the curvature times that: 1e-5 rad).
  std::vector<Eigen::Vector3d> where(n, Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN()));
  // Settled when the directions move by 1e-4 rad RMS: a height then moves by the
  // depth-to-baseline ratio times t times that over |n_x|, 0.1 um for a 0.3 mm sheet
  // on the paper rig's steep sides.
  constexpr double kSettledRad = 1e-4;
  const int passes = local ? 4 : 2;
  for (int pass = 0; pass < passes && rim.rim.size() >= 20; ++pass) {
    for (size_t i = 0; i < tri.points.size(); ++i)
      if (!where[tri.match[i]].allFinite()) where[tri.match[i]] = tri.points[i].cam1;
    WarpFitOptions fit;
    fit.tilt_ridge = 0;
    if (local) gain = HeightGains(triangulator, tri, sides, plane);
    const FaceCoupling coupling = local ? Coupling(rim, gain, sides, plane) : FaceCoupling();
    const SideFaceField faces(params.side_faces, WarpSurface::Fit(plane, rim.rim, rim.inner, fit, &coupling),
                              rim.footprint_centre, params.max_face_tilt_rad);
    std::vector<Eigen::Vector3d> next(n);
    double change = 0;
    for (size_t m = 0; m < n; ++m) {
      next[m] = faces.At(where[m]);
      change += (next[m] - sides[m]).squaredNorm();
    }
    rim.faces = faces;
    // Settled: the last triangulation's directions are within kSettledRad of the fit's.
    if (pass > 0 && std::sqrt(change / static_cast<double>(n)) <= kSettledRad) break;
    sides = std::move(next);
    tri = triangulator.Run(sides);
    const std::optional<Eigen::Vector3d> centre = rim.footprint_centre;
    rim = CollectRim(tri, pixel_scale, params.thickness_correction);
    rim.footprint_centre = centre;
    rim.faces = faces;
  }
  rim.side_tilt_rad = rim.footprint_centre ? rim.faces.Tilt(*rim.footprint_centre) : 0.0;
  for (const Eigen::Vector3d& p : rim.rim.points) rim.max_face_tilt_rad = std::max(rim.max_face_tilt_rad, rim.faces.Tilt(p));
  return rim;
}

}  // namespace flatscan
