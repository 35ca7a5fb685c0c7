#include "flatscan/inspection/inspect_part.h"

#include <algorithm>
#include <array>
#include <optional>
#include <span>
#include <chrono>
#include <map>
#include <cmath>

#include <Eigen/Dense>
#include <opencv2/core/eigen.hpp>

#include "flatscan/flatness/rim_heights.h"
#include "flatscan/reconstruction/outlier_filter.h"
#include "flatscan/reconstruction/rectified_stereo.h"
#include "flatscan/util/error.h"

namespace flatscan {
namespace {

class StageTimer {
 public:
  explicit StageTimer(std::vector<std::pair<std::string, double>>* out) : out_(out) {}
  void Mark(const std::string& stage) {
    const auto now = std::chrono::steady_clock::now();
    out_->emplace_back(stage, std::chrono::duration<double, std::milli>(now - last_).count());
    last_ = now;
  }

 private:
  std::vector<std::pair<std::string, double>>* out_;
  std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

// Raw image point <-> rectified point of one camera (exact undistortion).
struct CameraRectification {
  const Camera& camera;
  Eigen::Matrix3d rect_from_cam;
  double f, cx, cy;
  CameraRectification(const Camera& cam, const cv::Mat& r, const cv::Mat& p) : camera(cam) {
    cv::cv2eigen(r, rect_from_cam);
    f = p.at<double>(0, 0);
    cx = p.at<double>(0, 2);
    cy = p.at<double>(1, 2);
  }
  Eigen::Vector2d ToRectified(const Eigen::Vector2d& raw) const {
    const Eigen::Vector2d n = camera.PixelToNormalized(raw);
    const Eigen::Vector3d x = rect_from_cam * Eigen::Vector3d(n.x(), n.y(), 1.0);
    return {f * x.x() / x.z() + cx, f * x.y() / x.z() + cy};
  }
  Eigen::Vector2d ToRaw(const Eigen::Vector2d& rect) const {
    const Eigen::Vector3d x = rect_from_cam.transpose() * Eigen::Vector3d((rect.x() - cx) / f, (rect.y() - cy) / f, 1.0);
    return camera.NormalizedToPixel(Eigen::Vector2d(x.x() / x.z(), x.y() / x.z()));
  }
};

double SignedArea(const BoundaryResult& b, const ContourInfo& c) {
  double area = 0;
  for (int i = c.begin; i < c.end; ++i) {
    const EdgePoint& p = b.points[i];
    const EdgePoint& q = b.points[i + 1 < c.end ? i + 1 : c.begin];
    area += p.x * q.y - q.x * p.y;
  }
  return 0.5 * area;
}

// A closed contour whose normals (dark -> bright) point away from its centroid
// encloses dark material: a part's outer boundary (holes have them pointing inward).
bool EnclosesMaterial(const BoundaryResult& b, const ContourInfo& c) {
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
  for (int i = c.begin; i < c.end; ++i) centroid += Eigen::Vector2d(b.points[i].x, b.points[i].y);
  centroid /= (c.end - c.begin);
  double outward = 0;
  for (int i = c.begin; i < c.end; ++i)
    outward += (Eigen::Vector2d(b.points[i].x, b.points[i].y) - centroid).dot(Eigen::Vector2d(b.points[i].nx, b.points[i].ny));
  return outward > 0;
}

// Checks what the image shows and returns the outer contour of the one part.
int FindPartContour(const BoundaryResult& b, const cv::Mat1b& image, const std::string& name) {
  if (b.bright_level < 60)
    ThrowInputError("{}: under-exposed (backlight grey level {:.0f}; expected at least 60): increase exposure or light", name, b.bright_level);
  if (b.saturated_fraction > 0.25)
    ThrowInputError("{}: over-exposed ({:.0f}% of the backlight is saturated at 255): reduce exposure so the backlight stays below 255",
                    name, 100 * b.saturated_fraction);
  int best = -1, parts = 0;
  double best_area = 0;
  std::vector<double> areas(b.contours.size(), 0.0);
  const double min_area = 1e-4 * image.cols * image.rows;
  for (size_t c = 0; c < b.contours.size(); ++c) {
    const ContourInfo& info = b.contours[c];
    if (!info.closed || !EnclosesMaterial(b, info)) continue;
    areas[c] = std::abs(SignedArea(b, info));
    if (areas[c] > best_area) best_area = areas[c], best = static_cast<int>(c);
  }
  // Open contours that end at the image border: a part cut by the border.
  for (const ContourInfo& info : b.contours) {
    if (info.closed || info.length_px < 50) continue;
    const EdgePoint& a = b.points[info.begin];
    const EdgePoint& z = b.points[info.end - 1];
    auto near_border = [&](const EdgePoint& p) {
      return p.x < 10 || p.y < 10 || p.x > image.cols - 11 || p.y > image.rows - 11;
    };
    if (near_border(a) || near_border(z))
      ThrowInputError("{}: the part touches the image border: place it fully inside both cameras' views", name);
  }
  if (best < 0 || best_area < min_area)
    ThrowInputError("{}: no part found (expected a dark part on the bright backlight, fully in view)", name);
  for (size_t c = 0; c < b.contours.size(); ++c)
    if (areas[c] > 0.1 * best_area) ++parts;
  if (parts > 1) ThrowInputError("{}: {} parts found: inspect one part at a time", name, parts);
  return best;
}

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

// The bottom-rim point seen at raw left pixel `q` (image normal `n`) on the warp
// surface: the left ray meets the silhouette edge (the top edge when camera 1 is on
// the inner side of the side face), which lies `thickness` above the bottom rim.
// Fixed point h = surface height where the ray meets the level h: it contracts by the
// surface slope times the ray's obliquity; a point where it does not settle to 0.1 um
// is not completed (NaN; a runaway once gave +4.5 mm).
Eigen::Vector3d LiftLeftSilhouette(const WarpSurface& warp, const Camera& left, const Eigen::Vector2d& q,
                                   const Eigen::Vector2d& n, double thickness) {
  const Eigen::Vector2d xy = left.PixelToNormalized(q);
  const Eigen::Vector2d xy_out = left.PixelToNormalized(q + 0.5 * n);
  const Eigen::Vector3d d(xy.x(), xy.y(), 1.0), d_out(xy_out.x(), xy_out.y(), 1.0);
  const SupportPlane& plane = warp.plane();
  const Eigen::Vector3d& up = plane.normal;
  double h = 0.0;
  for (int iter = 0; iter < 8; ++iter) {
    const double level = up.dot(plane.point) + h;
    const Eigen::Vector3d seen = d * (level / up.dot(d));
    Eigen::Vector3d outward = d_out * (level / up.dot(d_out)) - seen;
    outward -= outward.dot(up) * up;
    const int top = (-seen).dot(outward) > 0 ? 0 : 1;  // camera 1 is at the origin
    const Eigen::Vector3d bottom = seen - top * thickness * up;
    const double next = warp.Height(bottom) + top * thickness;
    if (std::abs(next - h) < 1e-4 && iter > 0) return bottom;
    h = next;
  }
  return Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
}

// The part's outline enters each row at its leftmost crossing in both images; the
// disparity there must be the support plane's plus at most a few mm of height. With
// the images swapped it comes out near the negative of the expected one.
template <typename Range>
void CheckDisparitySign(const std::vector<RowCrossing>& lc, const std::vector<RowCrossing>& rc, int left_part,
                        int right_part, const Range& range, const std::string& left_name, const std::string& right_name) {
  // (row, leftmost x) of one contour's crossings, by row.
  auto leftmost = [](const std::vector<RowCrossing>& crossings, int contour) {
    std::vector<std::pair<int, double>> rows;
    for (const RowCrossing& c : crossings)
      if (c.contour == contour) rows.emplace_back(c.row, c.x);
    std::sort(rows.begin(), rows.end());
    rows.erase(std::unique(rows.begin(), rows.end(), [](const auto& a, const auto& b) { return a.first == b.first; }),
               rows.end());
    return rows;
  };
  const std::vector<std::pair<int, double>> first_left = leftmost(lc, left_part), first_right = leftmost(rc, right_part);
  std::vector<double> offsets;  // observed minus expected disparity, in units of the allowed range
  for (size_t i = 0, j = 0; i < first_left.size() && j < first_right.size();) {
    if (first_left[i].first != first_right[j].first) {
      (first_left[i].first < first_right[j].first ? i : j)++;
      continue;
    }
    const auto [row, xl] = first_left[i];
    const auto [lo, hi] = range(xl, row);
    offsets.push_back(((xl - first_right[j].second) - lo) / std::max(hi - lo, 1.0));
    ++i, ++j;
  }
  // Rows are epipolar lines: the outline's first and last rows are the same in both
  // rectified images (its extreme points lie on tangent epipolar planes).
  if (!first_left.empty() && !first_right.empty()) {
    const int top = std::abs(first_left.front().first - first_right.front().first);
    const int bottom = std::abs(first_left.back().first - first_right.back().first);
    if (std::max(top, bottom) > 3)
      ThrowInputError("{} and {}: the part's outline spans different rows in the two rectified views ({} px apart): the "
                      "images do not fit the rig: check that left and right are not swapped and that the rig file "
                      "belongs to these cameras", left_name, right_name, std::max(top, bottom));
  }
  if (offsets.size() < 10) return;
  std::nth_element(offsets.begin(), offsets.begin() + offsets.size() / 2, offsets.end());
  const double median = offsets[offsets.size() / 2];
  if (median < -1.0)
    ThrowInputError("{} and {}: the disparities are negative: the left and right images look swapped", left_name, right_name);
}

}  // namespace

InspectionResult InspectPart(const StereoRig& rig, const SupportPlane& plane, const cv::Mat1b& left,
                             const cv::Mat1b& right, const InspectionParams& params, const std::string& left_name,
                             const std::string& right_name) {
  for (const auto& [image, name, cam] : {std::tuple(&left, &left_name, &rig.left), std::tuple(&right, &right_name, &rig.right)})
    if (image->cols != cam->width || image->rows != cam->height)
      ThrowInputError("{}: image is {}x{} but the rig was calibrated for {}x{}: use the images of the calibrated cameras",
                      *name, image->cols, image->rows, cam->width, cam->height);
  InspectionResult result;
  StageTimer timer(&result.timing_ms);
  const BoundaryResult lb = DetectBoundary(left, params.boundary);
  timer.Mark("boundary_left");
  const BoundaryResult rb = DetectBoundary(right, params.boundary);
  timer.Mark("boundary_right");
  result.blur_left_px = lb.blur_sigma_px;
  result.blur_right_px = rb.blur_sigma_px;
  const int left_part = FindPartContour(lb, left, left_name);
  const int right_part = FindPartContour(rb, right, right_name);

  const CameraRectification left_rect(rig.left, rig.rectification.R1, rig.rectification.P1);
  const CameraRectification right_rect(rig.right, rig.rectification.R2, rig.rectification.P2);
  const std::vector<RowCrossing> lc = CrossRows(lb, [&](const Eigen::Vector2d& p) { return left_rect.ToRectified(p); });
  std::vector<std::vector<Eigen::Vector2d>> right_rectified;  // each right contour's chain, rectified
  const std::vector<RowCrossing> rc =
      CrossRows(rb, [&](const Eigen::Vector2d& p) { return right_rect.ToRectified(p); }, &right_rectified);
  result.crossings_left = static_cast<int>(lc.size());
  result.crossings_right = static_cast<int>(rc.size());
  timer.Mark("rectify_crossings");

  // Disparities a part resting on the plane can have: between the plane and
  // max_height_mm above it, along the left ray.
  const RectifiedStereo stereo = RectifiedStereo::FromRig(rig);
  const Eigen::Vector3d up = stereo.rect1_from_cam1 * plane.normal;
  const Eigen::Vector3d on_plane = stereo.rect1_from_cam1 * plane.point;
  auto range = [&](double x, int row) {
    const Eigen::Vector3d d = stereo.LeftRay(x, row);
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (double h : {-0.5, params.max_height_mm}) {
      const Eigen::Vector3d p = d * (up.dot(on_plane + h * up) / up.dot(d));
      const double disparity = stereo.Disparity(p);
      lo = std::min(lo, disparity), hi = std::max(hi, disparity);
    }
    return std::make_pair(lo - 0.5, hi + 0.5);
  };
  CheckDisparitySign(lc, rc, left_part, right_part, range, left_name, right_name);
  const std::vector<StereoMatch> matches =
      MatchCrossings(lc, rc, left, right, [&](const Eigen::Vector2d& p) { return left_rect.ToRaw(p); },
                     [&](const Eigen::Vector2d& p) { return right_rect.ToRaw(p); }, range, params.matching);
  result.matched = static_cast<int>(matches.size());
  timer.Mark("matching");
  if (matches.empty()) {
    // Left and right swapped show as disparities of the opposite sign.
    int negative = 0, total = 0;
    for (const RowCrossing& a : lc)
      for (const RowCrossing& b : rc)
        if (a.row == b.row && (a.nx > 0) == (b.nx > 0)) {
          const auto [lo, hi] = range(a.x, a.row);
          ++total;
          if ((b.x - a.x) >= lo && (b.x - a.x) <= hi) ++negative;
        }
    if (total > 0 && negative > total / 10)
      ThrowInputError("{} and {}: the disparities are negative: the left and right images look swapped", left_name, right_name);
    ThrowInputError("{} and {}: no boundary point could be matched between the images (expected the same part seen by both "
                    "cameras of this rig on this support plane): check the rig and plane files", left_name, right_name);
  }

  // The right silhouette near a crossing, rectified, in chain order (for the
  // thickness-aware triangulation, which needs the curve off the crossing's row): a
  // window of each contour's rectified chain, which for a closed contour is padded
  // with its own ends so that every window is contiguous.
  constexpr int kReach = 24;  // chain points either side (about 1 px apart)
  std::vector<std::vector<Eigen::Vector2d>> right_chains(rb.contours.size());
  auto right_silhouette = [&](const RowCrossing& b) -> std::span<const Eigen::Vector2d> {
    std::vector<Eigen::Vector2d>& chain = right_chains[b.contour];
    const ContourInfo& info = rb.contours[b.contour];
    const int n = info.end - info.begin;
    const int pad = info.closed ? kReach : 0;
    if (chain.empty()) {
      const std::vector<Eigen::Vector2d>& rectified = right_rectified[b.contour];
      chain.reserve(n + 2 * pad + 1);
      for (int k = -pad; k < n + pad + 1; ++k)
        if (info.closed || k < n) chain.push_back(rectified[((k % n) + n) % n]);
    }
    const int first = std::max(0, b.index - kReach + pad);
    const int last = std::min(static_cast<int>(chain.size()) - 1, b.index + 1 + kReach + pad);
    return std::span<const Eigen::Vector2d>(chain.data() + first, last - first + 1);
  };

  // Triangulate, thickness-aware, with the side faces along `side` (rectified frame 1).
  struct Triangulated {
    std::vector<InspectedPoint> points;
    std::vector<double> weight;      // inverse variance: a crossing's x error grows as 1 / |n_x|
    std::vector<int> chain_index;    // the left crossing's chain index
    std::vector<BottomPoint> seen;   // which edges, how the faces are seen
    std::vector<int> match;          // index in `matches`
    std::vector<bool> keep;          // radius outlier filter
  };
  const Eigen::Matrix3d cam1_from_rect1 = stereo.rect1_from_cam1.transpose();
  // Each match's right silhouette, made once for all the passes below.
  std::vector<std::span<const Eigen::Vector2d>> silhouettes;
  if (params.thickness_correction) {
    silhouettes.reserve(matches.size());
    for (const StereoMatch& m : matches) silhouettes.push_back(right_silhouette(rc[m.right]));
  }
  // The radius filter runs on the first pass only: a change of the side-face direction
  // moves points by t times the change of tilt (micrometres), not across a 0.25 mm
  // radius; later passes keep the first pass's verdict per match.
  std::vector<char> keep_match;
  auto triangulate = [&](const Eigen::Vector3d& side) {
    Triangulated t;
    std::vector<Eigen::Vector3d> cam1;
    std::vector<double> radii;
    for (size_t mi = 0; mi < matches.size(); ++mi) {
      const StereoMatch& m = matches[mi];
      const RowCrossing& a = lc[m.left];
      const RowCrossing& b = rc[m.right];
      InspectedPoint p;
      BottomPoint bp;
      if (params.thickness_correction) {
        bp = TriangulateBottomPoint(stereo, a.x, a.row, Eigen::Vector2d(a.nx, a.ny), silhouettes[mi], b.x, side,
                                    params.thickness_mm);
        if (!bp.valid) continue;
        p.left_edge = bp.left_edge;
        p.right_edge = bp.right_edge;
      } else {
        bp.rect1 = TriangulateRow(stereo, a.x, b.x, a.row);
        if (!(bp.rect1.z() > 0)) continue;
      }
      p.cam1 = cam1_from_rect1 * bp.rect1;
      p.left_raw = Eigen::Vector2d(a.raw_x, a.raw_y);
      p.right_raw = Eigen::Vector2d(b.raw_x, b.raw_y);
      p.outer = a.contour == left_part;
      p.height_mm = plane.Height(p.cam1);
      t.points.push_back(p);
      t.seen.push_back(bp);
      cam1.push_back(p.cam1);
      t.chain_index.push_back(a.index);
      t.match.push_back(static_cast<int>(mi));
      t.weight.push_back(a.nx * a.nx * b.nx * b.nx / (a.nx * a.nx + b.nx * b.nx));
      // Consecutive row crossings lie one row / |n_x| apart along the boundary: where it
      // runs near the rows they are sparse, and the radius must reach 2.5 spacings to
      // find the neighbours a point on a well-sampled stretch has.
      const double spacing_mm = p.cam1.z() / stereo.f / std::max(std::abs(a.nx), 1e-3);
      radii.push_back(std::max(params.outlier_radius_mm, 2.5 * spacing_mm));
    }
    if (keep_match.empty()) {
      t.keep = RadiusOutlierFilter(cam1, radii, params.outlier_min_neighbours);
      keep_match.assign(matches.size(), 0);
      for (size_t i = 0; i < t.keep.size(); ++i) keep_match[t.match[i]] = t.keep[i];
    } else {
      t.keep.resize(t.points.size());
      for (size_t i = 0; i < t.keep.size(); ++i) t.keep[i] = keep_match[t.match[i]];
    }
    return t;
  };
  // The rim of one triangulation: valid outer points in chain order (by the left
  // crossing's chain index), with the points near a camera's view turning across the
  // side face dropped; and the measured edges of the part's holes (the same sheet).
  struct Rim {
    std::vector<bool> drop;
    std::vector<std::pair<int, int>> order;  // (chain index, index in tri)
    HeightSamples outer, inner;
  };
  auto build_rim = [&](const Triangulated& tri) {
    Rim out;
    std::vector<std::pair<int, int>> chain_order;  // (chain index, index in tri)
    for (size_t i = 0; i < tri.points.size(); ++i)
      if (tri.keep[i] && tri.points[i].outer) chain_order.emplace_back(tri.chain_index[i], static_cast<int>(i));
    std::sort(chain_order.begin(), chain_order.end());
    // Where a camera's view of the side face turns from outside to inside (its line of
    // sight grazes the face: a corner), its silhouette runs along the face's vertical
    // generator, which is neither edge: rim points within the generator's length (plus
    // the edge operator's reach) of such a turn are dropped. A side whose face the
    // camera sees edge-on all along (|facing| below kGrazing beyond the reach on both
    // sides of the turn) flips between the two edges with the noise of the normal; there
    // the two edges project onto one line and either solution moves the point along the
    // rim by at most the generator's length (a micrometre of height), so it is kept
    // (measured: up to 160 of 900 points of a 12 mm-lens part were dropped before).
    out.drop.assign(tri.points.size(), false);
    if (params.thickness_correction && chain_order.size() > 2) {
      constexpr double kGrazing = 0.01;
      const int m = static_cast<int>(chain_order.size());
      auto point = [&](int j) -> const InspectedPoint& { return tri.points[chain_order[((j % m) + m) % m].second]; };
      auto seen = [&](int j) -> const BottomPoint& { return tri.seen[chain_order[((j % m) + m) % m].second]; };
      // Each camera's facing averaged over 9 neighbours along the rim: the normal's
      // noise (about +-0.004 here) would flip the sign of a face seen nearly edge-on.
      std::array<std::vector<double>, 2> mean_facing;
      for (int camera = 0; camera < 2; ++camera) {
        mean_facing[camera].resize(m);
        for (int j = 0; j < m; ++j) {
          double sum = 0;
          for (int k = j - 4; k <= j + 4; ++k) sum += camera == 0 ? seen(k).facing_left : seen(k).facing_right;
          mean_facing[camera][j] = sum / 9;
        }
      }
      std::vector<int> stretch;
      for (int j = 0; j < m; ++j) {
        for (int camera = 0; camera < 2; ++camera) {
          auto facing = [&](int k) { return mean_facing[camera][((k % m) + m) % m]; };
          auto generator = [&](int k) { return camera == 0 ? seen(k).generator_left_mm : seen(k).generator_right_mm; };
          if ((facing(j) > 0) == (facing(j + 1) > 0)) continue;
          const double reach = std::max(generator(j), generator(j + 1)) + 2.5 * point(j).cam1.z() / stereo.f;
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
          for (int k : stretch) out.drop[chain_order[((k % m) + m) % m].second] = true;
        }
      }
    }
    // A short run of points left between two dropped stretches (a corner where both
    // cameras' views turn) has no neighbours to check it: dropped too (measured: +16 um
    // from one such point at a corner).
    constexpr double kShortRunMm = 0.25;
    if (!chain_order.empty()) {
      const int m = static_cast<int>(chain_order.size());
      int first_dropped = -1;
      for (int j = 0; j < m && first_dropped < 0; ++j)
        if (out.drop[chain_order[j].second]) first_dropped = j;
      if (first_dropped >= 0) {
        std::vector<int> run;
        double length = 0;
        for (int step = 1; step <= m; ++step) {
          const int j = (first_dropped + step) % m;
          const int i = chain_order[j].second;
          if (!out.drop[i]) {
            if (!run.empty()) length += (tri.points[i].cam1 - tri.points[chain_order[(j + m - 1) % m].second].cam1).norm();
            run.push_back(i);
            continue;
          }
          if (!run.empty() && length < kShortRunMm)
            for (int k : run) out.drop[k] = true;
          run.clear();
          length = 0;
        }
      }
    }
    for (const auto& [index, i] : chain_order) {
      if (out.drop[i]) continue;
      out.order.emplace_back(index, i);
      out.outer.Add(tri.points[i].cam1, tri.points[i].height_mm, tri.weight[i]);
    }
    for (size_t i = 0; i < tri.points.size(); ++i)
      if (tri.keep[i] && !out.drop[i] && !tri.points[i].outer)
        out.inner.Add(tri.points[i].cam1, tri.points[i].height_mm, tri.weight[i]);
    return out;
  };

  // Side-face direction. A cut sheet's side faces are perpendicular to the sheet. The
  // first pass takes them along the support normal; a part resting tilted on three
  // points (burrs, warp) has its faces tilted with it, and where the two cameras see
  // different edges a face tilt theta shifts the silhouette seen at the top edge by
  // t theta, i.e. heights by about t theta Z / baseline (more on sides running near the
  // epipolar rows). So the sheet's normal is estimated from the first pass: the normal
  // of the fitted warp surface (cubic, ridge on the curvature) at the footprint's
  // centre, which separates the rest tilt from the warp's odd terms (the rim's
  // least-squares plane does not: its tilt mixes both). The faces are then taken along
  // that normal everywhere (assumed: the faces are parallel to the sheet normal at the
  // part's centre, exact for a flat tilted sheet; a warped sheet's local normal at
  // the rim differs by the warp's slope there, which is not modelled).
  Triangulated tri = triangulate(up);
  Rim rim = build_rim(tri);
  result.side_tilt_rad = 0;
  // Two passes: the first estimate comes from heights biased by the very tilt it
  // estimates (measured: 10-20% too large); the second is within a few percent.
  const bool estimate_tilt = params.thickness_correction && params.estimate_side_tilt;
  const std::optional<Eigen::Vector3d> centre = FootprintCentre(rig.left, plane, lb, lb.contours[left_part]);
  for (int pass = 0; pass < 2 && estimate_tilt && centre && rim.outer.size() >= 20; ++pass) {
    // A small ridge on the tilt terms: among tilts the data cannot tell from the odd
    // cubic terms (two opposite sides measured, the others along the rows) the lesser
    // (measured on 300 parts: 1e-3 halves well-determined tilts, 0 lets low-coverage
    // parts take spurious ones).
    WarpFitOptions fit;
    fit.tilt_ridge = 1e-4;
    Eigen::Vector3d normal = WarpSurface::Fit(plane, rim.outer, rim.inner, fit).SheetNormal(*centre);
    // A tilt beyond what a resting part can have is a failed fit: capped.
    const double tilt = std::acos(std::clamp(normal.dot(plane.normal), -1.0, 1.0));
    if (tilt > params.max_side_tilt_rad)
      normal = (plane.normal + std::tan(params.max_side_tilt_rad) *
                                  (normal - normal.dot(plane.normal) * plane.normal).normalized()).normalized();
    result.side_tilt_rad = std::min(tilt, params.max_side_tilt_rad);
    if (!normal.allFinite() || result.side_tilt_rad <= 1e-5) break;
    tri = triangulate(stereo.rect1_from_cam1 * normal);
    rim = build_rim(tri);
  }
  timer.Mark("triangulation");

  std::vector<int> result_index(tri.points.size(), -1);
  for (size_t i = 0; i < tri.points.size(); ++i) {
    if (!tri.keep[i] || rim.drop[i]) continue;
    result_index[i] = static_cast<int>(result.points.size());
    result.points.push_back(tri.points[i]);
  }
  std::vector<std::pair<int, int>> chain_order;  // (chain index, index in result.points)
  for (const auto& [index, i] : rim.order) chain_order.emplace_back(index, result_index[i]);
  result.valid = static_cast<int>(result.points.size());
  if (rim.outer.size() < 10)
    ThrowInputError("{} and {}: only {} valid points on the part's outline (expected at least 10): check focus, "
                    "exposure and calibration", left_name, right_name, rim.outer.size());
  // Heights: warp surface plus the significant local deviations (flatness/rim_heights.h).
  RimHeightOptions height_options;
  height_options.sigma_mm = params.height_smoothing_mm;
  height_options.significance = params.deviation_significance;
  const RimHeights heights = EstimateRimHeights(plane, rim.outer, rim.inner, height_options);
  result.rim_noise_mm = heights.deviation_spread_mm;
  result.local_deviations = heights.significant;
  // Each rim point moved along the plane normal to its estimated height, so the zone
  // widths (lsq_pv, minzone) see the same rim as flatness_mm.
  std::vector<Eigen::Vector3d> rim_all = rim.outer.points;
  std::vector<double> heights_all = heights.heights;
  for (size_t j = 0; j < chain_order.size(); ++j) {
    rim_all[j] += (heights.heights[j] - rim.outer.heights[j]) * plane.normal;
    result.points[chain_order[j].second].height_mm = heights.heights[j];
  }
  timer.Mark("rim_heights");

  // Coverage: outer-boundary chain segments with a valid point within 2 segments.
  const ContourInfo& outer = lb.contours[left_part];
  const int n = outer.end - outer.begin;
  std::vector<char> has_point(n, 0);
  for (const auto& [index, i] : chain_order)
    for (int k = -2; k <= 2; ++k) has_point[((index + k) % n + n) % n] = 1;
  double covered = 0, total = 0;
  for (int i = 0; i < n; ++i) {
    const EdgePoint& p = lb.points[outer.begin + i];
    const EdgePoint& q = lb.points[outer.begin + (i + 1) % n];
    const double len = std::hypot(q.x - p.x, q.y - p.y);
    total += len;
    if (has_point[i]) covered += len;
  }
  result.coverage = total > 0 ? covered / total : 0.0;

  // Stretches the two cameras cannot measure (boundary along the epipolar rows) are
  // completed from the warp surface fitted to the measured rim and hole edges.
  if (params.complete_unmeasured && result.coverage < 1.0) {
    const auto [lo, hi] = std::minmax_element(heights.heights.begin(), heights.heights.end());
    const double measured_min = *lo, measured_max = *hi, margin = 0.5 * (*hi - *lo) + 0.02;
    for (int i = 0; i < n; ++i) {
      if (has_point[i]) continue;
      const EdgePoint& e = lb.points[outer.begin + i];
      const Eigen::Vector3d bottom = LiftLeftSilhouette(heights.warp, rig.left, Eigen::Vector2d(e.x, e.y), Eigen::Vector2d(e.nx, e.ny),
                                                        params.thickness_correction ? params.thickness_mm : 0.0);
      if (!bottom.allFinite()) continue;
      // A safety net for a fit the data do not hold (once +4.5 mm on a 0.2 mm part): a
      // completed height beyond the measured rim's range widened by half that range
      // (plus 20 um) is not used.
      const double h = heights.warp.Height(bottom);
      if (h > measured_max + margin || h < measured_min - margin) continue;
      rim_all.push_back(bottom);
      heights_all.push_back(h);
      ++result.completed;
    }
  }
  result.values = ComputeFlatness(rim_all, heights_all);
  result.pass = result.values.flatness_mm <= params.tolerance_mm;
  timer.Mark("flatness");
  return result;
}

}  // namespace flatscan
