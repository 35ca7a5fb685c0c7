#include "flatscan/simulation/structured_light.h"

#include <cmath>

#include <gtest/gtest.h>

#include "flatscan/simulation/scene_config.h"

namespace flatscan {
namespace {

struct Traced {
  StructuredLightRig rig;
  PartGeometry part;
  PartTruth truth;
  ProjectorView view;
};

// A flat 10 x 10 mm plate, 0.5 mm thick, on the support under the camera.
Traced TraceFlatPlate(const SurfaceFinish& finish) {
  StructuredLightSpec spec;
  spec.finish = finish;
  Traced t{BuildStructuredLightRig(BuildStation(ScenePreset("paper")), spec), {}, {}, {}};
  t.part.thickness = 0.5;
  t.truth = RestAndPlacePart(t.part, 0, {0, 0});
  t.view = TraceProjectorView(t.rig, t.part, t.truth.support_from_part);
  return t;
}

TEST(StructuredLight, TheCameraSeesThePlatesTopAtItsThicknessAndItsShadowAwayFromTheProjector) {
  const Traced t = TraceFlatPlate(SurfaceFinish::Matte());
  const Eigen::Vector2d centre = t.rig.camera.Project(t.rig.cam_from_support * Eigen::Vector3d(0, 0, 0.5));
  const int u = static_cast<int>(std::round(centre.x())), v = static_cast<int>(std::round(centre.y()));
  ASSERT_EQ(t.view.on_part(v, u), 255);
  EXPECT_NEAR(t.view.point(v, u)[2], 0.5, 1e-5);
  // The projector stands at +x: the support just beyond the plate's -x edge is in its
  // shadow (0.5 mm x tan 25 deg = 0.23 mm wide), just beyond the +x edge it is lit.
  auto pixel_of = [&](double x) {
    const Eigen::Vector2d p = t.rig.camera.Project(t.rig.cam_from_support * Eigen::Vector3d(x, 0, 0));
    return cv::Point(static_cast<int>(std::round(p.x())), static_cast<int>(std::round(p.y())));
  };
  EXPECT_LT(t.view.projector_px(pixel_of(-5.12))[0], 0);  // shadow: unlit
  EXPECT_EQ(t.view.gain(pixel_of(-5.12)), 0.f);
  EXPECT_GT(t.view.projector_px(pixel_of(-5.4))[0], 0);   // beyond the shadow
  EXPECT_GT(t.view.projector_px(pixel_of(5.1))[0], 0);
  // Lambertian gains: exposure x albedo x cos(25 deg) on the plate and the support.
  EXPECT_NEAR(t.view.gain(v, u), 200 * 0.7 * std::cos(25 * M_PI / 180), 2.0);
  EXPECT_NEAR(t.view.gain(pixel_of(5.5)), 200 * 0.6 * std::cos(25 * M_PI / 180), 2.0);
}

TEST(StructuredLight, AMetallicTopReturnsItsSpecularLobe) {
  const Traced t = TraceFlatPlate(SurfaceFinish::Metallic());
  const Eigen::Vector2d centre = t.rig.camera.Project(t.rig.cam_from_support * Eigen::Vector3d(0, 0, 0.5));
  const float gain = t.view.gain(static_cast<int>(std::round(centre.y())), static_cast<int>(std::round(centre.x())));
  // n.h = cos(12.5 deg) on a flat top under a camera straight above: 0.25 cos 25 + 3 cos^80 12.5.
  EXPECT_NEAR(gain, 200 * (0.25 * std::cos(25 * M_PI / 180) + 3 * std::pow(std::cos(12.5 * M_PI / 180), 80)), 3.0);
}

TEST(StructuredLight, ImagesAPatternWithTheLitPixelsBrightAndTheShadowDark) {
  const Traced t = TraceFlatPlate(SurfaceFinish::Matte());
  const cv::Mat1b white(t.rig.projector.height, t.rig.projector.width, uchar{255});
  const cv::Mat1b image = ImagePattern(t.rig, t.view, white, 3);
  const Eigen::Vector2d centre = t.rig.camera.Project(t.rig.cam_from_support * Eigen::Vector3d(0, 0, 0.5));
  EXPECT_NEAR(image(static_cast<int>(centre.y()), static_cast<int>(centre.x())), 6 + 200 * 0.7 * std::cos(25 * M_PI / 180), 8);
}

TEST(StructuredLight, CutsTheCameraRegionToASizeTheFourierTransformTakesWhole) {
  StructuredLightSpec spec;
  spec.roi_width = 721;
  spec.roi_height = 580;
  const StructuredLightRig rig = BuildStructuredLightRig(BuildStation(ScenePreset("paper")), spec);
  EXPECT_EQ(rig.camera.width, 720);   // 2^4 3^2 5
  EXPECT_EQ(rig.camera.height, 576);  // 2^6 3^2
  spec.roi_width = spec.roi_height = 100000;  // at most the sensor, 2592 x 1944 (2^5 3^4, 2^3 3^5)
  const StructuredLightRig whole = BuildStructuredLightRig(BuildStation(ScenePreset("paper")), spec);
  EXPECT_EQ(whole.camera.width, 2592);
  EXPECT_EQ(whole.camera.height, 1944);
}

TEST(StructuredLight, RefusesASpecItCannotBuild) {
  StructuredLightSpec spec;
  spec.fringe_periods = 60;
  try {
    BuildStructuredLightRig(BuildStation(ScenePreset("paper")), spec);
    FAIL();
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("structured_light.fringe_periods"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("expected a divisor of the projector width 1024 (>= 2), got 60"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace flatscan
