#include "flatscan/station/recipe.h"

#include <filesystem>
#include <fstream>
#include <string>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "flatscan/util/sha256.h"
#include "flatscan/util/test_util.h"

namespace flatscan {
namespace {
namespace fs = std::filesystem;

// A simulated rig and its plane (the compact preset, no images).
class RecipeTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::ScratchDir("recipe");
    const auto sim = testing::RunFlatscan("simulate --preset compact --parts 0 --no-calibration --no-markers -q -o " +
                                          (dir_->path() / "data").string());
    ASSERT_EQ(sim.exit_code, 0) << sim.err;
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  // Writes a recipe file (in the scratch folder) and returns its path.
  static fs::path Write(const std::string& text, const std::string& name = "r.yml") {
    const fs::path p = dir_->path() / name;
    std::ofstream(p) << text;
    return p;
  }
  static std::string Minimal() { return "name: shield\nthickness_mm: 0.2\ntolerance_mm: 0.1\nrig: data/rig.yml\nplane: data/plane_true.yml\n"; }
  static std::string ErrorOf(const std::string& text) {
    const fs::path p = Write(text);
    return testing::InputErrorOf([&] { LoadRecipe(p); });
  }
  static testing::ScratchDir* dir_;
};
testing::ScratchDir* RecipeTest::dir_ = nullptr;

TEST_F(RecipeTest, ReadsEveryKey) {
  const fs::path p = Write(Minimal() +
                           "guard_band_mm: 0.01\npart_length_mm: [15, 25.5]\nside_faces: centre\n"
                           "exposure:\n  min_backlight_grey: 80\n  max_saturated_fraction: 0.1\n  max_blur_sigma_px: 1.5\n"
                           "archive:\n  keep_pass_every: 10\n  quota_mb: 500\n  fail_retention_days: 30\n"
                           "camera:\n  exposure_us: 800\n  gain_db: 6\n");
  const LoadedRecipe loaded = LoadRecipe(p);
  const Recipe& r = loaded.recipe;
  EXPECT_EQ(r.name, "shield");
  EXPECT_EQ(r.sha256, Sha256HexOfFile(p));
  EXPECT_EQ(r.params.thickness_mm, 0.2);
  EXPECT_EQ(r.spec.tolerance_mm, 0.1);
  EXPECT_EQ(r.spec.guard_band_mm, 0.01);
  EXPECT_EQ(r.rig_file, dir_->path() / "data/rig.yml");  // relative to the recipe's folder
  ASSERT_TRUE(r.part_length_mm);
  EXPECT_EQ(r.part_length_mm->max_mm, 25.5);
  EXPECT_EQ(r.params.side_faces, SideFaceModel::kCentreNormal);
  EXPECT_EQ(r.params.acceptance.min_backlight_grey, 80);
  EXPECT_EQ(r.params.acceptance.max_blur_sigma_px, 1.5);
  EXPECT_EQ(r.archive.keep_pass_every, 10);
  EXPECT_EQ(r.archive.quota_mb, 500);
  EXPECT_EQ(r.camera.exposure_us, 800);
  EXPECT_EQ(r.camera.gain_db, 6);
  EXPECT_FALSE(ReadRecipe(Write(Minimal(), "minimal.yml")).camera.exposure_us);  // the camera's own
  EXPECT_NE(DescribeRecipe(loaded).find("cameras (--source cameras:..): exposure 800 us, gain 6 dB"), std::string::npos);
  EXPECT_EQ(loaded.inputs.plane_rig, PlaneRigMatch::kMatches);
  EXPECT_EQ(loaded.inputs.rig_sha256, Sha256HexOfFile(dir_->path() / "data/rig.yml"));
  EXPECT_NE(DescribeRecipe(loaded).find("a part whose length is outside [15.00, 25.50] mm is not measured"),
            std::string::npos);
}

TEST_F(RecipeTest, BadKeysAreNamedWithWhatWasExpected) {
  const std::string f = (dir_->path() / "r.yml").string();
  EXPECT_EQ(ErrorOf("name: shield\nthickness_mm: 0.2\nrig: data/rig.yml\nplane: data/plane_true.yml\n"),
            f + ": tolerance_mm: expected a number, found nothing (the key is missing)");
  EXPECT_EQ(ErrorOf(Minimal() + "tolerance: 0.2\n"),
            f + ": tolerance: expected one of the recipe's keys (archive, camera, exposure, guard_band_mm, name, part_length_mm, "
                "plane, plane_sha256, rig, rig_sha256, side_faces, thickness_mm, tolerance_mm), found an unknown key");
  EXPECT_EQ(ErrorOf("name: shield\nthickness_mm: thin\ntolerance_mm: 0.1\nrig: a\nplane: b\n"),
            f + ": thickness_mm: expected a number in (0, 5] mm, found 'thin'");
  EXPECT_EQ(ErrorOf("name: shield\nthickness_mm: 0.2\ntolerance_mm: -0.1\nrig: a\nplane: b\n"),
            f + ": tolerance_mm: expected a number in (0, 5] mm, found '-0.1'");
  EXPECT_EQ(ErrorOf("name: shield cover\nthickness_mm: 0.2\ntolerance_mm: 0.1\nrig: a\nplane: b\n"),
            f + ": name: expected 1-64 characters from [A-Za-z0-9_.-], found 'shield cover'");
  EXPECT_EQ(ErrorOf(Minimal() + "rig_sha256: abc\n"), f + ": rig_sha256: expected 64 lower-case hex digits (a SHA-256), found 'abc'");
  EXPECT_EQ(ErrorOf(Minimal() + "part_length_mm: [20, 10]\n"),
            f + ": part_length_mm: expected a list [min, max] of two lengths in mm, 0 <= min < max, found a list of 2");
  EXPECT_EQ(ErrorOf(Minimal() + "exposure:\n  max_blur: 3\n"),
            f + ": exposure.max_blur: expected one of the recipe's keys (max_blur_sigma_px, max_saturated_fraction, "
                "min_backlight_grey), found an unknown key");
  EXPECT_EQ(ErrorOf(Minimal() + "camera:\n  gain_db: 60\n"),
            f + ": camera.gain_db: expected a number in [0, 48] dB, found '60'");
  EXPECT_EQ(ErrorOf(Minimal() + "camera:\n  exposure: 800\n"),
            f + ": camera.exposure: expected one of the recipe's keys (exposure_us, gain_db), found an unknown key");
  EXPECT_EQ(ErrorOf(Minimal() + "side_faces: tilted\n"), f + ": side_faces: expected local, centre or support, found 'tilted'");
  EXPECT_EQ(ErrorOf("name: [shield\n"), f + ": line 2: not valid YAML (end of sequence flow not found)");
  EXPECT_EQ(ErrorOf("- a list\n"), f + ": (top level): expected a mapping of keys to values, found a list");
  EXPECT_EQ(ErrorOf(Minimal() + "tolerance_mm: 0.5\n"),
            f + ": tolerance_mm: expected each key once, found it twice (which one holds?)");
  EXPECT_EQ(testing::InputErrorOf([&] { LoadRecipe(dir_->path() / "none.yml"); }),
            (dir_->path() / "none.yml").string() + ": no such recipe file");
}

TEST_F(RecipeTest, FilesArePinnedAndThePlaneMustBelongToTheRig) {
  const std::string f = (dir_->path() / "r.yml").string();
  const fs::path rig = dir_->path() / "data/rig.yml";
  EXPECT_EQ(ErrorOf("name: shield\nthickness_mm: 0.2\ntolerance_mm: 0.1\nrig: data/no_rig.yml\nplane: data/plane_true.yml\n"),
            f + ": rig: no such file " + (dir_->path() / "data/no_rig.yml").string());
  const std::string wrong_pin(64, '0');
  EXPECT_EQ(ErrorOf(Minimal() + "rig_sha256: " + wrong_pin + "\n"),
            fmt::format("{}: rig_sha256: the file {} has SHA-256 {}, the recipe pins {} (the file changed since the "
                        "recipe was written: check it, then update the pin)",
                        f, rig.string(), Sha256HexOfFile(rig), wrong_pin));
  EXPECT_EQ(ErrorOf(Minimal() + "rig_sha256: " + Sha256HexOfFile(rig) + "\n"), "(no error)");

  // A plane calibrated with another rig (the paper preset's) is refused.
  const auto sim = testing::RunFlatscan("simulate --preset paper --parts 0 --no-calibration --no-markers -q -o " +
                                        (dir_->path() / "paper").string());
  ASSERT_EQ(sim.exit_code, 0) << sim.err;
  const std::string error =
      ErrorOf("name: shield\nthickness_mm: 0.2\ntolerance_mm: 0.1\nrig: data/rig.yml\nplane: paper/plane_true.yml\n");
  EXPECT_EQ(error, fmt::format("{}: plane: {} was calibrated with another rig file (rig_sha256 {}...) than the "
                               "recipe's rig {} (SHA-256 {}...): recalibrate the plane with this rig (`flatscan "
                               "calibrate-plane`)",
                               f, (dir_->path() / "paper/plane_true.yml").string(),
                               Sha256HexOfFile(dir_->path() / "paper/rig.yml").substr(0, 12), rig.string(),
                               Sha256HexOfFile(rig).substr(0, 12)));
}

TEST(PartLength, IsTheExtentAlongTheLongestAxis) {
  InspectionResult result;
  // The rim of a 20 x 10 mm rectangle turned by 30 degrees, 2 mm above the origin.
  const double c = std::cos(0.5236), s = std::sin(0.5236);
  for (int i = 0; i <= 100; ++i)
    for (const Eigen::Vector2d& p : {Eigen::Vector2d(-10 + 0.2 * i, -5), Eigen::Vector2d(-10 + 0.2 * i, 5),
                                     Eigen::Vector2d(-10, -5 + 0.1 * i), Eigen::Vector2d(10, -5 + 0.1 * i)}) {
      InspectedPoint q{};
      q.left_raw = q.right_raw = Eigen::Vector2d::Zero();
      q.cam1 = {c * p.x() - s * p.y(), s * p.x() + c * p.y(), 2.0};
      result.points.push_back(q);
    }
  EXPECT_NEAR(PartLengthMm(result), 20.0, 1e-9);
  Recipe recipe;
  recipe.name = "big";
  recipe.part_length_mm = LengthRange{25, 30};
  EXPECT_EQ(WrongPartReason(recipe, result),
            "wrong part: its length is 20.00 mm, recipe 'big' expects 25.00-30.00 mm (part_length_mm); check the part "
            "in the nest and the active recipe");
  recipe.part_length_mm = LengthRange{19, 21};
  EXPECT_EQ(WrongPartReason(recipe, result), std::nullopt);
}

}  // namespace
}  // namespace flatscan
