#include "flatscan/simulation/part_model.h"

#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

#include "flatscan/util/random.h"

namespace flatscan {
namespace {

PartGeometry SharpRectangle() {
  PartGeometry g;
  g.half_width = 8.0;
  g.half_height = 6.0;
  g.corner_radius = 0.0;
  g.thickness = 0.2;
  return g;
}

void ExpectThreeContactsOnPlane(const PartGeometry& g, const PartTruth& truth) {
  const std::vector<Eigen::Vector3d> bottom = g.SampleBottomSurface(0.1);
  for (int i : truth.contacts) EXPECT_NEAR((truth.support_from_part * bottom[i]).z(), 0.0, 1e-9);
  EXPECT_NE(truth.contacts[0], truth.contacts[1]);
  EXPECT_NE(truth.contacts[1], truth.contacts[2]);
  EXPECT_NE(truth.contacts[0], truth.contacts[2]);
  for (const Eigen::Vector3d& p : bottom) EXPECT_GE((truth.support_from_part * p).z(), -1e-9);
}

TEST(PartModel, PureTwistFlatnessMatchesAnalyticValue) {
  // w = tw X Y: corners at -tw, -tw, +tw, +tw. It rests on both low corners and one
  // high corner, plane z = tw (X + Y - 1) in normalized coordinates; the fourth corner
  // is 4 tw above it vertically, 4 tw / sqrt(1 + (tw/a)^2 + (tw/b)^2) along the normal.
  for (double tw : {0.05, 0.12, -0.2}) {
    PartGeometry g = SharpRectangle();
    g.warp.twist = tw;
    const PartTruth truth = RestAndPlacePart(g, 30.0, Eigen::Vector2d(1.0, 2.0));
    const double a = g.half_width, b = g.half_height;
    const double analytic = 4 * std::abs(tw) / std::sqrt(1 + tw * tw / (a * a) + tw * tw / (b * b));
    EXPECT_NEAR(truth.flatness_mm, analytic, 1e-4) << "twist " << tw;
    ExpectThreeContactsOnPlane(g, truth);
  }
}

TEST(PartModel, PureBendingFlatnessMatchesAnalyticValue) {
  // Dome bent along x (ends down): rests on its two short edges, the middle of the
  // long edges is |bend| above the plane.
  PartGeometry g = SharpRectangle();
  g.warp.bend_x = -0.15;
  PartTruth truth = RestAndPlacePart(g, -40.0, Eigen::Vector2d(-2.0, 0.5));
  EXPECT_NEAR(truth.flatness_mm, 0.15, 1e-4);
  ExpectThreeContactsOnPlane(g, truth);
  // Bent along both axes (ends down): rests on the four corners, the edge midpoints
  // of the long sides are |bend_y| above them... and of the short sides |bend_x|.
  g.warp.bend_y = -0.09;
  truth = RestAndPlacePart(g, 0.0, Eigen::Vector2d::Zero());
  EXPECT_NEAR(truth.flatness_mm, 0.15, 1e-4);
  ExpectThreeContactsOnPlane(g, truth);
}

TEST(PartModel, FlatSheetRestsFlatWithWallsOnTheirRim) {
  PartGeometry g = SharpRectangle();
  g.corner_radius = 1.0;
  g.wall_height = 1.5;
  const PartTruth truth = RestAndPlacePart(g, 10.0, Eigen::Vector2d::Zero());
  EXPECT_NEAR(truth.flatness_mm, 0.0, 1e-9);
  EXPECT_NEAR(truth.lsq_pv_mm, 0.0, 1e-9);
  EXPECT_NEAR(truth.minzone_mm, 0.0, 1e-9);
  for (const Eigen::Vector3d& p : truth.rim) EXPECT_NEAR(p.z(), 0.0, 1e-9);
}

// A dome bent along x: its sheet slopes by 2 |bend| / a = 0.125 at the short edges.
PartGeometry Dome(SideFaceModel faces) {
  PartGeometry g = SharpRectangle();
  g.thickness = 0.3;
  g.warp.bend_x = -0.5;
  g.side_faces = faces;
  return g;
}

TEST(PartModel, SideFacesStandPerpendicularToTheLocalSheet) {
  const PartGeometry local = Dome(SideFaceModel::kLocalNormal), centre = Dome(SideFaceModel::kCentreNormal);
  const Eigen::Vector2d edge(local.half_width, 1.0);
  const Eigen::Vector2d g = local.WarpGradient(edge);
  ASSERT_NEAR(g.x(), -0.125, 1e-12);
  // Local: the bottom surface's unit normal; centre: the part's z axis.
  EXPECT_LT((local.FaceDirection(edge) - Eigen::Vector3d(-g.x(), -g.y(), 1).normalized()).norm(), 1e-15);
  EXPECT_EQ(centre.FaceDirection(edge), Eigen::Vector3d::UnitZ());
  // Sheet coordinates invert SheetPoint to 1e-11 mm, inside the sheet and on its walls.
  for (const PartGeometry* part : {&local, &centre})
    for (const double s : {0.0, 0.1, 0.3, -0.2})
      for (const Eigen::Vector2d& q : {edge, Eigen::Vector2d(-3.0, 2.5), Eigen::Vector2d(0, 0)}) {
        double s_back = 0;
        const Eigen::Vector2d q_back = part->SheetCoordinates(part->SheetPoint(q, s), &s_back);
        EXPECT_LT((q_back - q).norm(), 1e-11) << q.transpose() << " s " << s;
        EXPECT_NEAR(s_back, s, 1e-11);
      }
  // Where the dome falls away, the local face's top edge leans out by t g = 0.0375 mm: a
  // vertical ray 0.015 mm outside the bottom edge meets the local face and misses the
  // centre model's vertical face.
  const Rigid3d identity;
  const Ray down{Eigen::Vector3d(edge.x() + 0.015, edge.y(), 5.0), Eigen::Vector3d(0, 0, -1)};
  EXPECT_LT(PartOccluder(local, identity).RaySignedDistance(down), 0);
  EXPECT_GT(PartOccluder(centre, identity).RaySignedDistance(down), 0);
  // The truth is the bottom rim: the same for both models without walls.
  EXPECT_EQ(RestAndPlacePart(local, 20.0, {0, 0}).flatness_mm, RestAndPlacePart(centre, 20.0, {0, 0}).flatness_mm);
  // With walls the rim is the walls' lower edge, H along -S from the sheet's bottom.
  PartGeometry walled = local;
  walled.wall_height = 1.0;
  EXPECT_LT((walled.RimPoint(edge) - (walled.SheetPoint(edge, 0) - 1.0 * walled.FaceDirection(edge))).norm(), 1e-15);
}

TEST(PartModel, SignedDistancesOfOutlineHolesAndNotches) {
  PartGeometry g = SharpRectangle();
  g.corner_radius = 2.0;
  g.holes.push_back({Eigen::Vector2d(2.0, 1.0), 1.0});
  g.notches.push_back({Eigen::Vector2d(8.0, 0.0), Eigen::Vector2d(0.6, 1.0)});
  EXPECT_NEAR(g.FootprintSdf({0.0, 0.0}), -std::min(6.0, (Eigen::Vector2d(2, 1).norm() - 1.0)), 1e-12);
  EXPECT_NEAR(g.FootprintSdf({2.0, 1.0}), 1.0, 1e-12);        // hole centre
  EXPECT_NEAR(g.FootprintSdf({8.0, 0.0}), 0.6, 1e-12);        // notch
  EXPECT_NEAR(g.OuterSdf({7.0, 0.0}), -0.4, 1e-12);  // 1 mm from the edge, 0.4 mm from the notch
  EXPECT_NEAR(g.OuterSdf({8.0 + std::sqrt(2.0), 6.0 + std::sqrt(2.0)}), std::hypot(2 + std::sqrt(2.0), 2 + std::sqrt(2.0)) - 2.0, 1e-12);
  for (const Eigen::Vector2d& p : g.SampleOuterOutline(0.1)) EXPECT_NEAR(g.OuterSdf(p), 0.0, 1e-9);
}

// A burr in the sheet's plane is part of the outline (its arc is sampled, the rim runs
// round it); a burr under the rim is what the part rests on: a flat sheet on a 50 um burr
// at the middle of one short edge stands on it and the opposite edge, so that edge's rim
// is 50 um up and the flatness is 50 um (what a feeler gauge would find).
TEST(PartModel, BurrsStandOutOfTheOutlineOrUnderTheRim) {
  PartGeometry g = SharpRectangle();
  g.burrs.push_back({Eigen::Vector2d(2.0, 6.0), 0.04, false});
  EXPECT_NEAR(g.OuterSdf({2.0, 6.04}), 0.0, 1e-12);
  EXPECT_NEAR(g.OuterSdf({2.0, 6.05}), 0.01, 1e-12);
  double top = 0;
  int on_burr = 0;
  for (const Eigen::Vector2d& p : g.SampleOuterOutline(0.1)) {
    EXPECT_NEAR(g.OuterSdf(p), 0.0, 1e-9);
    top = std::max(top, p.y());
    on_burr += p.y() > 6.0 + 1e-9;
  }
  EXPECT_NEAR(top, 6.04, 1e-3);
  EXPECT_GE(on_burr, 5);  // the half arc, half the burr's size apart
  // ... in the outline's order: consecutive points at most the spacing apart.
  const std::vector<Eigen::Vector2d> outline = g.SampleOuterOutline(0.1);
  for (size_t i = 0; i < outline.size(); ++i)
    EXPECT_LT((outline[(i + 1) % outline.size()] - outline[i]).norm(), 0.1 + 1e-9) << i;
  // A burr between two samples (spacing 0.5 mm: x = 2.5 and 2.0) is still on the outline.
  PartGeometry between = g;
  between.burrs[0].centre.x() = 2.25;
  int far_out = 0;
  for (const Eigen::Vector2d& p : between.SampleOuterOutline(0.5)) far_out += p.y() > 6.0 + 1e-9;
  EXPECT_GE(far_out, 5);
  EXPECT_NEAR(RestAndPlacePart(g, 0.0, {0, 0}).flatness_mm, 0.0, 1e-9);  // flat: the arc is at rim level

  g.burrs.push_back({Eigen::Vector2d(8.0, 0.0), 0.05, true});
  const PartTruth truth = RestAndPlacePart(g, 0.0, {0, 0});
  ExpectThreeContactsOnPlane(g, truth);
  EXPECT_NEAR(truth.flatness_mm, 0.05, 1e-4);
  EXPECT_NEAR(truth.rim.front().z(), 0.05, 1e-4);  // the rim over the burr (x = 8)
}

TEST(PartModel, WithBurrsDrawsThemOnTheOutlineWithinTheirRange) {
  PartSpec spec;
  spec.burrs = {4, 4};
  spec.burr_size_um = {20, 50};
  spec.burr_under_rim_fraction = 0.5;
  const PartGeometry plain = SharpRectangle();
  const PartGeometry g = WithBurrs(plain, spec, 9);
  ASSERT_EQ(g.burrs.size(), 4u);
  int under = 0;
  for (const Burr& b : g.burrs) {
    EXPECT_NEAR(plain.OuterSdf(b.centre), 0.0, 1e-9);
    EXPECT_GE(b.size_mm, 0.020);
    EXPECT_LE(b.size_mm, 0.050);
    under += b.under_rim;
  }
  EXPECT_EQ(under, 2);
  EXPECT_EQ(WithBurrs(plain, spec, 9).burrs[3].centre, g.burrs[3].centre);
  EXPECT_TRUE(WithBurrs(plain, PartSpec{}, 9).burrs.empty());  // the default: none
}

// A flat sheet with a plane wave of amplitude A rests on its troughs; its rim crosses
// several wavelengths, so the rim's crests stand 2 A above the support.
TEST(PartModel, WavinessIsAPlaneWaveAcrossTheSheet) {
  PartSpec spec;
  spec.waviness_um = {5, 5};
  spec.waviness_wavelength_mm = {2, 2};
  const PartGeometry plain = SharpRectangle();
  const PartGeometry wavy = WithWaviness(plain, spec, 4);
  EXPECT_DOUBLE_EQ(wavy.warp.wave_mm, 0.005);
  EXPECT_DOUBLE_EQ(wavy.warp.wave_length_mm, 2.0);
  const Warp& w = wavy.warp;
  const Eigen::Vector2d k = 2 * M_PI / 2.0 * Eigen::Vector2d(std::cos(w.wave_direction_rad), std::sin(w.wave_direction_rad));
  for (const Eigen::Vector2d& p : {Eigen::Vector2d(0.3, -1.1), Eigen::Vector2d(5.0, 4.2)}) {
    EXPECT_NEAR(wavy.WarpZ(p), 0.005 * std::sin(k.dot(p) + w.wave_phase_rad), 1e-15);
    const double h = 1e-5;
    const Eigen::Vector2d numeric((wavy.WarpZ(p + Eigen::Vector2d(h, 0)) - wavy.WarpZ(p - Eigen::Vector2d(h, 0))) / (2 * h),
                                  (wavy.WarpZ(p + Eigen::Vector2d(0, h)) - wavy.WarpZ(p - Eigen::Vector2d(0, h))) / (2 * h));
    EXPECT_NEAR((wavy.WarpGradient(p) - numeric).norm(), 0.0, 1e-9);
  }
  EXPECT_NEAR(RestAndPlacePart(wavy, 20.0, Eigen::Vector2d::Zero()).flatness_mm, 0.010, 2e-4);
  // Drawn from its own seed only, and none by default; the smooth warp is untouched.
  EXPECT_EQ(WithWaviness(plain, spec, 4).warp.wave_phase_rad, w.wave_phase_rad);
  EXPECT_NE(WithWaviness(plain, spec, 5).warp.wave_phase_rad, w.wave_phase_rad);
  EXPECT_EQ(WithWaviness(plain, PartSpec{}, 4).warp.wave_mm, 0.0);
  // WithFlatness scales the smooth warp and keeps the waviness as drawn.
  PartGeometry bent = wavy;
  bent.warp.bend_x = 0.05;
  const PartGeometry scaled = WithFlatness(bent, 0.1);
  EXPECT_EQ(scaled.warp.wave_mm, 0.005);
  EXPECT_NEAR(RestAndPlacePart(scaled, 0.0, Eigen::Vector2d::Zero()).flatness_mm, 0.1, 1e-7);
}

TEST(PartModel, CenterOfMassOfSymmetricSheetIsAtMidThickness) {
  PartGeometry g = SharpRectangle();
  const Eigen::Vector3d com = g.CenterOfMass();
  EXPECT_NEAR(com.x(), 0.0, 1e-9);
  EXPECT_NEAR(com.y(), 0.0, 1e-9);
  EXPECT_NEAR(com.z(), g.thickness / 2, 1e-9);
}

TEST(PartModel, WithFlatnessHitsTheTargetAndKeepsTheShape) {
  Random rng(7);
  PartSpec spec;
  for (int i = 0; i < 4; ++i) {
    const PartGeometry g = SamplePartGeometry(spec, rng);
    for (double target : {0.02, 0.1, 0.323}) {
      const PartGeometry scaled = WithFlatness(g, target);
      EXPECT_NEAR(RestAndPlacePart(scaled, 30.0, Eigen::Vector2d(1, 2)).flatness_mm, target, 1e-7);
      EXPECT_EQ(scaled.half_width, g.half_width);
      // Only the warp's scale changes: its coefficients stay proportional.
      EXPECT_NEAR(scaled.warp.twist * g.warp.bend_x, scaled.warp.bend_x * g.warp.twist, 1e-12);
    }
  }
  PartGeometry flat = SharpRectangle();
  EXPECT_NEAR(RestAndPlacePart(WithFlatness(flat, 0.05), 0.0, Eigen::Vector2d::Zero()).flatness_mm, 0.05, 1e-7);
}

TEST(PartModel, FlatnessRangeOfTheSceneScalesTheDrawnWarp) {
  PartSpec spec;
  spec.flatness_mm = {0.05, 0.06};
  Random rng(11);
  for (int i = 0; i < 5; ++i) {
    const double f = RestAndPlacePart(SamplePartGeometry(spec, rng), 0.0, Eigen::Vector2d::Zero()).flatness_mm;
    EXPECT_GE(f, 0.05 - 1e-7);
    EXPECT_LE(f, 0.06 + 1e-7);
  }
}

}  // namespace
}  // namespace flatscan
