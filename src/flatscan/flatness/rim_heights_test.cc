#include "flatscan/flatness/rim_heights.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>

#include "flatscan/util/random.h"

namespace flatscan {
namespace {

// Support plane 200 mm in front of camera 1, normal toward it: a point (x, y) of the
// plane at height h is (x, y, 200 - h) in the camera-1 frame.
SupportPlane Plane() {
  SupportPlane plane;
  plane.normal = Eigen::Vector3d(0, 0, -1);
  plane.point = Eigen::Vector3d(0, 0, 200);
  return plane;
}

// A rounded rectangle (half sizes 8 x 5 mm, corner radius 1 mm) walked once round,
// `step` mm apart.
std::vector<Eigen::Vector2d> Outline(double step) {
  std::vector<Eigen::Vector2d> out;
  const double a = 8, b = 5, r = 1;
  const double straight_x = 2 * (a - r), straight_y = 2 * (b - r), arc = M_PI / 2 * r;
  const double length = 2 * (straight_x + straight_y) + 4 * arc;
  for (double s = 0; s < length; s += step) {
    double t = s;
    // Sides and corners counter-clockwise from (a, -(b - r)).
    const double legs[8] = {straight_y, arc, straight_x, arc, straight_y, arc, straight_x, arc};
    int k = 0;
    while (t > legs[k]) t -= legs[k++];
    const Eigen::Vector2d corners[4] = {{a - r, b - r}, {-(a - r), b - r}, {-(a - r), -(b - r)}, {a - r, -(b - r)}};
    switch (k) {
      case 0: out.emplace_back(a, -(b - r) + t); break;
      case 2: out.emplace_back(a - r - t, b); break;
      case 4: out.emplace_back(-a, b - r - t); break;
      case 6: out.emplace_back(-(a - r) + t, -b); break;
      default: {
        const double angle = (k - 1) / 2 * M_PI / 2 + t / r;
        out.push_back(corners[(k - 1) / 2] + r * Eigen::Vector2d(std::cos(angle), std::sin(angle)));
      }
    }
  }
  return out;
}

// A warp of the kind docs/design.md section 5 simulates: bending, twist, low-order terms
// (mm), resting on the plane.
double Warp(const Eigen::Vector2d& p) {
  const double x = p.x() / 8, y = p.y() / 5;
  return 0.05 + 0.04 * x * x - 0.03 * y * y + 0.05 * x * y + 0.01 * x * x * x - 0.008 * x * y * y;
}

// Noisy rim samples of `height`; also returns the true largest height.
template <typename F>
HeightSamples Sample(F height, double noise_mm, uint64_t seed, double* true_max) {
  Random rng(seed);
  HeightSamples rim;
  *true_max = -1e9;
  for (const Eigen::Vector2d& p : Outline(0.02)) {
    const double h = height(p);
    *true_max = std::max(*true_max, h);
    rim.Add(Eigen::Vector3d(p.x(), p.y(), 200 - h - rng.Normal(0, noise_mm)), h, 1.0);
    rim.heights.back() = 200 - rim.points.back().z();
  }
  return rim;
}

double Max(const std::vector<double>& v) { return *std::max_element(v.begin(), v.end()); }

TEST(WarpSurface, RecoversACubicWarpAndItsNormal) {
  double true_max = 0;
  const HeightSamples rim = Sample(Warp, 0.0, 1, &true_max);
  const WarpSurface warp = WarpSurface::Fit(Plane(), rim);
  // The small ridge on the curvature terms (WarpFitOptions) costs at most a
  // micrometre on a fully measured rim (measured: 0.93 um at worst here).
  for (size_t i = 0; i < rim.size(); i += 97) EXPECT_NEAR(warp.Height(rim.points[i]), rim.heights[i], 1e-3) << i;
  for (const Eigen::Vector2d& p : {Eigen::Vector2d(0, 0), Eigen::Vector2d(3, -2)})
    EXPECT_NEAR(warp.Height(Eigen::Vector3d(p.x(), p.y(), 200 - Warp(p))), Warp(p), 2e-3) << p.transpose();
  // At the centre the slope is (0, 0): the normal is the plane's (to 0.2 mrad, which
  // moves a 0.3 mm sheet's top edge by 0.06 um).
  EXPECT_LT((warp.SheetNormal(Eigen::Vector3d(0, 0, 200)) - Plane().normal).norm(), 2e-4);
}

// Heights triangulated with the side faces along the support normal are off by
// gain . (S_true - S_assumed) (FaceCoupling): with that dependence in its design the
// fit recovers the warp and its normals; fitted to the heights alone it does not.
TEST(WarpSurface, CoupledToTheFacesItRecoversTheSheetTheHeightsWereMeasuredWith) {
  const SupportPlane plane = Plane();
  const auto [e1, e2] = PlaneAxes(plane);
  // grad W in the camera's (x, y), mm per mm (Warp above).
  auto gradient = [](const Eigen::Vector2d& p) {
    const double x = p.x() / 8, y = p.y() / 5;
    return Eigen::Vector2d((0.08 * x + 0.05 * y + 0.03 * x * x - 0.008 * y * y) / 8,
                           (-0.06 * y + 0.05 * x - 0.016 * x * y) / 5);
  };
  auto true_normal = [&](const Eigen::Vector2d& p) {
    const Eigen::Vector2d g = gradient(p);
    // Heights grow along -z: a slope g in (x, y) is -g along the plane normal's frame.
    const Eigen::Vector3d up = plane.normal, gx = Eigen::Vector3d::UnitX(), gy = Eigen::Vector3d::UnitY();
    return (up - g.x() * gx - g.y() * gy).normalized();
  };
  HeightSamples rim;
  FaceCoupling coupling;
  for (const Eigen::Vector2d& p : Outline(0.05)) {
    const double h = Warp(p);
    const Eigen::Vector3d s_true = true_normal(p);
    const Eigen::Vector2d s_true_h(s_true.dot(e1), s_true.dot(e2));
    // About the gains of a 0.3 mm sheet on the paper rig: 1 mm per rad, outward.
    const Eigen::Vector3d out(p.x() / 8, p.y() / 5, 0);
    const Eigen::Vector2d gain = 1.0 * Eigen::Vector2d(out.dot(e1), out.dot(e2)).normalized();
    const Eigen::Vector2d assumed(0, 0);  // faces along the support normal
    rim.Add(Eigen::Vector3d(p.x(), p.y(), 200 - h), h + gain.dot(s_true_h - assumed), 1.0);
    coupling.rim_gain.push_back(gain);
    coupling.rim_assumed.push_back(assumed);
  }
  WarpFitOptions options;
  options.curvature_prior_mm = 0;  // noise-free data: no prior needed
  options.curvature_ridge = 0;
  const WarpSurface coupled = WarpSurface::Fit(plane, rim, {}, options, &coupling);
  const WarpSurface alone = WarpSurface::Fit(plane, rim, {}, options);
  double coupled_error = 0, alone_error = 0, height_error = 0;
  for (const Eigen::Vector2d& p : Outline(0.5)) {
    const Eigen::Vector3d at(p.x(), p.y(), 200 - Warp(p));
    coupled_error = std::max(coupled_error, (coupled.SheetNormal(at) - true_normal(p)).norm());
    alone_error = std::max(alone_error, (alone.SheetNormal(at) - true_normal(p)).norm());
    height_error = std::max(height_error, std::abs(coupled.Height(at) - Warp(p)));
  }
  std::printf("largest normal error: coupled %.1e rad, heights alone %.1e rad\n", coupled_error, alone_error);
  // What remains is the linearisation S_h = -grad W (the normal's horizontal part is
  // -grad W / sqrt(1 + |grad W|^2)): a few urad, hundredths of a micrometre.
  EXPECT_LT(coupled_error, 1e-5);
  EXPECT_LT(height_error, 2e-5);
  EXPECT_GT(alone_error, 1e-3);
}

// The largest of thousands of noisy heights is biased up by about 3 noise SDs; the
// warp surface is not. A point-wise maximum of these samples errs by +4 um or more.
TEST(RimHeights, MaximumOfANoisyWarpIsUnbiased) {
  std::vector<double> errors;
  for (uint64_t seed = 1; seed <= 10; ++seed) {
    double true_max = 0;
    const HeightSamples rim = Sample(Warp, 0.002, seed, &true_max);
    const RimHeights h = EstimateRimHeights(Plane(), rim, {});
    errors.push_back(Max(h.heights) - true_max);
    EXPECT_GT(Max(rim.heights) - true_max, 0.004);
    EXPECT_LT(h.significant, static_cast<int>(rim.size() / 100)) << seed;  // no features: few flagged
  }
  for (double e : errors) EXPECT_LT(std::abs(e), 0.0005);
}

// A local bump (a dent pushed up at the rim: 25 um, 0.5 mm wide) is not in the warp
// model: the deviation channel keeps it, so the maximum is the bump's.
TEST(RimHeights, KeepsALocalBumpTheWarpCannotShow) {
  const Eigen::Vector2d centre(8, 1.5);  // on the x = 8 side
  auto bumped = [&](const Eigen::Vector2d& p) {
    return Warp(p) + 0.025 * std::exp(-(p - centre).squaredNorm() / (2 * 0.5 * 0.5));
  };
  for (uint64_t seed = 1; seed <= 5; ++seed) {
    double true_max = 0;
    const HeightSamples rim = Sample(bumped, 0.002, seed, &true_max);
    const RimHeights h = EstimateRimHeights(Plane(), rim, {});
    EXPECT_NEAR(Max(h.heights), true_max, 0.002) << seed;
    EXPECT_GT(h.significant, 20) << seed;
    // The warp surface alone (robust: the bump is its outlier) misses most of it.
    double warp_max = -1e9;
    for (const Eigen::Vector3d& p : rim.points) warp_max = std::max(warp_max, h.warp.Height(p));
    EXPECT_LT(warp_max, true_max - 0.015) << seed;
  }
}

// Crossings matched to a wrong edge (a run of five at +4.7 mm) neither bend the warp
// nor carry the maximum.
TEST(RimHeights, IgnoresARunOfMismatchedPoints) {
  double true_max = 0;
  HeightSamples rim = Sample(Warp, 0.002, 3, &true_max);
  for (int i = 300; i < 305; ++i) {
    rim.points[i].z() -= 4.7;
    rim.heights[i] += 4.7;
  }
  const RimHeights h = EstimateRimHeights(Plane(), rim, {});
  EXPECT_NEAR(Max(h.heights), true_max, 0.001);
}

// A warp of higher order than the cubic (quartic terms of 20 um at the part's ends)
// is mostly taken up by the cubic on a closed rim: the maximum stays within 1.5 um.
TEST(RimHeights, QuarticWarpStaysWithinAMicrometreAndAHalf) {
  auto quartic = [](const Eigen::Vector2d& p) {
    const double x = p.x() / 8, y = p.y() / 5;
    return Warp(p) + 0.02 * (x * x * x * x + 0.5 * y * y * y * y);
  };
  double true_max = 0;
  const HeightSamples rim = Sample(quartic, 0.002, 7, &true_max);
  EXPECT_NEAR(Max(EstimateRimHeights(Plane(), rim, {}).heights), true_max, 0.0015);
}

// Hole edges join the fit with their own height offset (a part with folded walls stands
// on the walls' rim, the holes are in the sheet 2 mm above): the offset does not leak
// into the rim's heights, and gross hole points are down-weighted like rim points.
TEST(RimHeights, HoleEdgesWithTheirOwnOffset) {
  double true_max = 0;
  const HeightSamples rim = Sample(Warp, 0.001, 4, &true_max);
  HeightSamples inner;
  for (double cx : {-3.0, 3.0})
    for (int k = 0; k < 100; ++k) {
      const Eigen::Vector2d p(cx + 0.8 * std::cos(k * 0.0628), 0.8 * std::sin(k * 0.0628));
      const double h = Warp(p) + 2.0 + (k < 3 ? 1.5 : 0.0);  // three mismatched
      inner.Add(Eigen::Vector3d(p.x(), p.y(), 200 - h), h, 1.0);
    }
  const RimHeights h = EstimateRimHeights(Plane(), rim, inner);
  EXPECT_NEAR(Max(h.heights), true_max, 0.0005);
  for (size_t i = 0; i < rim.size(); i += 101) EXPECT_NEAR(h.warp.Height(rim.points[i]), rim.heights[i], 0.004) << i;
}

}  // namespace
// The warp surface's standard uncertainty (RimHeights::HeightSd) against its actual
// error at 8 points of the rim, over 40 noisy rims: with independent noise about 95% of
// the errors lie within 2 SD; with noise correlated along the rim (a moving average
// over 15 points, as neighbouring crossings share image noise) the inflation kappa and
// the block jackknife keep that share, which the independent-noise variance alone
// would not.
struct WarpErrorShares {
  double within_2sd = 0, within_2sd_uninflated = 0, mean_kappa = 0;
};

WarpErrorShares ShareOfWarpErrorsWithinTwoSd(int correlated_points) {
  WarpErrorShares out;
  int count = 0;
  for (uint64_t seed = 1; seed <= 40; ++seed) {
    Random rng(seed);
    HeightSamples rim;
    const std::vector<Eigen::Vector2d> outline = Outline(0.02);
    std::vector<double> white(outline.size());
    for (double& v : white) v = rng.Normal(0, 0.002);
    for (size_t i = 0; i < outline.size(); ++i) {
      double noise = 0;  // moving average, scaled back to 2 um SD
      for (int k = 0; k < correlated_points; ++k) noise += white[(i + k) % outline.size()];
      noise /= std::sqrt(static_cast<double>(correlated_points));
      const double h = Warp(outline[i]) + noise;
      rim.Add(Eigen::Vector3d(outline[i].x(), outline[i].y(), 200 - h), h, 1.0);
    }
    const RimHeights heights = EstimateRimHeights(Plane(), rim, {});
    out.mean_kappa += heights.noise_inflation / 40;
    for (size_t i = 0; i < outline.size(); i += outline.size() / 8) {
      const Eigen::Vector3d p(outline[i].x(), outline[i].y(), 200);
      const double error = std::abs(heights.warp.Height(p) - Warp(outline[i]));
      const double sd = heights.HeightSd(p);
      out.within_2sd += error <= 2 * sd;
      out.within_2sd_uninflated += error <= 2 * std::sqrt(heights.warp.HeightVariance(p));
      ++count;
    }
  }
  out.within_2sd /= count;
  out.within_2sd_uninflated /= count;
  return out;
}

TEST(RimHeights, WarpUncertaintyCoversItsErrorWithIndependentNoise) {
  const WarpErrorShares shares = ShareOfWarpErrorsWithinTwoSd(1);
  EXPECT_LT(shares.mean_kappa, 1.5);
  EXPECT_GT(shares.within_2sd, 0.88);
  EXPECT_LT(shares.within_2sd, 0.995);  // not inflated
  std::printf("independent noise: kappa %.2f, %.1f%% within 2 SD\n", shares.mean_kappa, 100 * shares.within_2sd);
}

TEST(RimHeights, CorrelatedNoiseIsInflatedIntoTheWarpUncertainty) {
  const WarpErrorShares shares = ShareOfWarpErrorsWithinTwoSd(15);
  EXPECT_GT(shares.mean_kappa, 5);
  EXPECT_GT(shares.within_2sd, 0.85);
  EXPECT_LT(shares.within_2sd_uninflated, 0.75);
  std::printf("correlated noise: kappa %.2f, %.1f%% within 2 SD (%.1f%% with the independent-noise variance)\n", shares.mean_kappa,
              100 * shares.within_2sd, 100 * shares.within_2sd_uninflated);
}

}  // namespace flatscan
