#include "flatscan/reconstruction/stereo_matching.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include <Eigen/Dense>

namespace flatscan {
namespace {

// N x N window of grey values around a crossing, rectified axes, sampled bilinearly
// from the raw image through the local affine map rectified -> raw.
std::vector<float> SampleWindow(const cv::Mat1b& image, const RowCrossing& c, const PointRectifier& rectifier, int n) {
  const Eigen::Vector2d at(c.x, c.row);
  const Eigen::Vector2d raw(c.raw_x, c.raw_y);
  const Eigen::Vector2d raw_at = rectifier.RectifiedToRaw(at);
  const Eigen::Vector2d ex = rectifier.RectifiedToRaw(at + Eigen::Vector2d(1, 0)) - raw_at;
  const Eigen::Vector2d ey = rectifier.RectifiedToRaw(at + Eigen::Vector2d(0, 1)) - raw_at;
  std::vector<float> w(n * n);
  const int h = n / 2;
  for (int j = -h; j <= h; ++j)
    for (int i = -h; i <= h; ++i) {
      const Eigen::Vector2d p = raw + i * ex + j * ey;
      const int x0 = static_cast<int>(std::floor(p.x())), y0 = static_cast<int>(std::floor(p.y()));
      float value = 0;
      if (x0 >= 0 && y0 >= 0 && x0 + 1 < image.cols && y0 + 1 < image.rows) {
        const float fx = static_cast<float>(p.x() - x0), fy = static_cast<float>(p.y() - y0);
        const uint8_t* r0 = image.ptr<uint8_t>(y0) + x0;
        const uint8_t* r1 = image.ptr<uint8_t>(y0 + 1) + x0;
        value = (1 - fy) * ((1 - fx) * r0[0] + fx * r0[1]) + fy * ((1 - fx) * r1[0] + fx * r1[1]);
      }
      w[(j + h) * n + (i + h)] = value;
    }
  return w;
}

struct RowIndex {
  std::map<int, std::vector<int>> rows;  // row -> crossing indices sorted by x
  explicit RowIndex(const std::vector<RowCrossing>& c) {
    for (size_t i = 0; i < c.size(); ++i) rows[c[i].row].push_back(static_cast<int>(i));
    for (auto& [row, list] : rows)
      std::sort(list.begin(), list.end(), [&](int a, int b) { return c[a].x < c[b].x; });
  }
};

}  // namespace

std::vector<StereoMatch> MatchCrossings(const std::vector<RowCrossing>& left, const std::vector<RowCrossing>& right,
                                        const cv::Mat1b& left_image, const cv::Mat1b& right_image,
                                        const PointRectifier& left_rectifier, const PointRectifier& right_rectifier,
                                        const DisparityRange& range, const MatchingParams& params) {
  const RowIndex left_rows(left), right_rows(right);
  const int n = params.window;
  std::vector<std::vector<float>> right_windows(right.size());
  auto right_window = [&](int r) -> const std::vector<float>& {
    if (right_windows[r].empty()) right_windows[r] = SampleWindow(right_image, right[r], right_rectifier, n);
    return right_windows[r];
  };
  auto usable = [&](const RowCrossing& c) { return std::abs(c.nx) >= params.min_abs_nx; };
  // Matches made so far, per left contour: (row, x_L, disparity), for C_dis.
  std::map<int, std::vector<Eigen::Vector3d>> made;
  std::vector<StereoMatch> best_left(left.size());
  // Best left for each right crossing (for the left-right check).
  std::vector<StereoMatch> best_right(right.size(), StereoMatch{-1, -1, std::numeric_limits<double>::infinity()});

  for (const auto& [row, lefts] : left_rows.rows) {
    const auto found = right_rows.rows.find(row);
    if (found == right_rows.rows.end()) continue;
    const std::vector<int>& rights = found->second;
    for (int l : lefts) {
      const RowCrossing& a = left[l];
      if (!usable(a)) continue;
      const auto [d_lo, d_hi] = range(a.x, row);
      // Reference disparity from this contour's matches within N rows (eq. 2.9).
      double d_sum = 0;
      int d_count = 0;
      for (auto it = made[a.contour].rbegin(); it != made[a.contour].rend(); ++it) {
        if (row - (*it)[0] > n) break;
        if (std::abs((*it)[1] - a.x) <= 2 * n) d_sum += (*it)[2], ++d_count;
      }
      std::vector<float> wl;
      StereoMatch best{l, -1, std::numeric_limits<double>::infinity()};
      for (int r : rights) {
        const RowCrossing& b = right[r];
        const double d = a.x - b.x;
        if (d < d_lo || d > d_hi || !usable(b) || (a.nx > 0) != (b.nx > 0)) continue;
        if (wl.empty()) wl = SampleWindow(left_image, a, left_rectifier, n);
        const std::vector<float>& wr = right_window(r);
        double ssd = 0;
        for (size_t i = 0; i < wl.size(); ++i) ssd += (wl[i] - wr[i]) * (wl[i] - wr[i]);
        const double hl = std::max(a.step, 1.0), hr = std::max(b.step, 1.0);
        const double c_ssd = ssd / (n * n * hl * hr);
        const double cos_angle = a.nx * b.nx + a.ny * b.ny;
        const double c_dir = std::abs(hl - hr) / (params.k * (hl + hr) * (cos_angle + params.sigma));
        const double d_ref = d_count > 0 ? d_sum / d_count : d;
        const double c_dis = std::abs(d - d_ref) / (params.beta0 + d_count * params.delta_beta);
        const double cost = params.alpha * c_ssd + params.beta * c_dir + params.gamma * c_dis;
        if (cost < best.cost) best = {l, r, cost};
        if (cost < best_right[r].cost) best_right[r] = {l, r, cost};
      }
      best_left[l] = best;
      if (best.right >= 0) made[a.contour].push_back(Eigen::Vector3d(row, a.x, a.x - right[best.right].x));
    }
  }
  std::vector<StereoMatch> out;
  for (const StereoMatch& m : best_left) {
    if (m.right < 0) continue;
    if (params.left_right_check && best_right[m.right].left != m.left) continue;
    out.push_back(m);
  }
  return out;
}

}  // namespace flatscan
