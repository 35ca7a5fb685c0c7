#include "flatscan/inspection/stereo_outline.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <tuple>

#include "flatscan/util/error.h"

namespace flatscan {
namespace {

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

// A part's outline that does not close: open contours (the outline in one or more
// pieces) whose every end lies close to another end, together long enough for a part.
// Measured cause: a dark speck (dust on the backlight or the lens) touching the part's
// edge joins the two silhouettes by a blurred neck where the edge's gradient is too
// weak to follow (docs/inspection.md, "Image defects"). The outline there is hidden:
// not measured, with the reason.
void ThrowIfOutlineIsBroken(const BoundaryResult& b, const ImageAcceptance& accept, const std::string& name) {
  std::vector<Eigen::Vector2d> ends;
  double length = 0;
  for (const ContourInfo& info : b.contours) {
    if (info.closed || info.end - info.begin < 2) continue;
    for (int i : {info.begin, info.end - 1}) ends.emplace_back(b.points[i].x, b.points[i].y);
    length += info.length_px;
  }
  if (ends.empty() || length < 2 * accept.min_cut_contour_px) return;
  std::vector<Eigen::Vector2d> gaps;
  for (size_t i = 0; i < ends.size(); ++i) {
    double nearest = std::numeric_limits<double>::infinity();
    size_t partner = i;
    for (size_t j = 0; j < ends.size(); ++j)
      if (j != i && (ends[j] - ends[i]).norm() < nearest) nearest = (ends[j] - ends[i]).norm(), partner = j;
    if (nearest > accept.max_outline_gap_px) return;  // a loose end: not an interrupted outline
    if (partner > i) gaps.push_back(0.5 * (ends[i] + ends[partner]));
  }
  std::string where;
  for (const Eigen::Vector2d& g : gaps) where += fmt::format("{}({:.0f}, {:.0f})", where.empty() ? "" : ", ", g.x(), g.y());
  ThrowInputError("{}: the part's outline is interrupted near {} px: a dark speck (dust on the backlight or the lens) "
                  "touching the part's edge? Clean the backlight and the lenses and measure again",
                  name, where);
}

// Grey level at (x, y), bilinear; NaN outside the image.
double GreyAt(const cv::Mat1b& image, double x, double y) {
  const int u = static_cast<int>(std::floor(x)), v = static_cast<int>(std::floor(y));
  if (u < 0 || v < 0 || u + 1 >= image.cols || v + 1 >= image.rows) return std::numeric_limits<double>::quiet_NaN();
  const double fx = x - u, fy = y - v;
  return (1 - fy) * ((1 - fx) * image(v, u) + fx * image(v, u + 1)) + fy * ((1 - fx) * image(v + 1, u) + fx * image(v + 1, u + 1));
}

// How much brighter the backlight is just outside the part's edge than a little further
// out, over the edge's step: median over the outline of (I(p + 2 n) - I(p + 8 n)) / step,
// n the outward normal. A blurred step is below its plateau 2 px out (measured -2% at
// blur 0.8 px, -4% at 1.0 px), so a positive value is a halo: light reflected by bright metal
// edges, which the step model does not have (measured: it pulls the blur estimate from
// 0.80 to 0.27 px and the heights by up to tens of micrometres).
double HaloContrast(const BoundaryResult& b, const ContourInfo& c, const cv::Mat1b& image) {
  std::vector<double> contrast;
  for (int i = c.begin; i < c.end; i += 4) {
    const EdgePoint& p = b.points[i];
    if (p.step <= 0) continue;
    const double near = GreyAt(image, p.x + 2 * p.nx, p.y + 2 * p.ny), far = GreyAt(image, p.x + 8 * p.nx, p.y + 8 * p.ny);
    if (std::isfinite(near) && std::isfinite(far)) contrast.push_back((near - far) / p.step);
  }
  if (contrast.empty()) return 0;
  std::nth_element(contrast.begin(), contrast.begin() + contrast.size() / 2, contrast.end());
  return contrast[contrast.size() / 2];
}

// Checks what the image shows and returns the outer contour of the one part.
int FindPartContour(const BoundaryResult& b, const cv::Mat1b& image, const ImageAcceptance& accept, const std::string& name) {
  if (b.bright_level < accept.min_backlight_grey)
    ThrowInputError("{}: under-exposed (backlight grey level {:.0f}; expected at least {:.0f}): increase exposure or light",
                    name, b.bright_level, accept.min_backlight_grey);
  if (b.saturated_fraction > accept.max_saturated_fraction)
    ThrowInputError("{}: over-exposed ({:.0f}% of the backlight is saturated at 255): reduce exposure so the backlight stays below 255",
                    name, 100 * b.saturated_fraction);
  if (b.blur_sigma_px > accept.max_blur_sigma_px)
    ThrowInputError("{}: out of focus (the edges' blur sigma is {:.2f} px; expected at most {:.2f} px): focus the lens "
                    "on the support plane, or close its aperture for more depth of field",
                    name, b.blur_sigma_px, accept.max_blur_sigma_px);
  int best = -1, parts = 0;
  double best_area = 0;
  std::vector<double> areas(b.contours.size(), 0.0);
  const double min_area = accept.min_part_area_fraction * image.cols * image.rows;
  for (size_t c = 0; c < b.contours.size(); ++c) {
    const ContourInfo& info = b.contours[c];
    if (!info.closed || !EnclosesMaterial(b, info)) continue;
    areas[c] = std::abs(SignedArea(b, info));
    if (areas[c] > best_area) best_area = areas[c], best = static_cast<int>(c);
  }
  // Open contours that end at the image border: a part cut by the border.
  for (const ContourInfo& info : b.contours) {
    if (info.closed || info.length_px < accept.min_cut_contour_px) continue;
    const EdgePoint& a = b.points[info.begin];
    const EdgePoint& z = b.points[info.end - 1];
    const double m = accept.border_margin_px;
    auto near_border = [&](const EdgePoint& p) {
      return p.x < m || p.y < m || p.x > image.cols - 1 - m || p.y > image.rows - 1 - m;
    };
    if (near_border(a) || near_border(z))
      ThrowInputError("{}: the part touches the image border: place it fully inside both cameras' views", name);
  }
  if (best < 0 || best_area < min_area) {
    ThrowIfOutlineIsBroken(b, accept, name);
    ThrowInputError("{}: no part found (expected a dark part on the bright backlight, fully in view)", name);
  }
  for (size_t c = 0; c < b.contours.size(); ++c)
    if (areas[c] > accept.second_part_area_ratio * best_area) ++parts;
  if (parts > 1) ThrowInputError("{}: {} parts found: inspect one part at a time", name, parts);
  const double halo = HaloContrast(b, b.contours[best], image);
  if (halo > accept.max_halo_contrast)
    ThrowInputError("{}: a bright halo around the part's edge (the backlight {:.0f}% of the edge's step brighter 2 px "
                    "outside it than 8 px out; expected at most {:.0f}%): light reflected by bright metal edges biases "
                    "the edge: use a matte fixture or part finish, or a backlight whose light does not graze the edges",
                    name, 100 * halo, 100 * accept.max_halo_contrast);
  return best;
}

// Disparities a part resting on the plane can have at a left crossing: between
// 0.5 mm below the plane and max_height_mm above it, along the left ray, widened by
// half a pixel.
class PlausibleDisparities {
 public:
  PlausibleDisparities(const RectifiedStereo& stereo, const SupportPlane& plane, double max_height_mm)
      : stereo_(stereo),
        up_(stereo.rect1_from_cam1 * plane.normal),
        on_plane_(stereo.rect1_from_cam1 * plane.point),
        max_height_mm_(max_height_mm) {}
  std::pair<double, double> operator()(double x, int row) const {
    const Eigen::Vector3d d = stereo_.LeftRay(x, row);
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (double h : {-0.5, max_height_mm_}) {
      const Eigen::Vector3d p = d * (up_.dot(on_plane_ + h * up_) / up_.dot(d));
      const double disparity = stereo_.Disparity(p);
      lo = std::min(lo, disparity), hi = std::max(hi, disparity);
    }
    return {lo - 0.5, hi + 0.5};
  }

 private:
  const RectifiedStereo& stereo_;
  Eigen::Vector3d up_, on_plane_;
  double max_height_mm_;
};

// The part's outline enters each row at its leftmost crossing in both images; the
// disparity there must be the support plane's plus at most a few mm of height. With
// the images swapped it comes out near the negative of the expected one.
void CheckDisparitySign(const std::vector<RowCrossing>& lc, const std::vector<RowCrossing>& rc, int left_part,
                        int right_part, const PlausibleDisparities& range, const std::string& left_name, const std::string& right_name) {
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

// Nothing matched: left and right swapped show as disparities of the opposite sign;
// anything else is a rig or plane that does not belong to these images.
[[noreturn]] void ThrowNothingMatched(const std::vector<RowCrossing>& lc, const std::vector<RowCrossing>& rc,
                                      const PlausibleDisparities& range, const std::string& left_name,
                                      const std::string& right_name) {
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

}  // namespace

StereoOutline MatchStereoOutline(const StereoRectification& rectification, const SupportPlane& plane,
                                 const cv::Mat1b& left, const cv::Mat1b& right, const InspectionParams& params,
                                 const std::string& left_name, const std::string& right_name, StageTimer* timer) {
  const PointRectifier &left_rect = rectification.left(), &right_rect = rectification.right();
  for (const auto& [image, name, cam] : {std::tuple(&left, &left_name, &left_rect.camera()),
                                         std::tuple(&right, &right_name, &right_rect.camera())})
    if (image->cols != cam->width || image->rows != cam->height)
      ThrowInputError("{}: image is {}x{} but the rig was calibrated for {}x{}: use the images of the calibrated cameras",
                      *name, image->cols, image->rows, cam->width, cam->height);
  StereoOutline out;
  out.left = DetectBoundary(left, params.boundary);
  timer->Mark("boundary_left");
  out.right = DetectBoundary(right, params.boundary);
  timer->Mark("boundary_right");
  out.left_part = FindPartContour(out.left, left, params.acceptance, left_name);
  out.right_part = FindPartContour(out.right, right, params.acceptance, right_name);

  out.left_crossings = CrossRows(out.left, [&](const Eigen::Vector2d& p) { return left_rect.RawToRectified(p); });
  out.right_crossings = CrossRows(
      out.right, [&](const Eigen::Vector2d& p) { return right_rect.RawToRectified(p); }, &out.right_chains);
  timer->Mark("rectify_crossings");

  const PlausibleDisparities range(rectification.stereo(), plane, params.max_height_mm);
  CheckDisparitySign(out.left_crossings, out.right_crossings, out.left_part, out.right_part, range, left_name, right_name);
  out.matches = MatchCrossings(out.left_crossings, out.right_crossings, left, right, left_rect, right_rect, range,
                               params.matching);
  timer->Mark("matching");
  if (out.matches.empty()) ThrowNothingMatched(out.left_crossings, out.right_crossings, range, left_name, right_name);
  return out;
}

}  // namespace flatscan
