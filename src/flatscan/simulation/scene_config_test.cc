#include "flatscan/simulation/scene_config.h"

#include <fstream>

#include <gtest/gtest.h>

#include "flatscan/util/error.h"
#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {

using testing::InputErrorOf;

void WriteText(const std::filesystem::path& path, const std::string& text) {
  std::ofstream(path) << text;
}

TEST(SceneConfig, PaperPresetFollowsTheReferenceRig) {
  const SceneConfig s = ScenePreset("paper");
  EXPECT_EQ(s.left_camera.width, 2592);
  EXPECT_EQ(s.left_camera.height, 1944);
  EXPECT_NEAR(s.left_camera.focal_length_mm / (s.left_camera.pixel_size_um * 1e-3), 11364, 1.0);
  EXPECT_DOUBLE_EQ(s.rig.baseline_mm, 60.0);
  EXPECT_DOUBLE_EQ(s.rig.working_distance_mm, 200.0);
  EXPECT_EQ(InputErrorOf([] { ScenePreset("nope"); }), "unknown preset 'nope' (expected one of: paper, compact)");
}

TEST(SceneConfig, JsonRoundTripKeepsEveryField) {
  const SceneConfig compact = ScenePreset("compact");
  const nlohmann::json doc = SceneToJson(compact);
  nlohmann::json body = doc;
  body.erase("name");
  SceneConfig back = ApplySceneDocument(ScenePreset("paper"), body, "round-trip");
  back.name = compact.name;
  EXPECT_EQ(SceneToJson(back).dump(), doc.dump());
  EXPECT_EQ(back.right_camera.principal_point_offset_px[0], 6.0);
  EXPECT_EQ(back.left_camera.distortion, compact.left_camera.distortion);
}

TEST(SceneConfig, YamlFileOverridesFieldsOfItsPreset) {
  testing::ScratchDir dir("scene-yaml");
  const auto path = dir.path() / "rig.yml";
  WriteText(path,
            "preset: compact\n"
            "camera:\n"
            "  width: 1280\n"
            "  distortion: [-0.1, 0.05, 0, 0, 0]\n"
            "optics:\n"
            "  blur_sigma_px: 1.2\n"
            "part:\n"
            "  thickness_mm: [0.1, 0.2]\n"
            "  holes: 1\n"
            "  waviness_um: [2, 8]\n"
            "dataset:\n"
            "  markers_in_part_images: true\n");
  const SceneConfig s = LoadSceneFile(path);
  EXPECT_EQ(s.left_camera.width, 1280);
  EXPECT_EQ(s.right_camera.width, 1280);
  EXPECT_EQ(s.left_camera.height, 1200);                                 // from the preset
  EXPECT_EQ(s.right_camera.principal_point_offset_px[0], 6.0);           // kept per camera
  EXPECT_DOUBLE_EQ(s.left_camera.distortion[0], -0.1);
  EXPECT_DOUBLE_EQ(s.optics.blur_sigma_px, 1.2);
  EXPECT_DOUBLE_EQ(s.part.thickness_mm.lo, 0.1);
  EXPECT_DOUBLE_EQ(s.part.thickness_mm.hi, 0.2);
  EXPECT_EQ(s.part.holes[0], 1);
  EXPECT_EQ(s.part.holes[1], 1);
  EXPECT_DOUBLE_EQ(s.part.waviness_um.hi, 8.0);
  EXPECT_DOUBLE_EQ(s.part.waviness_wavelength_mm.lo, 1.5);  // the default
  EXPECT_TRUE(s.dataset.markers_in_part_images);
}

TEST(SceneConfig, BadValuesNameTheFileAndField) {
  testing::ScratchDir dir("scene-bad");
  const auto yml = dir.path() / "s.yml";
  const auto json = dir.path() / "s.json";
  const std::string y = yml.string(), j = json.string();
  WriteText(yml, "optics:\n  noise_sigma_grey: -1\n");
  EXPECT_EQ(InputErrorOf([&] { LoadSceneFile(yml); }), y + ": optics.noise_sigma_grey must be >= 0, got -1");
  WriteText(yml, "optics:\n  blur_sigma_px:\n");
  EXPECT_EQ(InputErrorOf([&] { LoadSceneFile(yml); }), y + ": optics.blur_sigma_px has no value (expected a number in [0, 10])");
  WriteText(json, R"({"part": {"thickness_mm": [0.3, 0.1]}})");
  EXPECT_EQ(InputErrorOf([&] { LoadSceneFile(json); }), j + ": part.thickness_mm must have lo <= hi, got [0.3,0.1]");
  WriteText(json, R"({"part": {"waviness_wavelength_mm": 0.1}})");
  EXPECT_EQ(InputErrorOf([&] { LoadSceneFile(json); }),
            j + ": part.waviness_wavelength_mm must be >= 0.2, got 0.1");
  WriteText(json, R"({"optic": {"blur_sigma_px": 1}})");
  EXPECT_EQ(InputErrorOf([&] { LoadSceneFile(json); }).rfind(j + ": unknown field 'optic'", 0), 0u);
  WriteText(json, R"({"camera": {"width": "big"}})");
  EXPECT_EQ(InputErrorOf([&] { LoadSceneFile(json); }), j + ": camera.width must be an integer in [16, 20000], got \"big\"");
  WriteText(json, R"({"camera": {"distortion": [0.1, 0.2, 0.3]}})");
  EXPECT_EQ(InputErrorOf([&] { LoadSceneFile(json); }),
            j + ": camera.distortion must be a list of 4, 5 or 8 coefficients (k1 k2 p1 p2 [k3 [k4 k5 k6]]), got [0.1,0.2,0.3]");
  WriteText(json, R"({"part": {"side_faces": "vertical"}})");
  EXPECT_EQ(InputErrorOf([&] { LoadSceneFile(json); }), j + ": part.side_faces must be local or centre, got \"vertical\"");
  WriteText(json, R"({"part": {"side_faces": "centre"}})");
  EXPECT_EQ(LoadSceneFile(json).part.side_faces, SideFaceModel::kCentreNormal);
  EXPECT_EQ(ScenePreset("paper").part.side_faces, SideFaceModel::kLocalNormal);
  WriteText(json, R"({"image_effects": {"f_number": [0.5, 4]}})");
  EXPECT_EQ(InputErrorOf([&] { LoadSceneFile(json); }),
            j + ": image_effects.f_number must be 0 (no defocus) or apertures from f/0.7 (got [0.5, 4])");
  WriteText(json, R"({"image_effects": {"f_number": [2.8, 8], "focus_error_mm": [-3, 3]}})");
  EXPECT_EQ(LoadSceneFile(json).image_effects.focus_error_mm.hi, 3.0);
  WriteText(json, R"({"image_effects": {"f_number": [2.8, 8]}, "optics": {"blur_subpixels": 3}})");
  EXPECT_EQ(InputErrorOf([&] { LoadSceneFile(json); }),
            j + ": optics.blur_subpixels 3 with image_effects.f_number: the varying blur is rendered on whole pixels "
                "only (expected blur_subpixels 1)");
  WriteText(json, R"({"preset": "nope"})");
  EXPECT_EQ(InputErrorOf([&] { LoadSceneFile(json); }), "unknown preset 'nope' (expected one of: paper, compact)");
  WriteText(json, "{not json");
  EXPECT_EQ(InputErrorOf([&] { LoadSceneFile(json); }).rfind(j + ": not valid JSON", 0), 0u);
  WriteText(json, R"({"camera": {"noise_sigma_grey": 1e999}})");  // was an "internal error"
  EXPECT_EQ(InputErrorOf([&] { LoadSceneFile(json); }).rfind(j + ": not valid JSON (", 0), 0u);
  EXPECT_EQ(InputErrorOf([&] { LoadSceneFile(dir.path() / "missing.yml"); }),
            (dir.path() / "missing.yml").string() + ": cannot open scene file (expected a readable YAML or JSON file)");
}

}  // namespace
}  // namespace flatscan
