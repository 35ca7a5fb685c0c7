#pragma once
// Options that several commands share: one name, one default and one help text each.
#include <cstdint>
#include <filesystem>
#include <limits>
#include <string>

#include <CLI/CLI.hpp>

#include "flatscan/exe/number_checks.h"
#include "flatscan/flatness/verdict.h"
#include "flatscan/geometry/side_faces.h"
#include "flatscan/simulation/scene_config.h"
#include "flatscan/util/error.h"

namespace flatscan {

// -o,--output: what the command writes (`what`, e.g. "rig file to write").
inline CLI::Option* AddOutputOption(CLI::App* sub, std::string* path, const std::string& what) {
  return sub->add_option("-o,--output", *path, what);
}

// --force: an output folder that exists is replaced only if flatscan wrote it (it holds
// StagedDirectory::kOutputMarker), or with this flag.
inline CLI::Option* AddForceFlag(CLI::App* sub, bool* force) {
  return sub->add_flag("--force", *force,
                       "replace the output folder even if flatscan did not write it (without: only a folder with "
                       "flatscan's .flatscan-output marker is replaced)");
}

// --seed: every random choice derives from it.
inline CLI::Option* AddSeedOption(CLI::App* sub, uint64_t* seed) {
  return sub->add_option("--seed", *seed, "random seed (the same seed gives the same result)")
      ->default_val(*seed)
      ->check(IntegerIn(0, std::numeric_limits<long long>::max()));
}

// --tolerance: the flatness tolerance (flatness/verdict.h owns its default).
inline CLI::Option* AddToleranceOption(CLI::App* sub, double* tolerance_mm) {
  *tolerance_mm = FlatnessSpec::kDefaultToleranceMm;
  return sub->add_option("--tolerance", *tolerance_mm, "flatness tolerance, mm: a part fails above it")
      ->default_val(*tolerance_mm)
      ->check(PositiveReal(10));
}

// --no-thickness-correction: triangulate as if the sheet had no thickness.
inline CLI::Option* AddNoThicknessCorrectionFlag(CLI::App* sub, bool* no_correction) {
  return sub->add_flag("--no-thickness-correction", *no_correction,
                       "triangulate the silhouettes as if the sheet had no thickness (to see what the correction "
                       "removes)");
}

// --side-faces: the measurement's model of the side faces (geometry/side_faces.h).
inline CLI::Option* AddSideFacesOption(CLI::App* sub, SideFaceModel* model) {
  return sub
      ->add_option_function<std::string>(
          "--side-faces", [model](const std::string& name) { *model = ParseSideFaceModel(name); },
          "how the measurement takes the side faces: local (perpendicular to the sheet at each rim point, the "
          "physics of a cut sheet), centre (one direction: the sheet's normal at the part's centre, earlier "
          "versions) or support (the support plane's normal); a diagnostic")
      ->check(CLI::IsMember({"local", "centre", "support"}))
      ->default_str(SideFaceModelName(*model));
}

// --blur: the lens blur if known. Sharp optics give 0.5-1.5 px; beyond 5 px the cameras are
// out of focus, and the band the edges are searched in grows with the blur.
inline CLI::Option* AddBlurOption(CLI::App* sub, double* blur_sigma_px) {
  return sub->add_option("--blur", *blur_sigma_px, "lens blur sigma in px if known (0: estimated from the image)")
      ->default_val(*blur_sigma_px)
      ->check(RealIn(0, 5));
}

// --preset / --scene: the simulated station.
inline void AddSceneOptions(CLI::App* sub, std::string* preset, std::string* scene_file) {
  auto* p = sub->add_option("--preset", *preset, "built-in scene: paper (docs/design.md section 4) or compact")
                ->default_val(*preset);
  sub->add_option("--scene", *scene_file, "scene file (YAML or JSON) overriding any parameter; see docs/simulator.md")
      ->excludes(p);
}

// --calib-poses: chessboard pairs rendered for the rig calibration (the simulation's
// default, kDefaultCalibrationPoses).
inline CLI::Option* AddCalibrationPosesOption(CLI::App* sub, int* poses) {
  *poses = kDefaultCalibrationPoses;
  return sub->add_option("--calib-poses", *poses, "chessboard pairs for the rig calibration")
      ->default_val(*poses)
      ->check(IntegerIn(3, 200));
}

inline SceneConfig LoadScene(const std::string& preset, const std::string& scene_file) {
  return scene_file.empty() ? ScenePreset(preset) : LoadSceneFile(scene_file);
}

}  // namespace flatscan
