#include "flatscan/evaluation/calibration_share.h"

#include <cmath>

#include <fmt/format.h>

#include "flatscan/support_plane/plane_calibration.h"

namespace flatscan {
namespace {

// The point seen at (left_raw, right_raw) triangulated with `rig`.
Eigen::Vector3d Triangulate(const StereoRig& rig, const Eigen::Vector2d& left_raw, const Eigen::Vector2d& right_raw) {
  return TriangulateNormalized(rig, rig.left.PixelToNormalized(left_raw), rig.right.PixelToNormalized(right_raw));
}

// The grid above (camera-1 frame, true heights 0.1 mm).
std::vector<Eigen::Vector3d> PartPlaceGrid(const Station& truth) {
  const double half = truth.scene.part.width_mm.hi / 2;
  std::vector<Eigen::Vector3d> grid;
  for (int i = 0; i < 5; ++i)
    for (int j = 0; j < 5; ++j)
      grid.push_back(truth.cam1_from_support * Eigen::Vector3d(-half + i * half / 2, -half + j * half / 2, 0.1));
  return grid;
}

double Rms(double sum_squares, size_t n) { return n > 0 ? std::sqrt(sum_squares / n) : 0.0; }

}  // namespace

CalibrationShare MeasureCalibrationShare(const CalibratedStation& station, uint64_t seed,
                                         const UncertaintyOptions& options) {
  const StereoRig& truth = station.truth.rig;
  const StereoRig& rig = station.rig();
  // The plane from the station's own marker detections, triangulated with the true rig
  // (a station without detections, such as TrueCalibratedStation's: its plane's markers).
  std::vector<Eigen::Vector3d> seen_markers;
  for (const MatchedMarker& m : station.plane_report.matched)
    seen_markers.push_back(Triangulate(truth, m.left_centre_px, m.right_centre_px));
  if (seen_markers.size() < 3) seen_markers = station.plane().markers;
  const SupportPlaneFit plane_from_markers = FitSupportPlaneTls(seen_markers);

  CalibrationShare out;
  out.seed = seed;
  const std::vector<Eigen::Vector3d> grid = PartPlaceGrid(station.truth);
  for (const Eigen::Vector3d& p : grid) {
    const double h_true = station.truth.plane.Height(p);
    const double plane_error = plane_from_markers.normal.dot(p - plane_from_markers.point) - h_true;
    const Eigen::Vector2d l = truth.left.Project(p), r = truth.right.Project(truth.cam2_from_cam1 * p);
    const double rig_error = HeightAboveOwnPlane(rig, truth, station.truth.plane.markers, l, r) - h_true;
    const double u_plane = PlaneHeightSd(rig, station.plane(), p, options);
    const double u_rig = RigHeightSd(rig, station.plane(), l, r);
    out.plane_error_mm += plane_error * plane_error, out.plane_sd_mm += u_plane * u_plane;
    out.rig_error_mm += rig_error * rig_error, out.rig_sd_mm += u_rig * u_rig;
  }
  for (double* v : {&out.plane_error_mm, &out.plane_sd_mm, &out.rig_error_mm, &out.rig_sd_mm})
    *v = Rms(*v, grid.size());
  return out;
}

namespace {

// Root mean square over the stations of error / estimate (1 for an honest estimate).
double RatioRms(const std::vector<CalibrationShare>& stations, bool plane) {
  double sum = 0;
  size_t n = 0;
  for (const CalibrationShare& s : stations) {
    const double error = plane ? s.plane_error_mm : s.rig_error_mm, sd = plane ? s.plane_sd_mm : s.rig_sd_mm;
    if (sd > 0) sum += (error / sd) * (error / sd), ++n;
  }
  return Rms(sum, n);
}

}  // namespace

std::string CalibrationShareMarkdown(const std::vector<CalibrationShare>& stations) {
  std::string md = "### The calibration's share, measured\n\n";
  md += "Each station's calibration against the truth at a 5 x 5 grid 0.1 mm above the plane over the parts' place "
        "(root mean square over the grid): the plane from the station's marker detections triangulated with the true "
        "rig, and the calibrated rig with the plane it gives from the true markers, each beside its own estimate "
        "(u_plane, u_rig). An honest estimate gives a root mean square of error / estimate of about 1 over many "
        "stations.\n\n";
  md += "| station | plane error (um) | u_plane (um) | rig error (um) | u_rig (um) |\n|---|---|---|---|---|\n";
  for (const CalibrationShare& s : stations)
    md += fmt::format("| seed {} | {:.3f} | {:.3f} | {:.3f} | {:.3f} |\n", s.seed, 1000 * s.plane_error_mm,
                      1000 * s.plane_sd_mm, 1000 * s.rig_error_mm, 1000 * s.rig_sd_mm);
  md += fmt::format("\nRoot mean square of error / estimate over {} stations: plane {:.2f}, rig {:.2f}.\n",
                    stations.size(), RatioRms(stations, true), RatioRms(stations, false));
  return md;
}

nlohmann::json CalibrationShareJson(const std::vector<CalibrationShare>& stations) {
  nlohmann::json rows = nlohmann::json::array();
  for (const CalibrationShare& s : stations)
    rows.push_back({{"seed", s.seed},
                    {"plane_error_mm", s.plane_error_mm},
                    {"plane_sd_mm", s.plane_sd_mm},
                    {"rig_error_mm", s.rig_error_mm},
                    {"rig_sd_mm", s.rig_sd_mm}});
  return {{"stations", rows},
          {"plane_ratio_rms", RatioRms(stations, true)},
          {"rig_ratio_rms", RatioRms(stations, false)}};
}

}  // namespace flatscan
