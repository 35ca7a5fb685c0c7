#include "flatscan/evaluation/structured_light_peer.h"

#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "flatscan/simulation/scene_config.h"
#include "flatscan/util/statistics.h"

namespace flatscan {
namespace {

// An 8 x 6 mm sheet, 0.2 mm thick, with the given warp, resting on the support.
PartGeometry Sheet(const Warp& warp) {
  PartGeometry g;
  g.half_width = 4;
  g.half_height = 3;
  g.warp = warp;
  return g;
}

struct Shot {
  StructuredLightRig rig;
  PartTruth truth;
  ProjectorView view;
  StructuredLightPatterns captured;
};

Shot Capture(const PartGeometry& geometry, const SurfaceFinish& finish, double rotation_deg = 20) {
  StructuredLightSpec spec;  // a 720 x 576 px region (12.7 x 10.1 mm) keeps the tests short
  spec.roi_width = 720;
  spec.roi_height = 580;     // cut to 576 (2^6 3^2), a size cv::dft takes whole
  spec.finish = finish;
  Shot s{BuildStructuredLightRig(BuildStation(ScenePreset("paper")), spec), RestAndPlacePart(geometry, rotation_deg, {0.5, -0.3}),
         {}, {}};
  s.view = TraceProjectorView(s.rig, geometry, s.truth.support_from_part);
  s.captured = CapturePatterns(s.rig, s.view, MakeStructuredLightPatterns(spec), 7);
  return s;
}

TEST(StructuredLightPeer, DecodesTheProjectorColumnToAFewHundredthsOfAPixelAwayFromThePartsEdge) {
  const Shot s = Capture(Sheet({0.05, 0.02, 0.03}), SurfaceFinish::Matte());
  const cv::Mat1f columns = DecodeProjectorColumns(s.rig.spec, s.captured, PhaseMethod::kPerPixel);
  cv::Mat1b inside;  // 12 px inside the part's outline, as the peer measures
  cv::erode(s.view.on_part, inside, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(25, 25)));
  std::vector<double> errors;
  int lit = 0;
  for (int v = 0; v < columns.rows; v += 3)
    for (int u = 0; u < columns.cols; u += 3) {
      if (!inside(v, u)) continue;
      ++lit;
      if (std::isfinite(columns(v, u))) errors.push_back(std::abs(columns(v, u) - s.view.projector_px(v, u)[0]));
    }
  ASSERT_GT(lit, 10000);
  EXPECT_EQ(errors.size(), static_cast<size_t>(lit));
  EXPECT_LT(Median(errors), 0.05);  // projector pixels (16 a period)
  EXPECT_LT(*std::max_element(errors.begin(), errors.end()), 0.5);  // no period slips
}

TEST(StructuredLightPeer, MeasuresTheTopItSeesWithinFiveMicrometresButMissesTheRimsExtremes) {
  const PartGeometry part = WithFlatness(Sheet({0.1, 0.05, 0.05}), 0.3);
  const Shot s = Capture(part, SurfaceFinish::Matte());
  const StructuredLightMeasurement m = MeasureStructuredLight(s.rig, s.captured, part.SideHeight(), PhaseMethod::kPerPixel);
  ASSERT_TRUE(m.measured) << m.error;
  EXPECT_GT(m.cells, 1500);
  const FlatnessValues seen = TrueValuesOverCells(s.view, m.cell_rects, part.SideHeight());
  EXPECT_NEAR(m.values.flatness_mm, seen.flatness_mm, 0.005);
  EXPECT_NEAR(m.values.lsq_pv_mm, seen.lsq_pv_mm, 0.005);
  EXPECT_NEAR(m.values.minzone_mm, seen.minzone_mm, 0.005);
  // The rim's highest corner lies in the edge band the peer drops: it reads low.
  EXPECT_LT(m.values.flatness_mm, s.truth.flatness_mm - 0.010);
}

TEST(StructuredLightPeer, SeesTheRaisedCentreOfADomeThatTheRimMisses) {
  // Edges bent down by 0.1 mm: the part rests on its corners, whose rim is flat within
  // about a bend, while the centre stands about two bends above them.
  const PartGeometry dome = Sheet({-0.1, -0.1, 0});
  const Shot s = Capture(dome, SurfaceFinish::Matte(), 0);
  const StructuredLightMeasurement m = MeasureStructuredLight(s.rig, s.captured, dome.SideHeight(), PhaseMethod::kPerPixel);
  ASSERT_TRUE(m.measured) << m.error;
  const double centre_height = (s.truth.support_from_part * Eigen::Vector3d(0, 0, dome.WarpZ({0, 0}))).z();
  EXPECT_LT(s.truth.flatness_mm, 0.6 * centre_height);
  EXPECT_NEAR(m.values.flatness_mm, centre_height, 0.010);
}

// 99th percentile of |measured - true| height over the 8 x 8 px cells of `m`.
double CellHeightErrorP99(const Shot& s, const StructuredLightMeasurement& m, PhaseMethod method) {
  const cv::Mat3f points = TriangulateColumns(s.rig, DecodeProjectorColumns(s.rig.spec, s.captured, method));
  std::vector<double> errors;
  for (const cv::Rect& cell : m.cell_rects) errors.push_back(std::abs(cv::mean(points(cell))[2] - cv::mean(s.view.point(cell))[2]));
  std::sort(errors.begin(), errors.end());
  return errors[errors.size() * 99 / 100];
}

// OpenCV's PSP band-passes each image with a fixed 42 x 42-bin window around the fringe
// frequency: the part's edge rings through it across the part (5.2 um at the 99th
// percentile of the cells here, in a 720 x 576 px image; about 10 um in the 1280 x 1024 px
// image of evaluate), where the per-pixel formula is off by 0.8 um.
TEST(StructuredLightPeer, OpenCvsFilteredPhaseRipplesWhereThePerPixelPhaseDoesNot) {
  const PartGeometry part = Sheet({0.05, 0.02, 0.03});
  const Shot s = Capture(part, SurfaceFinish::Matte());
  const StructuredLightMeasurement m = MeasureStructuredLight(s.rig, s.captured, part.SideHeight(), PhaseMethod::kPerPixel);
  ASSERT_TRUE(m.measured) << m.error;
  const double opencv = CellHeightErrorP99(s, m, PhaseMethod::kOpenCvPsp);
  const double per_pixel = CellHeightErrorP99(s, m, PhaseMethod::kPerPixel);
  EXPECT_LT(per_pixel, 0.0025);
  EXPECT_GT(opencv, 3 * per_pixel);
}

TEST(StructuredLightPeer, RefusesAPartItCannotSee) {
  PartGeometry tiny = Sheet({});
  tiny.half_width = tiny.half_height = 0.1;
  tiny.corner_radius = 0.05;
  const Shot s = Capture(tiny, SurfaceFinish::Matte());
  const StructuredLightMeasurement m = MeasureStructuredLight(s.rig, s.captured, tiny.SideHeight());
  EXPECT_FALSE(m.measured);
  EXPECT_EQ(m.error, "structured light: 0 cells of 8x8 px on the part's top, expected at least 10");
}

}  // namespace
}  // namespace flatscan
