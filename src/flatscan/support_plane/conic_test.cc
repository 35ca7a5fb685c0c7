#include "flatscan/support_plane/conic.h"

#include <cmath>
#include <random>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

namespace flatscan {
namespace {

constexpr double kDeg = M_PI / 180.0;

// A pinhole camera (docs/design.md section 4: f = 25 mm / 2.2 um) looking at a plane 200 mm
// away, tilted by `tilt_deg` about an in-plane axis at `azimuth_deg`.
struct PlaneView {
  Eigen::Matrix3d k;
  Eigen::Matrix3d rotation;  // camera_from_plane
  Eigen::Vector3d translation;

  PlaneView(double tilt_deg, double azimuth_deg, const Eigen::Vector3d& t = {3.0, -2.0, 200.0}) {
    const double f = 25.0 / 2.2e-3;
    k << f, 0, 1295.5, 0, f, 971.5, 0, 0, 1;
    const Eigen::Vector3d axis(std::cos(azimuth_deg * kDeg), std::sin(azimuth_deg * kDeg), 0);
    rotation = Eigen::AngleAxisd(tilt_deg * kDeg, axis).toRotationMatrix();
    translation = t;
  }
  // Plane-to-image homography: x_img ~ K [r1 r2 t] (X, Y, 1).
  Eigen::Matrix3d Homography() const {
    Eigen::Matrix3d rt;
    rt << rotation.col(0), rotation.col(1), translation;
    return k * rt;
  }
  Eigen::Vector2d Project(const Eigen::Vector2d& plane_point) const {
    const Eigen::Vector3d x = Homography() * Eigen::Vector3d(plane_point.x(), plane_point.y(), 1);
    return x.head<2>() / x.z();
  }
  // Image conic of the circle (centre c, radius r) of the plane: H^-T C H^-1.
  ConicMatrix CircleConic(const Eigen::Vector2d& c, double r) const {
    ConicMatrix plane;
    plane << 1, 0, -c.x(), 0, 1, -c.y(), -c.x(), -c.y(), c.squaredNorm() - r * r;
    const Eigen::Matrix3d h_inv = Homography().inverse();
    const ConicMatrix img = h_inv.transpose() * plane * h_inv;
    return img / img.norm();
  }
  std::vector<Eigen::Vector2d> CirclePoints(const Eigen::Vector2d& c, double r, int n, double from = 0,
                                            double to = 2 * M_PI) const {
    std::vector<Eigen::Vector2d> out;
    for (int i = 0; i < n; ++i) {
      const double t = from + (to - from) * i / n;
      out.push_back(Project(c + r * Eigen::Vector2d(std::cos(t), std::sin(t))));
    }
    return out;
  }
};

TEST(Conic, EllipseConicRoundTripAndDistance) {
  Ellipse e;
  e.centre = {812.25, -33.5};
  e.a = 140.0;
  e.b = 96.0;
  e.angle = 0.7;
  const ConicMatrix c = e.ToConic();
  for (double t : {0.0, 1.0, 2.5, 4.0}) {
    const Eigen::Vector3d x(e.PointAt(t).x(), e.PointAt(t).y(), 1.0);
    EXPECT_NEAR(x.dot(c * x) / (c.norm() * x.squaredNorm()), 0.0, 1e-15);
  }
  const Eigen::Vector3d centre(e.centre.x(), e.centre.y(), 1);
  EXPECT_LT(centre.dot(c * centre), 0.0);
  const std::optional<Ellipse> back = EllipseFromConic(-3.0 * c);  // any scale and sign
  ASSERT_TRUE(back);
  EXPECT_NEAR((back->centre - e.centre).norm(), 0, 1e-9);
  EXPECT_NEAR(back->a, e.a, 1e-9);
  EXPECT_NEAR(back->b, e.b, 1e-9);
  EXPECT_NEAR(back->angle, e.angle, 1e-12);

  // Orthogonal distance against brute-force sampling of the ellipse.
  for (const Eigen::Vector2d& p : {Eigen::Vector2d(1000, 50), Eigen::Vector2d(800, 40), Eigen::Vector2d(700, -200),
                                   Eigen::Vector2d(830, -30)}) {
    double best = 1e300;
    for (int i = 0; i < 200000; ++i) best = std::min(best, (e.PointAt(2 * M_PI * i / 200000) - p).norm());
    double t = 0;
    const double d = EllipseDistance(e, p, &t);
    EXPECT_NEAR(std::abs(d), best, 1e-5) << p.transpose();
    EXPECT_NEAR((e.PointAt(t) - p).norm(), std::abs(d), 1e-9);
    const Eigen::Vector3d x(p.x(), p.y(), 1);
    EXPECT_EQ(d > 0, x.dot(c * x) > 0);
  }
  EXPECT_FALSE(EllipseFromConic(Eigen::Vector3d(1, -1, -1).asDiagonal().toDenseMatrix()));  // hyperbola
  EXPECT_FALSE(EllipseFromConic(Eigen::Vector3d(1, 1, 1).asDiagonal().toDenseMatrix()));   // imaginary
}

TEST(Conic, FitsAreExactWithoutNoise) {
  const PlaneView view(25.0, 30.0);
  const Ellipse truth = *EllipseFromConic(view.CircleConic({1.0, 2.0}, 2.5));
  for (int n : {6, 40, 900}) {
    const std::vector<Eigen::Vector2d> pts = view.CirclePoints({1.0, 2.0}, 2.5, n, 0.3, 0.3 + 2 * M_PI);
    const std::optional<Ellipse> direct = FitEllipseDirect(pts);
    ASSERT_TRUE(direct) << n;
    EXPECT_NEAR((direct->centre - truth.centre).norm(), 0, 1e-6) << n;
    const EllipseFit fit = FitEllipse(pts);
    ASSERT_TRUE(fit.ok);
    EXPECT_NEAR((fit.ellipse.centre - truth.centre).norm(), 0, 1e-7) << n;
    EXPECT_NEAR(fit.ellipse.a, truth.a, 1e-7);
    EXPECT_NEAR(fit.ellipse.b, truth.b, 1e-7);
    EXPECT_LT(fit.rms_px, 1e-7);
  }
  EXPECT_FALSE(FitEllipseDirect({{0, 0}, {1, 1}, {2, 2}, {3, 3}, {4, 4}, {5, 5}, {6, 6}}));  // a line
  EXPECT_FALSE(FitEllipse({{0, 0}, {1, 0}, {0, 1}}).ok);                                 // too few
}

// A bump on a short arc (dust on a ring edge) is left out; a square is not made an ellipse.
TEST(Conic, TrimmedFitLeavesOutABump) {
  Ellipse truth;
  truth.centre = {700.0, 500.0};
  truth.a = 140.0;
  truth.b = 120.0;
  truth.angle = -0.3;
  std::vector<Eigen::Vector2d> pts;
  for (int i = 0; i < 800; ++i) {
    const double t = 2 * M_PI * i / 800;
    const double bump = (t > 1.0 && t < 1.15) ? 3.0 * std::sin((t - 1.0) / 0.15 * M_PI) : 0.0;
    const Eigen::Vector2d p = truth.PointAt(t);
    pts.push_back(p + bump * (p - truth.centre).normalized());
  }
  const EllipseFit plain = FitEllipse(pts);
  const EllipseFit trimmed = FitEllipseTrimmed(pts, 0.5);
  const EllipseFit grown = FitEllipseTrimmed(pts, 0.5, 0.1, 5);
  EXPECT_GT((plain.ellipse.centre - truth.centre).norm(), 0.02);
  // The bump's feet (under 0.5 px) stay in: a small remainder.
  EXPECT_LT((trimmed.ellipse.centre - truth.centre).norm(), 0.1 * (plain.ellipse.centre - truth.centre).norm());
  EXPECT_LT((grown.ellipse.centre - truth.centre).norm(), 1e-9);  // the feet too
  EXPECT_GT(trimmed.outliers, 10);
  EXPECT_LT(trimmed.outliers, 20);
  EXPECT_EQ(grown.outliers, trimmed.outliers + 10);
  EXPECT_EQ(trimmed.points + trimmed.outliers, 800);
  std::vector<Eigen::Vector2d> square;
  for (int i = 0; i < 400; ++i) {
    const double s = -50 + 100.0 * (i % 100) / 100;
    const Eigen::Vector2d side[] = {{s, -50}, {50, s}, {-s, 50}, {-50, -s}};
    square.push_back(side[i / 100]);
  }
  const EllipseFit sq = FitEllipseTrimmed(square);
  EXPECT_EQ(sq.outliers, 0);
  EXPECT_GT(sq.rms_px, 1.0);
}

// On partial arcs the algebraic fit is pulled (it weights points by their distance from
// the centre); the orthogonal-distance fit is not. Also compare cv::fitEllipseDirect.
TEST(Conic, GeometricFitIsUnbiasedOnPartialArcs) {
  Ellipse truth;
  truth.centre = {400.0, 300.0};
  truth.a = 60.0;
  truth.b = 45.0;
  truth.angle = 0.4;
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 0.1);
  for (double arc_deg : {120.0, 180.0, 360.0}) {
    Eigen::Vector2d sum_direct = Eigen::Vector2d::Zero(), sum_fit = Eigen::Vector2d::Zero();
    Eigen::Vector2d sum_opencv = Eigen::Vector2d::Zero();
    double sq_fit = 0;
    const int trials = 30;
    for (int trial = 0; trial < trials; ++trial) {
      std::vector<Eigen::Vector2d> pts;
      std::vector<cv::Point2f> cv_pts;
      const int n = static_cast<int>(arc_deg * 2);
      for (int i = 0; i < n; ++i) {
        // Noise along the normal, as sub-pixel edge points have.
        const double t = 0.2 + arc_deg * kDeg * i / n;
        const Eigen::Vector2d p = truth.PointAt(t);
        double foot = 0;
        EllipseDistance(truth, p, &foot);
        const Eigen::Vector2d normal = (truth.PointAt(foot + 1e-6) - truth.PointAt(foot - 1e-6)).normalized();
        pts.push_back(p + noise(rng) * Eigen::Vector2d(normal.y(), -normal.x()));
        cv_pts.emplace_back(static_cast<float>(pts.back().x() + 1600), static_cast<float>(pts.back().y() + 1200));
      }
      const Ellipse direct = *FitEllipseDirect(pts);
      const EllipseFit fit = FitEllipse(pts);
      ASSERT_TRUE(fit.ok);
      EXPECT_NEAR(fit.rms_px, 0.1, 0.03);
      sum_direct += direct.centre - truth.centre;
      sum_fit += fit.ellipse.centre - truth.centre;
      sq_fit += (fit.ellipse.centre - truth.centre).squaredNorm();
      const cv::RotatedRect r = cv::fitEllipseDirect(cv_pts);
      sum_opencv += Eigen::Vector2d(r.center.x - 1600, r.center.y - 1200) - truth.centre;
    }
    const double bias_direct = (sum_direct / trials).norm(), bias_fit = (sum_fit / trials).norm();
    const double spread_fit = std::sqrt(sq_fit / trials);
    std::printf("arc %3.0f deg: centre bias direct %.4f px, cv::fitEllipseDirect %.4f px, geometric %.4f px "
                "(rms error %.4f px)\n",
                arc_deg, bias_direct, (sum_opencv / trials).norm(), bias_fit, spread_fit);
    // The bias of the mean must be within its standard error (spread / sqrt(trials)) x 3.
    EXPECT_LT(bias_fit, 3 * spread_fit / std::sqrt(trials) + 1e-3) << arc_deg;
    if (arc_deg < 200) {
      EXPECT_GT(bias_direct, 3 * bias_fit) << arc_deg;
    }
  }
}

// The corrected centre from two concentric circles is exact (analytic conics), the
// ellipse centre is not: docs/design.md section 6.2 gives 0.30 px at 10 deg and 0.57 px at 20
// deg for a 2.5 mm ring at 200 mm with a 25 mm lens.
TEST(Conic, ConcentricCirclesCentreIsExact) {
  const std::pair<double, double> design[] = {{10.0, 0.30}, {20.0, 0.57}};
  for (const auto& [tilt, bias] : design) {
    const PlaneView view(tilt, 90.0, {0.0, 0.0, 200.0});  // ring on the optical axis
    const ConicMatrix outer = view.CircleConic({0, 0}, 2.5), inner = view.CircleConic({0, 0}, 1.0);
    const Eigen::Vector2d truth = view.Project({0, 0});
    const std::optional<Eigen::Vector2d> c = ConcentricCirclesCentre(outer, inner);
    ASSERT_TRUE(c);
    EXPECT_NEAR((*c - truth).norm(), 0.0, 1e-9) << tilt;
    const double naive = (EllipseFromConic(outer)->centre - truth).norm();
    EXPECT_NEAR(naive, bias, 0.01) << tilt;
  }
  for (double tilt : {0.0, 7.0, 15.0, 40.0, 60.0}) {
    for (double azimuth : {0.0, 35.0, 200.0}) {
      const PlaneView view(tilt, azimuth);
      const Eigen::Vector2d centre(-4.0, 6.5);
      const ConicMatrix outer = view.CircleConic(centre, 2.5), inner = view.CircleConic(centre, 1.0);
      const Eigen::Vector2d truth = view.Project(centre);
      for (const auto& [c1, c2] : {std::pair(outer, inner), std::pair(inner, outer)}) {
        const std::optional<Eigen::Vector2d> c = ConcentricCirclesCentre(c1, -7.0 * c2);
        ASSERT_TRUE(c) << tilt << " " << azimuth;
        EXPECT_NEAR((*c - truth).norm(), 0.0, 1e-9) << tilt << " " << azimuth;
      }
    }
  }
  // Degenerate: one conic twice.
  const PlaneView view(10, 0);
  EXPECT_FALSE(ConcentricCirclesCentre(view.CircleConic({0, 0}, 2), view.CircleConic({0, 0}, 2)));
}

// The same from fitted points, noise-free and with sub-pixel edge noise.
TEST(Conic, ConcentricCirclesCentreFromFittedPoints) {
  const PlaneView view(15.0, 60.0);
  const Eigen::Vector2d centre(10.0, -7.0);
  const Eigen::Vector2d truth = view.Project(centre);
  {
    const EllipseFit outer = FitEllipse(view.CirclePoints(centre, 2.5, 880));
    const EllipseFit inner = FitEllipse(view.CirclePoints(centre, 1.0, 350));
    const Eigen::Vector2d c = *ConcentricCirclesCentre(outer.conic, inner.conic);
    EXPECT_NEAR((c - truth).norm(), 0.0, 1e-6);
    EXPECT_GT((outer.ellipse.centre - truth).norm(), 0.3);
  }
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, 0.05);
  double sq = 0, naive = 0;
  const int trials = 20;
  for (int trial = 0; trial < trials; ++trial) {
    auto noisy = [&](std::vector<Eigen::Vector2d> pts) {
      for (auto& p : pts) p += Eigen::Vector2d(noise(rng), noise(rng));
      return pts;
    };
    const EllipseFit outer = FitEllipse(noisy(view.CirclePoints(centre, 2.5, 880)));
    const EllipseFit inner = FitEllipse(noisy(view.CirclePoints(centre, 1.0, 350)));
    sq += (*ConcentricCirclesCentre(outer.conic, inner.conic) - truth).squaredNorm();
    naive += (outer.ellipse.centre - truth).norm();
  }
  const double rms = std::sqrt(sq / trials);
  std::printf("tilt 15 deg, noise 0.05 px: corrected centre rms error %.4f px, outer ellipse centre error %.3f px\n",
              rms, naive / trials);
  EXPECT_LT(rms, 0.01);
  EXPECT_GT(naive / trials, 0.3);
}

}  // namespace
}  // namespace flatscan
