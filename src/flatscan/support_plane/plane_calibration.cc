#include "flatscan/support_plane/plane_calibration.h"

#include <algorithm>
#include <cmath>
#include <functional>

#include <Eigen/Dense>
#include <fmt/format.h>

#include "flatscan/geometry/plane_fit.h"
#include "flatscan/util/error.h"

namespace flatscan {
namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

Eigen::Matrix3d Skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d s;
  s << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return s;
}

Eigen::Vector2d Normalized(const Camera& camera, const Eigen::Vector2d& undistorted_px) {
  return {(undistorted_px.x() - camera.cx) / camera.fx, (undistorted_px.y() - camera.cy) / camera.fy};
}

// Orients `normal` toward the cameras (camera 1 at the origin): n . (0 - point) > 0.
Eigen::Vector3d TowardCameras(const Eigen::Vector3d& normal, const Eigen::Vector3d& point) {
  return normal.dot(-point) >= 0 ? normal : Eigen::Vector3d(-normal);
}

SupportPlaneFit MakeFit(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& normal,
                 const Eigen::Vector3d& centroid) {
  SupportPlaneFit fit;
  fit.point = centroid;
  fit.normal = TowardCameras(normal.normalized(), centroid);
  for (const Eigen::Vector3d& p : points) fit.residuals_mm.push_back(fit.normal.dot(p - centroid));
  return fit;
}

Eigen::Vector3d Centroid(const std::vector<Eigen::Vector3d>& points) {
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : points) c += p;
  return c / static_cast<double>(points.size());
}

std::string DescribeRejections(const MarkerDetection& d) {
  if (d.rejected.empty()) return "no other dark or bright outlines were seen";
  std::string out;
  const size_t shown = std::min<size_t>(d.rejected.size(), 6);
  for (size_t i = 0; i < shown; ++i) {
    const RejectedContour& r = d.rejected[i];
    out += fmt::format("{}outline at ({:.0f}, {:.0f}): {}", i ? "; " : "", r.centroid_px.x(), r.centroid_px.y(),
                       r.reason);
  }
  if (shown < d.rejected.size()) out += fmt::format("; and {} more", d.rejected.size() - shown);
  return out;
}

// True when `rights` (right indices in left cyclic order) is a rotation of an
// increasing sequence, i.e. the matching keeps the cyclic order of both images.
bool KeepsCyclicOrder(const std::vector<int>& rights) {
  const size_t n = rights.size();
  if (n < 3) return true;
  int descents = 0;
  for (size_t k = 0; k < n; ++k) descents += rights[(k + 1) % n] < rights[k] ? 1 : 0;
  return descents == 1;
}

}  // namespace

double SupportPlaneFit::RmsMm() const {
  double s = 0;
  for (double r : residuals_mm) s += r * r;
  return residuals_mm.empty() ? 0.0 : std::sqrt(s / residuals_mm.size());
}

double SupportPlaneFit::MaxAbsMm() const {
  double m = 0;
  for (double r : residuals_mm) m = std::max(m, std::abs(r));
  return m;
}

SupportPlaneFit FitSupportPlaneTls(const std::vector<Eigen::Vector3d>& points) {
  FLATSCAN_CHECK(points.size() >= 3);
  const PlaneFit tls = FitPlaneTotalLeastSquares(points);
  return MakeFit(points, tls.normal, tls.centroid);
}

SupportPlaneFit FitSupportPlanePaper(const std::vector<Eigen::Vector3d>& points, Eigen::Vector3d* r_out) {
  FLATSCAN_CHECK(points.size() >= 3);
  Eigen::MatrixXd v(points.size(), 3);
  for (size_t i = 0; i < points.size(); ++i) v.row(i) = points[i].transpose();
  // r = (V^T V)^-1 V^T 1, by QR (the normal equations square the condition number).
  const Eigen::Vector3d r = v.colPivHouseholderQr().solve(Eigen::VectorXd::Ones(points.size()));
  if (r_out) *r_out = r;
  return MakeFit(points, r, Centroid(points));
}

Eigen::Vector3d TriangulateNormalized(const StereoRig& rig, const Eigen::Vector2d& x1, const Eigen::Vector2d& x2) {
  const Eigen::Matrix3d& rot = rig.cam2_from_cam1.rotation;
  const Eigen::Vector3d& t = rig.cam2_from_cam1.translation;
  Eigen::Matrix<double, 3, 4> p1 = Eigen::Matrix<double, 3, 4>::Zero(), p2;
  p1.leftCols<3>().setIdentity();
  p2 << rot, t;
  // Linear (DLT): x (P.row(2) X) - P.row(0) X = 0, y (P.row(2) X) - P.row(1) X = 0.
  Eigen::Matrix4d a;
  a.row(0) = x1.x() * p1.row(2) - p1.row(0);
  a.row(1) = x1.y() * p1.row(2) - p1.row(1);
  a.row(2) = x2.x() * p2.row(2) - p2.row(0);
  a.row(3) = x2.y() * p2.row(2) - p2.row(1);
  const Eigen::JacobiSVD<Eigen::Matrix4d> svd(a, Eigen::ComputeFullV);
  const Eigen::Vector4d h = svd.matrixV().col(3);
  Eigen::Vector3d x = h.head<3>() / h(3);
  // Gauss-Newton on the reprojection error in ideal pixels (normalized error x f).
  const double f1 = std::sqrt(rig.left.fx * rig.left.fy), f2 = std::sqrt(rig.right.fx * rig.right.fy);
  for (int iter = 0; iter < 20; ++iter) {
    Eigen::Matrix<double, 4, 3> jac;
    Eigen::Vector4d res;
    const Eigen::Vector3d c2 = rot * x + t;
    auto project = [](const Eigen::Vector3d& c, double f, Eigen::Matrix<double, 2, 3>* d) {
      const double iz = 1.0 / c.z();
      *d << f * iz, 0, -f * c.x() * iz * iz, 0, f * iz, -f * c.y() * iz * iz;
      return Eigen::Vector2d(f * c.x() * iz, f * c.y() * iz);
    };
    Eigen::Matrix<double, 2, 3> d1, d2;
    res.head<2>() = project(x, f1, &d1) - f1 * x1;
    res.tail<2>() = project(c2, f2, &d2) - f2 * x2;
    jac.topRows<2>() = d1;
    jac.bottomRows<2>() = d2 * rot;
    const Eigen::Vector3d step = (jac.transpose() * jac).ldlt().solve(-jac.transpose() * res);
    if (!step.allFinite()) break;
    x += step;
    if (step.norm() < 1e-13 * (1 + x.norm())) break;
  }
  return x;
}

double EpipolarDistancePx(const StereoRig& rig, const Eigen::Vector2d& x1, const Eigen::Vector2d& x2) {
  // E = [T]x R: x2^T E x1 = 0 for X2 = R X1 + T.
  const Eigen::Matrix3d e = Skew(rig.cam2_from_cam1.translation) * rig.cam2_from_cam1.rotation;
  const Eigen::Vector3d h1(x1.x(), x1.y(), 1), h2(x2.x(), x2.y(), 1);
  const Eigen::Vector3d l2 = e * h1, l1 = e.transpose() * h2;
  const double algebraic = std::abs(h2.dot(l2));
  const double d2 = algebraic / l2.head<2>().norm() * rig.right.fx;
  const double d1 = algebraic / l1.head<2>().norm() * rig.left.fx;
  return 0.5 * (d1 + d2);
}

PlaneCalibration CalibratePlane(const StereoRig& rig, const cv::Mat1b& left, const cv::Mat1b& right,
                                const PlaneCalibrationOptions& options) {
  const std::pair<const cv::Mat1b*, const Camera*> views[] = {{&left, &rig.left}, {&right, &rig.right}};
  const std::string* names[] = {&options.left_name, &options.right_name};
  for (int k = 0; k < 2; ++k) {
    const cv::Mat1b& image = *views[k].first;
    const Camera& camera = *views[k].second;
    if (image.cols != camera.width || image.rows != camera.height)
      ThrowInputError("{}: image is {}x{} px but the rig is calibrated for {}x{} px ({} camera)", *names[k],
                      image.cols, image.rows, camera.width, camera.height, k == 0 ? "left" : "right");
  }
  MarkerDetection l = DetectRingMarkers(left, rig.left, options.detection);
  MarkerDetection r = DetectRingMarkers(right, rig.right, options.detection);
  return CalibratePlaneFromDetections(rig, std::move(l), std::move(r), options);
}

PlaneCalibration CalibratePlaneFromDetections(const StereoRig& rig, MarkerDetection left, MarkerDetection right,
                                              const PlaneCalibrationOptions& options) {
  PlaneCalibration out;
  out.centre_correction = options.centre_correction;
  out.left = std::move(left);
  out.right = std::move(right);
  const MarkerDetection* detections[] = {&out.left, &out.right};
  const std::string* names[] = {&options.left_name, &options.right_name};
  for (int k = 0; k < 2; ++k) {
    const int found = static_cast<int>(detections[k]->markers.size());
    if (found < 3)
      ThrowInputError("{}: found {} concentric-ring marker{}, expected {} (at least 3 are needed to calibrate the "
                      "plane); {}",
                      *names[k], found, found == 1 ? "" : "s", options.expected_markers,
                      DescribeRejections(*detections[k]));
    if (found > options.expected_markers)
      out.warnings.push_back(fmt::format("{}: found {} ring markers, expected {}; the matching keeps the pairs "
                                         "that agree with the rig",
                                         *names[k], found, options.expected_markers));
  }

  // Centres used: normalized coordinates of the corrected or the naive centres.
  auto centre = [&](const RingMarker& m) {
    return options.centre_correction ? m.centre_undistorted : m.naive_centre_undistorted;
  };
  const std::vector<RingMarker>& lm = out.left.markers;
  const std::vector<RingMarker>& rm = out.right.markers;
  const int nl = static_cast<int>(lm.size()), nr = static_cast<int>(rm.size());
  std::vector<std::vector<double>> epipolar(nl, std::vector<double>(nr, 0.0));
  std::vector<std::vector<bool>> valid(nl, std::vector<bool>(nr, false));
  for (int i = 0; i < nl; ++i)
    for (int j = 0; j < nr; ++j) {
      const Eigen::Vector2d x1 = Normalized(rig.left, centre(lm[i])), x2 = Normalized(rig.right, centre(rm[j]));
      epipolar[i][j] = EpipolarDistancePx(rig, x1, x2);
      if (epipolar[i][j] > options.max_epipolar_px) continue;
      const Eigen::Vector3d p = TriangulateNormalized(rig, x1, x2);
      valid[i][j] = p.z() > 0 && (rig.cam2_from_cam1 * p).z() > 0;
    }

  // Largest cyclic-order-keeping matching, then smallest summed epipolar distance.
  std::vector<int> assignment(nl, -1), best;
  int best_size = 0;
  double best_cost = 0;
  std::vector<bool> used(nr, false);
  std::function<void(int, int, double)> search = [&](int i, int size, double cost) {
    if (i == nl) {
      std::vector<int> rights;
      for (int a : assignment)
        if (a >= 0) rights.push_back(a);
      if (!KeepsCyclicOrder(rights)) return;
      if (size > best_size || (size == best_size && size > 0 && cost < best_cost))
        best = assignment, best_size = size, best_cost = cost;
      return;
    }
    if (size + (nl - i) < best_size) return;  // cannot beat the best any more
    for (int j = 0; j < nr; ++j) {
      if (used[j] || !valid[i][j]) continue;
      used[j] = true;
      assignment[i] = j;
      search(i + 1, size + 1, cost + epipolar[i][j]);
      assignment[i] = -1;
      used[j] = false;
    }
    search(i + 1, size, cost);
  };
  search(0, 0, 0.0);
  if (best_size < 3) {
    std::string closest;
    for (int i = 0; i < nl; ++i) {
      double m = 1e300;
      for (int j = 0; j < nr; ++j) m = std::min(m, epipolar[i][j]);
      closest += fmt::format("{}{:.2f}", i ? ", " : "", m);
    }
    ThrowInputError("only {} of the markers ({} in {}, {} in {}) could be matched between the images (at least 3 "
                    "are needed): smallest epipolar distances of the left markers {} px, allowed {} px; is the rig "
                    "file the one of these cameras?",
                    best_size, nl, options.left_name, nr, options.right_name, closest, options.max_epipolar_px);
  }

  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < nl; ++i) {
    if (best[i] < 0) continue;
    const RingMarker& a = lm[i];
    const RingMarker& b = rm[best[i]];
    MatchedMarker m;
    m.left = i;
    m.right = best[i];
    m.left_centre_px = options.centre_correction ? a.centre_px : a.naive_centre_px;
    m.right_centre_px = options.centre_correction ? b.centre_px : b.naive_centre_px;
    m.left_shift_px = a.CentreShiftPx();
    m.right_shift_px = b.CentreShiftPx();
    m.epipolar_px = epipolar[i][best[i]];
    const Eigen::Vector2d x1 = Normalized(rig.left, centre(a)), x2 = Normalized(rig.right, centre(b));
    m.position = TriangulateNormalized(rig, x1, x2);
    const Eigen::Vector3d c2 = rig.cam2_from_cam1 * m.position;
    const double e1 = (m.position.head<2>() / m.position.z() - x1).norm() * rig.left.fx;
    const double e2 = (c2.head<2>() / c2.z() - x2).norm() * rig.right.fx;
    m.reprojection_px = std::max(e1, e2);
    points.push_back(m.position);
    out.matched.push_back(m);
  }
  if (best_size < options.expected_markers)
    out.warnings.push_back(fmt::format("only {} of {} markers matched between the images: the plane is fitted to {} "
                                       "points{}",
                                       best_size, options.expected_markers, best_size,
                                       best_size == 3 ? " and passes exactly through them (no residual check)" : ""));

  // The plane must be defined: the markers may not be (nearly) collinear.
  {
    const Eigen::Vector3d centroid = Centroid(points);
    Eigen::MatrixXd centred(points.size(), 3);
    for (size_t i = 0; i < points.size(); ++i) centred.row(i) = (points[i] - centroid).transpose();
    const Eigen::Vector3d s = Eigen::JacobiSVD<Eigen::MatrixXd>(centred).singularValues();
    if (s(1) < 1e-3 * s(0))
      ThrowInputError("the {} matched markers are collinear: they do not define a plane", points.size());
  }
  out.tls = FitSupportPlaneTls(points);
  out.paper = FitSupportPlanePaper(points, &out.paper_r);
  out.normals_angle_deg = std::acos(std::clamp(out.tls.normal.dot(out.paper.normal), -1.0, 1.0)) * kRadToDeg;
  // Both cameras must look at the plane's side the normal points to.
  const Eigen::Vector3d camera2 = rig.cam2_from_cam1.Inverse().translation;
  if (out.tls.normal.dot(camera2 - out.tls.point) <= 0)
    out.warnings.push_back("the two cameras are on different sides of the fitted plane: check the rig file");
  for (size_t k = 0; k < out.matched.size(); ++k) out.matched[k].residual_mm = out.tls.residuals_mm[k];

  out.plane.normal = out.tls.normal;
  out.plane.point = out.tls.point;
  out.plane.markers = points;
  out.plane.residuals_mm = out.tls.residuals_mm;
  return out;
}

namespace {

nlohmann::json Json(const Eigen::Vector2d& v) { return {v.x(), v.y()}; }
nlohmann::json Json(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

nlohmann::json FitJson(const SupportPlaneFit& fit) {
  return {{"normal", Json(fit.normal)}, {"point", Json(fit.point)}, {"residuals_mm", fit.residuals_mm}, {"rms_mm", fit.RmsMm()}};
}

nlohmann::json MarkerSideJson(const RingMarker& m, int index) {
  return {{"index", index},
          {"centre_px", Json(m.centre_px)},
          {"naive_centre_px", Json(m.naive_centre_px)},
          {"centre_shift_px", m.CentreShiftPx()},
          {"outer_axes_px", {m.outer.ellipse.a, m.outer.ellipse.b}},
          {"inner_axes_px", {m.inner.ellipse.a, m.inner.ellipse.b}},
          {"outer_fit_rms_px", m.outer.rms_px},
          {"inner_fit_rms_px", m.inner.rms_px},
          {"radius_ratio", m.radius_ratio}};
}

nlohmann::json RejectedJson(const MarkerDetection& d) {
  nlohmann::json out = nlohmann::json::array();
  for (const RejectedContour& r : d.rejected) out.push_back({{"at_px", Json(r.centroid_px)}, {"reason", r.reason}});
  return out;
}

}  // namespace

nlohmann::json PlaneCalibration::ToJson() const {
  nlohmann::json markers = nlohmann::json::array();
  for (const MatchedMarker& m : matched) {
    markers.push_back({{"position_mm", Json(m.position)},
                       {"residual_mm", m.residual_mm},
                       {"epipolar_px", m.epipolar_px},
                       {"reprojection_px", m.reprojection_px},
                       {"left", MarkerSideJson(left.markers[m.left], m.left)},
                       {"right", MarkerSideJson(right.markers[m.right], m.right)}});
  }
  nlohmann::json paper_json = FitJson(paper);
  paper_json["r"] = Json(paper_r);
  return {
      {"normal", Json(plane.normal)},
      {"point", Json(plane.point)},
      {"residuals_mm", plane.residuals_mm},
      {"markers_found", {{"left", left.markers.size()}, {"right", right.markers.size()}}},
      {"markers_matched", matched.size()},
      {"centre_correction", centre_correction},
      {"plane_fit", "tls"},
      {"tls_fit", FitJson(tls)},
      {"paper_fit", paper_json},
      {"normals_angle_deg", normals_angle_deg},
      {"markers", markers},
      {"rejected_outlines", {{"left", RejectedJson(left)}, {"right", RejectedJson(right)}}},
      {"warnings", warnings},
      {"frame", "camera 1 (left), mm; pixels: raw image coordinates, pixel centres at integers"},
  };
}

}  // namespace flatscan
