#include "flatscan/calibration/rig_calibration.h"

#include <glob.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <mutex>
#include <set>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <fmt/format.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <tbb/parallel_for.h>

#include "flatscan/util/error.h"

namespace flatscan {
namespace fs = std::filesystem;

namespace {

// ---------------------------------------------------------------------------------
// Corner refinement.
//
// At a chessboard X-corner q two straight edges cross. At every pixel p on an edge the
// image gradient g_p is perpendicular to the edge, which passes through q, so
// g_p . (p - q) = 0. The corner is the q that best satisfies this over a window:
//   minimise  sum_p w_p (g_p . (p - q))^2   =>   q = (sum w g g^T)^-1 (sum w g g^T p).
// This is the criterion of cv::cornerSubPix too, but cornerSubPix evaluates it on a
// window bilinearly resampled around the current estimate; the resampling acts as a
// fractional-delay filter whose phase error shifts the result by about 0.02 px,
// depending on the sub-pixel position (measured on simulated boards: 0.018 px RMS
// without any noise). Here the gradients are central differences on the pixel grid
// itself, and the window weight is a smooth radial taper (1 - r^2/R^2)^2, so pixels
// enter and leave it gradually as q moves. Why this is unbiased: a blurred X-corner
// (straight edges through q, any Gaussian blur) is point-symmetric about q, its
// gradient field is odd about q, so the contributions of p and its mirror image cancel.
//
// Noise: a Gaussian pre-smoothing (sigma 1 px, which keeps the point symmetry) lowers
// the gradient noise, and pixels whose gradient is below 10% of the largest in the
// window are left out: flat regions carry no information, only noise that grows with
// the distance from q.
//
// Window radius: as large as possible (more edge pixels, less noise) while other edges
// stay out: 0.6 x the distance from the corner to the nearest grid line that does not
// pass through it (at most that distance - 4 px, for the blur). Past the outermost
// corners the board may end sooner than one square (cut squares, a thin margin, the
// background), so border corners are refined with 0.35 x that distance as well, and
// the large-window estimate is kept only where the two agree within 0.1 px.
//
// Measured (corner error against the truth on simulated 'paper' boards, blur 1 px,
// noise 2 grey): cv::cornerSubPix 0.023 px RMS at its best window, this 0.0075 px;
// 'compact' (blur 0.8, noise 2.5): 0.027 vs 0.011 px. On OpenCV's stereo sample images
// the stereo RMS drops from 0.20 px (cornerSubPix, best fixed window 7) to 0.19 px and
// the epipolar error from 0.23 to 0.18 px; with the sample's own 11 px window, 0.44 px.
constexpr double kPresmoothSigmaPx = 1.0;
constexpr double kGradientThresholdFraction = 0.1;
constexpr double kInteriorRadiusFraction = 0.6;
constexpr double kBorderRadiusFraction = 0.35;
constexpr double kBorderAgreementPx = 0.1;
constexpr double kEdgeClearancePx = 4.0;
constexpr double kMinRadiusPx = 3.0;
constexpr double kMaxRadiusPx = 120.0;
constexpr int kMaxRefineIterations = 50;
constexpr double kConvergedStepPx = 1e-4;

// cv::findChessboardCorners runs on a copy of the image reduced to at most this many
// pixels on its longer side (it is slow on multi-megapixel images and gains nothing
// there: the refinement works on the full-resolution image).
constexpr int kDetectionMaxSide = 1000;

// Inner corners on a side of the chessboard, at most (a calibration target has tens).
constexpr int kMaxBoardSide = 100;

// Gradient fields of a region of the image: gx, gy in grey levels per pixel.
struct GradientField {
  cv::Rect roi;  // in image coordinates
  cv::Mat1f gx, gy;
};

GradientField ComputeGradients(const cv::Mat& gray, cv::Rect roi) {
  GradientField field;
  field.roi = roi & cv::Rect(0, 0, gray.cols, gray.rows);
  cv::Mat1f smooth;
  gray(field.roi).convertTo(smooth, CV_32F);
  cv::GaussianBlur(smooth, smooth, cv::Size(), kPresmoothSigmaPx);
  // ksize 1: the plain central difference [-1 0 1] / 2, without cross smoothing.
  cv::Sobel(smooth, field.gx, CV_32F, 1, 0, 1, 0.5);
  cv::Sobel(smooth, field.gy, CV_32F, 0, 1, 1, 0.5);
  return field;
}

// One corner: iterate q = (sum w g g^T)^-1 (sum w g g^T p) with the window centred on
// q. Returns false if the normal matrix is singular (fewer than two edge directions).
bool RefineOneCorner(const GradientField& field, double radius, Eigen::Vector2d& q) {
  const double r2_max = radius * radius;
  const int x_off = field.roi.x, y_off = field.roi.y;
  for (int iter = 0; iter < kMaxRefineIterations; ++iter) {
    const int u0 = std::max(1, static_cast<int>(std::floor(q.x() - radius)) - x_off);
    const int u1 = std::min(field.roi.width - 2, static_cast<int>(std::ceil(q.x() + radius)) - x_off);
    const int v0 = std::max(1, static_cast<int>(std::floor(q.y() - radius)) - y_off);
    const int v1 = std::min(field.roi.height - 2, static_cast<int>(std::ceil(q.y() + radius)) - y_off);
    if (u0 > u1 || v0 > v1) return false;
    double g2_max = 0;
    for (int v = v0; v <= v1; ++v)
      for (int u = u0; u <= u1; ++u) {
        const double gx = field.gx(v, u), gy = field.gy(v, u);
        g2_max = std::max(g2_max, gx * gx + gy * gy);
      }
    const double g2_min = kGradientThresholdFraction * kGradientThresholdFraction * g2_max;
    Eigen::Matrix2d normal = Eigen::Matrix2d::Zero();
    Eigen::Vector2d rhs = Eigen::Vector2d::Zero();
    for (int v = v0; v <= v1; ++v)
      for (int u = u0; u <= u1; ++u) {
        const double px = u + x_off, py = v + y_off;
        const double dx = px - q.x(), dy = py - q.y();
        const double r2 = (dx * dx + dy * dy) / r2_max;
        if (r2 >= 1) continue;
        const double gx = field.gx(v, u), gy = field.gy(v, u);
        if (gx * gx + gy * gy < g2_min) continue;
        const double w = (1 - r2) * (1 - r2);
        const double gxx = w * gx * gx, gxy = w * gx * gy, gyy = w * gy * gy;
        normal(0, 0) += gxx;
        normal(0, 1) += gxy;
        normal(1, 1) += gyy;
        rhs.x() += gxx * px + gxy * py;
        rhs.y() += gxy * px + gyy * py;
      }
    normal(1, 0) = normal(0, 1);
    // Both eigenvalues must be substantial: two edge directions through the window.
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen(normal);
    const Eigen::Vector2d ev = eigen.eigenvalues();
    if (!(ev(0) > 1e-6 * ev(1)) || !(ev(1) > 0)) return false;
    const Eigen::Vector2d next = normal.inverse() * rhs;
    const double step = (next - q).norm();
    q = next;
    if (!q.allFinite()) return false;
    if (step < kConvergedStepPx) break;
  }
  return true;
}

// Distance from corner (i, j) to the nearest grid line that does not pass through it:
// the rows j +- 1 and the columns i +- 1, as far as they exist on the board.
double DistanceToNeighbourLines(const std::vector<cv::Point2f>& c, const ChessboardSpec& board, int i, int j) {
  const int w = board.columns, h = board.rows;
  const auto at = [&](int a, int b) { return Eigen::Vector2d(c[b * w + a].x, c[b * w + a].y); };
  const Eigen::Vector2d q = at(i, j);
  const auto line_distance = [&](const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    const Eigen::Vector2d d = (b - a).normalized();
    const Eigen::Vector2d r = q - a;
    return std::abs(r.x() * d.y() - r.y() * d.x());
  };
  double best = std::numeric_limits<double>::infinity();
  for (int s : {-1, 1}) {
    const int col = i + s, row = j + s;
    if (col >= 0 && col < w)
      best = std::min(best, line_distance(at(col, std::max(0, j - 1)), at(col, std::min(h - 1, j + 1))));
    if (row >= 0 && row < h)
      best = std::min(best, line_distance(at(std::max(0, i - 1), row), at(std::min(w - 1, i + 1), row)));
  }
  return best;
}

// Maps a point of an image resized by `scale` back to the original (OpenCV's resize
// maps pixel centres: x_src = (x_dst + 0.5) / scale - 0.5).
cv::Point2f FromResized(const cv::Point2f& p, double scale) {
  return {static_cast<float>((p.x + 0.5) / scale - 0.5), static_cast<float>((p.y + 0.5) / scale - 0.5)};
}

// Large images: a reduced copy first, then the full resolution. Small images: as they
// are, then enlarged 2x (as stereo_calib does: it helps with small squares). The first
// attempt is cv::findChessboardCorners as it is (immediate where the board is; 2.6 s on
// the 1000 px copy of an image that shows a board of another size). Before the second,
// slow one, the sector-based detector (cv::findChessboardCornersSB) says whether a board
// of this size is there at all: the classic detector searched a 5 MP image showing a 9x6
// board as 7x5 for more than 5 minutes per pair, the sector-based one answers in 0.6 s.
// (It is not the first attempt because it misses boards the classic detector finds on
// OpenCV's own sample images.) Where it finds the board and the classic detector does
// not, its corners stand in; the refinement that follows works on the full-resolution
// image either way.
bool DetectApproximateCorners(const cv::Mat& gray, cv::Size pattern, std::vector<cv::Point2f>& corners) {
  const int flags = cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE;
  const int side = std::max(gray.cols, gray.rows);
  const std::vector<double> scales = side > kDetectionMaxSide * 1.3
                                         ? std::vector<double>{static_cast<double>(kDetectionMaxSide) / side, 1.0}
                                         : std::vector<double>{1.0, 2.0};
  for (size_t attempt = 0; attempt < scales.size(); ++attempt) {
    const double scale = scales[attempt];
    cv::Mat image = gray;
    if (scale != 1.0)
      cv::resize(gray, image, cv::Size(), scale, scale, scale < 1 ? cv::INTER_AREA : cv::INTER_LINEAR_EXACT);
    std::vector<cv::Point2f> sector_corners;
    if (attempt > 0 && !cv::findChessboardCornersSB(image, pattern, sector_corners)) continue;
    if (!cv::findChessboardCorners(image, pattern, corners, flags)) {
      if (sector_corners.empty()) continue;
      corners = sector_corners;
    }
    for (cv::Point2f& p : corners) p = FromResized(p, scale);
    return true;
  }
  return false;
}

// ---------------------------------------------------------------------------------
// Calibration helpers.

Eigen::Matrix3d Skew(const Eigen::Vector3d& t) {
  Eigen::Matrix3d s;
  s << 0, -t.z(), t.y(), t.z(), 0, -t.x(), -t.y(), t.x(), 0;
  return s;
}

// Fundamental matrix x2^T F x1 = 0 for pixels of the two cameras once undistorted
// (pinhole pixels u = fx x + cx): F = K2^-T [T]x R K1^-1.
Eigen::Matrix3d FundamentalMatrix(const StereoRig& rig) {
  Eigen::Matrix3d k1, k2;
  cv::cv2eigen(rig.left.CameraMatrix(), k1);
  cv::cv2eigen(rig.right.CameraMatrix(), k2);
  const Rigid3d& pose = rig.cam2_from_cam1;
  return k2.inverse().transpose() * Skew(pose.translation) * pose.rotation * k1.inverse();
}

// Ideal (undistorted) pixel of a raw corner, homogeneous.
Eigen::Vector3d IdealPixel(const Camera& camera, const cv::Point2f& raw) {
  return camera.PixelToIdeal(Eigen::Vector2d(raw.x, raw.y)).homogeneous();
}

// Sum over the corners of one pair of d(x1, line of x2) + d(x2, line of x1).
double EpipolarErrorSum(const StereoRig& rig, const Eigen::Matrix3d& f, const BoardViewPair& view) {
  double sum = 0;
  for (size_t k = 0; k < view.left.size(); ++k) {
    const Eigen::Vector3d x1 = IdealPixel(rig.left, view.left[k]);
    const Eigen::Vector3d x2 = IdealPixel(rig.right, view.right[k]);
    const Eigen::Vector3d line_in_2 = f * x1, line_in_1 = f.transpose() * x2;
    sum += std::abs(line_in_2.dot(x2)) / line_in_2.head<2>().norm() +
           std::abs(line_in_1.dot(x1)) / line_in_1.head<2>().norm();
  }
  return sum;
}

// The first `n` distortion coefficients (OpenCV may return up to 14, the rest zero
// unless thin-prism or tilt terms were asked for, which they are not).
cv::Mat FirstCoefficients(const cv::Mat& distortion, int n) {
  cv::Mat d;
  distortion.convertTo(d, CV_64F);
  d = d.reshape(1, 1);
  FLATSCAN_CHECK(d.cols >= n);
  return d.colRange(0, n).clone();
}

RigReplicate ToReplicate(const cv::Mat& m1, const cv::Mat& d1, const cv::Mat& m2, const cv::Mat& d2, const cv::Mat& r,
                         const cv::Mat& t, cv::Size image_size, int n_coefficients) {
  RigReplicate out;
  out.left = Camera::FromOpenCv(m1, FirstCoefficients(d1, n_coefficients), image_size.width, image_size.height);
  out.right = Camera::FromOpenCv(m2, FirstCoefficients(d2, n_coefficients), image_size.width, image_size.height);
  cv::Mat r64, t64;
  r.convertTo(r64, CV_64F);
  t.convertTo(t64, CV_64F);
  Eigen::Matrix3d rotation;
  Eigen::Vector3d translation;
  cv::cv2eigen(r64, rotation);
  cv::cv2eigen(t64.reshape(1, 3), translation);
  out.cam2_from_cam1 = {rotation, translation};
  return out;
}

std::string SizeText(cv::Size s) { return fmt::format("{}x{}", s.width, s.height); }

cv::Mat LoadGrayImage(const fs::path& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) ThrowInputError("image '{}' does not exist", path.string());
  if (!fs::is_regular_file(path, ec)) ThrowInputError("image '{}' is not a file", path.string());
  cv::Mat image;
  try {
    image = cv::imread(path.string(), cv::IMREAD_GRAYSCALE);
  } catch (const cv::Exception&) {
    image.release();
  }
  if (image.empty())
    ThrowInputError("cannot read image '{}' (expected an image file OpenCV can decode, such as PNG or JPEG)",
                    path.string());
  return image;
}

cv::Mat ReadImage(const fs::path& path, const RigCalibrationOptions& options) {
  return options.read_image ? options.read_image(path) : LoadGrayImage(path);
}

// "; the images seem to show a board of 9x6 inner corners (try --board 9x6)": the size
// DetectedBoardSize finds most often in the first left images (at most 5, about 0.2 s
// each; several, since it misreads some images).
std::string BoardSizeHint(const std::vector<ImagePairFiles>& pairs, const RigCalibrationOptions& options) {
  std::map<std::pair<int, int>, int> votes;
  for (size_t i = 0; i < std::min<size_t>(pairs.size(), 5); ++i)
    if (const std::optional<cv::Size> seen = DetectedBoardSize(ReadImage(pairs[i].left, options)))
      ++votes[{seen->width, seen->height}];
  const auto best = std::max_element(votes.begin(), votes.end(),
                                     [](const auto& a, const auto& b) { return a.second < b.second; });
  if (best == votes.end()) return "";
  return fmt::format("; the images seem to show a board of {0}x{1} inner corners (try --board {0}x{1})",
                     best->first.first, best->first.second);
}

// What the detection gave for one pair.
struct PairDetection {
  cv::Size size;
  ChessboardCorners left, right;
  std::string error;  // an InputError message (unreadable image, size mismatch)
};

// OpenCV's flags for the coefficients `model` fits (without CALIB_USE_INTRINSIC_GUESS
// the single-camera fits start k3 at 0, so CALIB_FIX_K3 holds it there).
int CalibrationFlags(DistortionModel model) {
  switch (model) {
    case DistortionModel::kRational: return cv::CALIB_RATIONAL_MODEL;
    case DistortionModel::kTwoRadial: return cv::CALIB_FIX_K3;
    case DistortionModel::kStandard: break;
  }
  return 0;
}

}  // namespace

bool RefineChessboardCorners(const cv::Mat& gray, const ChessboardSpec& board, std::vector<cv::Point2f>& corners,
                             std::string* failure) {
  FLATSCAN_CHECK(gray.type() == CV_8UC1);
  FLATSCAN_CHECK(static_cast<int>(corners.size()) == board.columns * board.rows);
  const int n = static_cast<int>(corners.size());
  std::vector<double> line_distance(n);
  double max_radius = 0;
  const cv::Rect bounds = cv::boundingRect(corners);
  for (int k = 0; k < n; ++k) {
    line_distance[k] = DistanceToNeighbourLines(corners, board, k % board.columns, k / board.columns);
    max_radius = std::max(max_radius, std::min(kMaxRadiusPx, kInteriorRadiusFraction * line_distance[k]));
  }
  const int margin = static_cast<int>(std::ceil(max_radius + 4 * kPresmoothSigmaPx + 4));
  const GradientField field = ComputeGradients(
      gray, cv::Rect(bounds.x - margin, bounds.y - margin, bounds.width + 2 * margin, bounds.height + 2 * margin));

  std::vector<cv::Point2f> refined = corners;
  for (int k = 0; k < n; ++k) {
    const int i = k % board.columns, j = k / board.columns;
    const double d = line_distance[k];
    const double radius =
        std::clamp(std::min(kInteriorRadiusFraction * d, d - kEdgeClearancePx), kMinRadiusPx, kMaxRadiusPx);
    const Eigen::Vector2d start(corners[k].x, corners[k].y);
    Eigen::Vector2d q = start;
    bool ok = RefineOneCorner(field, radius, q);
    const bool border = i == 0 || j == 0 || i == board.columns - 1 || j == board.rows - 1;
    if (ok && border) {
      Eigen::Vector2d q_small = start;
      const double small_radius = std::clamp(kBorderRadiusFraction * d, kMinRadiusPx, kMaxRadiusPx);
      if (RefineOneCorner(field, small_radius, q_small) && (q_small - q).norm() > kBorderAgreementPx) q = q_small;
    }
    // The detector's corners are within a pixel or two (a few at full resolution when
    // detected on a reduced copy); a refinement that runs further has locked onto
    // something else.
    if (ok && (q - start).norm() > std::max(3.0, 0.5 * radius)) ok = false;
    if (!ok) {
      if (failure)
        *failure = fmt::format("corner refinement failed at inner corner ({}, {}) near pixel ({:.1f}, {:.1f})", i, j,
                               corners[k].x, corners[k].y);
      return false;
    }
    refined[k] = cv::Point2f(static_cast<float>(q.x()), static_cast<float>(q.y()));
  }
  corners = refined;
  return true;
}

ChessboardCorners FindChessboardCorners(const cv::Mat& gray, const ChessboardSpec& board) {
  ChessboardCorners out;
  if (!DetectApproximateCorners(gray, board.PatternSize(), out.corners)) {
    out.corners.clear();
    out.failure = fmt::format("no {}x{} chessboard (inner corners) found", board.columns, board.rows);
    return out;
  }
  out.found = RefineChessboardCorners(gray, board, out.corners, &out.failure);
  if (!out.found) out.corners.clear();
  return out;
}

std::optional<cv::Size> DetectedBoardSize(const cv::Mat& gray) {
  std::vector<cv::Point2f> corners;
  cv::Mat meta;
  bool found = false;
  try {
    found = cv::findChessboardCornersSB(gray, cv::Size(3, 3), corners, cv::CALIB_CB_LARGER, meta);
  } catch (const cv::Exception&) {
    found = false;
  }
  if (!found || meta.empty()) return std::nullopt;
  // meta's rows and columns follow the board's orientation in the image; either order
  // is a valid --board.
  return cv::Size(std::max(meta.cols, meta.rows), std::min(meta.cols, meta.rows));
}

bool AlignCornerOrder(const std::vector<cv::Point2f>& left, std::vector<cv::Point2f>& right,
                      const ChessboardSpec& board) {
  const int w = board.columns, h = board.rows;
  FLATSCAN_CHECK(static_cast<int>(left.size()) == w * h && right.size() == left.size());
  // Candidate orders of the right corners: the relabellings (i, j) -> source index that
  // map the pattern onto itself.
  std::vector<std::function<int(int, int)>> orders = {
      [&](int i, int j) { return j * w + i; },
      [&](int i, int j) { return (h - 1 - j) * w + (w - 1 - i); },
  };
  if (w == h) {
    orders.push_back([&](int i, int j) { return (w - 1 - i) * w + j; });
    orders.push_back([&](int i, int j) { return i * w + (w - 1 - j); });
  }
  // Grid directions of a labelling: along a row (first to last column) and a column.
  const auto directions = [&](const std::function<cv::Point2f(int, int)>& at) {
    const cv::Point2f row = at(w - 1, 0) - at(0, 0) + at(w - 1, h - 1) - at(0, h - 1);
    const cv::Point2f col = at(0, h - 1) - at(0, 0) + at(w - 1, h - 1) - at(w - 1, 0);
    return std::pair<cv::Point2f, cv::Point2f>(row * (1.0f / cv::norm(row)), col * (1.0f / cv::norm(col)));
  };
  const auto [left_row, left_col] = directions([&](int i, int j) { return left[j * w + i]; });
  int best = 0;
  double best_score = -1e9;
  for (size_t o = 0; o < orders.size(); ++o) {
    const auto [row, col] = directions([&](int i, int j) { return right[orders[o](i, j)]; });
    const double score = left_row.dot(row) + left_col.dot(col);
    if (score > best_score) {
      best_score = score;
      best = static_cast<int>(o);
    }
  }
  if (best == 0) return false;
  std::vector<cv::Point2f> reordered(right.size());
  for (int j = 0; j < h; ++j)
    for (int i = 0; i < w; ++i) reordered[j * w + i] = right[orders[best](i, j)];
  right = std::move(reordered);
  return true;
}

std::vector<fs::path> ExpandGlob(const std::string& pattern) {
  glob_t matches{};
  const int status = ::glob(pattern.c_str(), 0, nullptr, &matches);
  std::vector<fs::path> out;
  if (status == 0) {
    for (size_t i = 0; i < matches.gl_pathc; ++i) {
      std::error_code ec;
      const fs::path p(matches.gl_pathv[i]);
      if (!fs::is_directory(p, ec)) out.push_back(p);
    }
  }
  globfree(&matches);
  if (out.empty() && status != 0 && status != GLOB_NOMATCH)
    ThrowInputError("'{}': cannot list the matching files (read error)", pattern);
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<ImagePairFiles> PairImagesByName(const std::vector<std::string>& left_patterns,
                                             const std::vector<std::string>& right_patterns) {
  const auto expand = [](const std::vector<std::string>& patterns, const std::string& field) {
    if (patterns.empty()) ThrowFieldError(field, "expected at least one image file or pattern");
    std::set<fs::path> files;
    for (const std::string& p : patterns) {
      const std::vector<fs::path> matched = ExpandGlob(p);
      if (matched.empty())
        ThrowFieldError(field, "'{}': no file matches (expected a file name or a pattern such as 'calib/left*.png')", p);
      files.insert(matched.begin(), matched.end());
    }
    return std::vector<fs::path>(files.begin(), files.end());
  };
  const std::vector<fs::path> left = expand(left_patterns, "left"), right = expand(right_patterns, "right");
  if (left.size() != right.size()) {
    const bool more_left = left.size() > right.size();
    const fs::path& extra = more_left ? left[right.size()] : right[left.size()];
    ThrowFieldError("left",
                    "matched {} images but the right images matched {}; pairs are made by sorted name, so both must "
                    "match the same number (first image without a partner: '{}')",
                    left.size(), right.size(), extra.string());
  }
  std::vector<ImagePairFiles> pairs;
  for (size_t i = 0; i < left.size(); ++i) pairs.push_back({left[i], right[i]});
  return pairs;
}

RigCalibrationReport CalibrateRig(const std::vector<ImagePairFiles>& pairs, const RigCalibrationOptions& options) {
  const ChessboardSpec& board = options.board;
  if (board.columns < 3 || board.rows < 3 || board.columns > kMaxBoardSide || board.rows > kMaxBoardSide)
    ThrowFieldError("board", "{}x{}: expected 3 to {} inner corners on each side", board.columns, board.rows,
                    kMaxBoardSide);
  if (!(board.square_mm > 0)) ThrowFieldError("board.square_mm", "expected the square side > 0 mm, got {}", board.square_mm);
  if (pairs.empty()) ThrowInputError("no image pairs given");

  // Detection, pairs in parallel (each reads its own two images).
  std::vector<PairDetection> detections(pairs.size());
  std::mutex progress_mutex;
  tbb::parallel_for(size_t{0}, pairs.size(), [&](size_t i) {
    PairDetection& d = detections[i];
    try {
      const cv::Mat left = ReadImage(pairs[i].left, options);
      const cv::Mat right = ReadImage(pairs[i].right, options);
      if (left.size() != right.size()) {
        ThrowInputError("images '{}' ({}) and '{}' ({}) of a pair differ in size (expected both cameras to give the "
                        "same image size)",
                        pairs[i].left.string(), SizeText(left.size()), pairs[i].right.string(),
                        SizeText(right.size()));
      }
      d.size = left.size();
      d.left = FindChessboardCorners(left, board);
      d.right = FindChessboardCorners(right, board);
    } catch (const InputError& e) {
      d.error = e.what();
    }
    if (options.progress) {
      const std::lock_guard<std::mutex> lock(progress_mutex);
      options.progress(fmt::format("pair {} of {}: {} {}", i + 1, pairs.size(), pairs[i].left.filename().string(),
                                   d.error.empty() ? (d.left.found && d.right.found ? "board found" : "no board")
                                                   : "error"));
    }
  });
  for (const PairDetection& d : detections)
    if (!d.error.empty()) throw InputError(d.error);

  // The calibration image size: the one most pairs with a board share.
  std::map<std::pair<int, int>, int> size_votes;
  for (const PairDetection& d : detections)
    if (d.left.found && d.right.found) ++size_votes[{d.size.width, d.size.height}];
  if (size_votes.empty()) {
    ThrowFieldError("board",
                    "no {}x{} chessboard (inner corners) found in both images of any of the {} pairs (first pair: "
                    "'{}', '{}'; expected the board's inner corners as columns x rows, as OpenCV counts them){}",
                    board.columns, board.rows, pairs.size(), pairs.front().left.string(), pairs.front().right.string(),
                    BoardSizeHint(pairs, options));
  }
  cv::Size image_size;
  int best_votes = 0;
  for (const PairDetection& d : detections) {  // first in name order among equals
    if (!(d.left.found && d.right.found)) continue;
    const int votes = size_votes[{d.size.width, d.size.height}];
    if (votes > best_votes) {
      best_votes = votes;
      image_size = d.size;
    }
  }

  std::vector<BoardViewPair> views;
  std::vector<RejectedPair> rejected;
  for (size_t i = 0; i < pairs.size(); ++i) {
    const PairDetection& d = detections[i];
    const std::string left_name = pairs[i].left.string(), right_name = pairs[i].right.string();
    std::string reason;
    if (!d.left.found && !d.right.found)
      reason = d.left.failure == d.right.failure
                   ? d.left.failure + " in either image"
                   : fmt::format("{} in the left image; {} in the right image", d.left.failure, d.right.failure);
    else if (!d.left.found)
      reason = d.left.failure + " in the left image";
    else if (!d.right.found)
      reason = d.right.failure + " in the right image";
    else if (d.size != image_size)
      reason = fmt::format("image size {} differs from the {} of the other {} pairs", SizeText(d.size),
                           SizeText(image_size), best_votes);
    if (!reason.empty()) {
      rejected.push_back({left_name, right_name, reason});
      continue;
    }
    BoardViewPair view{left_name, right_name, d.left.corners, d.right.corners};
    AlignCornerOrder(view.left, view.right, board);
    views.push_back(std::move(view));
  }
  if (static_cast<int>(views.size()) < kMinCalibrationPairs) {
    std::string why;
    for (const RejectedPair& r : rejected) why += fmt::format("\n  {}: {}", r.left, r.reason);
    ThrowInputError("only {} of the {} pairs show the {}x{} board in both images; at least {} are needed{}",
                    views.size(), pairs.size(), board.columns, board.rows, kMinCalibrationPairs, why);
  }
  return CalibrateRigFromCorners(views, image_size, options, std::move(rejected), static_cast<int>(pairs.size()));
}

RigCalibrationReport CalibrateRigFromCorners(const std::vector<BoardViewPair>& views, cv::Size image_size,
                                             const RigCalibrationOptions& options, std::vector<RejectedPair> rejected,
                                             int pairs_total) {
  const ChessboardSpec& board = options.board;
  const int n_corners = board.columns * board.rows;
  FLATSCAN_CHECK(!views.empty());
  std::vector<std::vector<cv::Point3f>> object_points;
  std::vector<std::vector<cv::Point2f>> left_points, right_points;
  std::vector<cv::Point3f> board_points;
  for (int j = 0; j < board.rows; ++j)
    for (int i = 0; i < board.columns; ++i)
      board_points.emplace_back(static_cast<float>(i * board.square_mm), static_cast<float>(j * board.square_mm), 0.f);
  for (const BoardViewPair& v : views) {
    FLATSCAN_CHECK(static_cast<int>(v.left.size()) == n_corners && static_cast<int>(v.right.size()) == n_corners);
    object_points.push_back(board_points);
    left_points.push_back(v.left);
    right_points.push_back(v.right);
  }

  const int model_flags = CalibrationFlags(options.model);
  // Tighter than OpenCV's defaults (30, 1e-6 for the pair); tighter still changes nothing
  // measurable (1e-3 px in cx) but costs 3x the time.
  const cv::TermCriteria criteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100, 1e-10);
  RigCalibrationReport report;
  report.board = board;
  report.model = options.model;
  report.image_width = image_size.width;
  report.image_height = image_size.height;
  report.pairs_total = pairs_total >= 0 ? pairs_total : static_cast<int>(views.size() + rejected.size());
  report.rejected = std::move(rejected);

  // Each camera alone: a good starting point for the joint refinement, and its RMS.
  cv::Mat m1, d1, m2, d2;
  std::vector<cv::Mat> rvecs, tvecs;
  report.left_rms_px = cv::calibrateCamera(object_points, left_points, image_size, m1, d1, rvecs, tvecs, model_flags,
                                           criteria);
  report.right_rms_px = cv::calibrateCamera(object_points, right_points, image_size, m2, d2, rvecs, tvecs, model_flags,
                                            criteria);
  // The pair: both cameras' intrinsics, distortion and the relative pose together, as
  // the board poses are shared by the two cameras. Measured on the simulated rigs this
  // recovers the pose 2-10x better than keeping the single-camera intrinsics fixed
  // (CALIB_FIX_INTRINSIC), and on OpenCV's sample it lowers both error figures.
  cv::Mat r, t, e, f, per_view;
  report.rms_px = cv::stereoCalibrate(object_points, left_points, right_points, m1, d1, m2, d2, image_size, r, t, e, f,
                                      per_view, cv::CALIB_USE_INTRINSIC_GUESS | model_flags, criteria);

  StereoRig& rig = report.rig;
  const int n_coefficients = options.model == DistortionModel::kRational ? 8 : 5;
  const RigReplicate full = ToReplicate(m1, d1, m2, d2, r, t, image_size, n_coefficients);
  rig.left = full.left;
  rig.right = full.right;
  rig.cam2_from_cam1 = full.cam2_from_cam1;
  rig.ComputeRectification();
  if (options.replicates && views.size() >= 4) {
    rig.replicates.resize(views.size());
    tbb::parallel_for(size_t{0}, views.size(), [&](size_t left_out) {
      auto without = [left_out](auto all) {
        all.erase(all.begin() + static_cast<std::ptrdiff_t>(left_out));
        return all;
      };
      cv::Mat m1_i = m1.clone(), d1_i = d1.clone(), m2_i = m2.clone(), d2_i = d2.clone(), r_i, t_i, e_i, f_i;
      cv::stereoCalibrate(without(object_points), without(left_points), without(right_points), m1_i, d1_i, m2_i, d2_i,
                          image_size, r_i, t_i, e_i, f_i, cv::CALIB_USE_INTRINSIC_GUESS | model_flags, criteria);
      rig.replicates[left_out] = ToReplicate(m1_i, d1_i, m2_i, d2_i, r_i, t_i, image_size, n_coefficients);
    });
  }

  const Eigen::Matrix3d fundamental = FundamentalMatrix(rig);
  double epipolar_sum = 0;
  for (size_t v = 0; v < views.size(); ++v) {
    const double sum = EpipolarErrorSum(rig, fundamental, views[v]);
    epipolar_sum += sum;
    ViewError ve;
    ve.left = views[v].left_name;
    ve.right = views[v].right_name;
    ve.left_rms_px = per_view.at<double>(static_cast<int>(v), 0);
    ve.right_rms_px = per_view.at<double>(static_cast<int>(v), 1);
    ve.epipolar_px = sum / n_corners;
    report.views.push_back(ve);
  }
  report.epipolar_px = epipolar_sum / (static_cast<double>(n_corners) * views.size());
  return report;
}

double MeanEpipolarError(const StereoRig& rig, const std::vector<BoardViewPair>& views) {
  const Eigen::Matrix3d fundamental = FundamentalMatrix(rig);
  double sum = 0;
  size_t count = 0;
  for (const BoardViewPair& v : views) {
    FLATSCAN_CHECK(v.left.size() == v.right.size());
    sum += EpipolarErrorSum(rig, fundamental, v);
    count += v.left.size();
  }
  return count > 0 ? sum / count : 0.0;
}

nlohmann::json RigCalibrationReport::ToJson() const {
  nlohmann::json j;
  j["rms_px"] = rms_px;
  j["epipolar_px"] = epipolar_px;
  j["epipolar_definition"] =
      "mean over corner pairs of the distances of both undistorted corners to their partner's epipolar line, summed "
      "over the two images (OpenCV stereo_calib.cpp's 'average epipolar err')";
  j["left_rms_px"] = left_rms_px;
  j["right_rms_px"] = right_rms_px;
  j["pairs_used"] = PairsUsed();
  j["pairs_total"] = pairs_total;
  j["pairs_rejected"] = nlohmann::json::array();
  for (const RejectedPair& r : rejected)
    j["pairs_rejected"].push_back({{"left", r.left}, {"right", r.right}, {"reason", r.reason}});
  j["image_width"] = image_width;
  j["image_height"] = image_height;
  j["board"] = {{"inner_corners", {board.columns, board.rows}}, {"square_mm", board.square_mm}};
  j["distortion_model"] = DistortionModelName(model);
  j["views"] = nlohmann::json::array();
  for (const ViewError& v : views)
    j["views"].push_back({{"left", v.left},
                          {"right", v.right},
                          {"left_rms_px", v.left_rms_px},
                          {"right_rms_px", v.right_rms_px},
                          {"epipolar_px", v.epipolar_px}});
  const Eigen::AngleAxisd angle(rig.cam2_from_cam1.rotation);
  j["rig"] = {{"left", {{"fx", rig.left.fx}, {"fy", rig.left.fy}, {"cx", rig.left.cx}, {"cy", rig.left.cy}}},
              {"right", {{"fx", rig.right.fx}, {"fy", rig.right.fy}, {"cx", rig.right.cx}, {"cy", rig.right.cy}}},
              {"baseline_mm", rig.BaselineMm()},
              {"rotation_deg", angle.angle() * 180.0 / M_PI}};
  return j;
}

}  // namespace flatscan
