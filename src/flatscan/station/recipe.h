#pragma once
// Recipes: one YAML file per part type, holding everything a station needs to measure
// and judge that part, so that an operator never types a thickness or a tolerance.
//
//   name: shield-20x15            # required; [A-Za-z0-9_.-], 1-64 characters
//   thickness_mm: 0.2             # required; height of the part's side face, (0, 5] mm
//   tolerance_mm: 0.1             # required; flatness tolerance, (0, 5] mm
//   rig: rig.yml                  # required; relative to the recipe's folder (or absolute)
//   plane: plane.yml              # required; calibrated with that rig
//   guard_band_mm: 0.01           # optional (0): marginal band, flatness/verdict.h
//   rig_sha256: <64 hex digits>   # optional: pin the rig file's bytes
//   plane_sha256: <64 hex digits> # optional: pin the plane file's bytes
//   part_length_mm: [15, 25]      # optional: plausible length of the part's footprint
//                                 # (its extent along its longest axis); a part outside
//                                 # it is "not measured" (the wrong part in the nest)
//   side_faces: local             # optional: local | centre | support (geometry/side_faces.h)
//   exposure:                     # optional: what the images must show (ImageAcceptance)
//     min_backlight_grey: 60      #   backlight grey level, 1-255
//     max_saturated_fraction: 0.25  # fraction of the backlight at 255, [0, 1]
//     max_blur_sigma_px: 2.0      #   the edges' blur, (0, 6] px
//   camera:                       # optional: set on both cameras (--source cameras:..)
//     exposure_us: 800            #   GenICam ExposureTime, [1, 10000000] us
//     gain_db: 0                  #   GenICam Gain, [0, 48] dB; both leave the camera's
//                                 #   own setting when absent
//   archive:                      # optional: which images the station keeps (--archive)
//     keep_pass_every: 100        #   one "pass" pair in N (0: none); every fail and
//                                 #   every "not measured" pair is kept
//     quota_mb: 2000              #   disk quota of the archive; the oldest kept pass
//                                 #   pairs go first
//     fail_retention_days: 90     #   a fail or not-measured pair is never evicted
//                                 #   within this time
// Unknown keys are refused (a misspelt `tolerance_mm` would judge with a default). The
// recipe's SHA-256 (of the file's bytes) goes into every record it produced.
#include <filesystem>
#include <optional>
#include <string>

#include "flatscan/calibration/stereo_rig.h"
#include "flatscan/flatness/verdict.h"
#include "flatscan/inspection/inspect_part.h"
#include "flatscan/inspection/inspection_record.h"
#include "flatscan/io/rig_file.h"

namespace flatscan {

struct ArchivePolicy {
  int keep_pass_every = 100;         // one "pass" pair in N; 0 keeps none
  double quota_mb = 2000;            // about 1000 pairs of 5 MP PNGs
  double fail_retention_days = 90;   // a quarter: long enough for a customer complaint
};

// What the cameras are set to for this part (a camera source applies it when the recipe
// becomes active; file sources ignore it).
struct CameraSettings {
  std::optional<double> exposure_us, gain_db;
};

struct LengthRange {
  double min_mm = 0, max_mm = 0;
};

struct Recipe {
  std::string name;
  std::filesystem::path file;        // the recipe file, as given
  std::string sha256;                // of the recipe file's bytes
  std::filesystem::path rig_file, plane_file;  // resolved against the recipe's folder
  std::string rig_sha256_pin, plane_sha256_pin;  // empty when not pinned
  FlatnessSpec spec;
  InspectionParams params;           // thickness, side faces, exposure
  std::optional<LengthRange> part_length_mm;
  ArchivePolicy archive;
  CameraSettings camera;
};

// Parses and checks a recipe file's keys and values (not the files it names). Throws
// InputError "<file>: <key>: expected ..., found ..." for a missing, misspelt or bad key.
Recipe ReadRecipe(const std::filesystem::path& path);

// A recipe with its rig and plane read and checked: the files exist and parse, their
// bytes match the pinned hashes, and the plane was calibrated with this rig (a plane
// file that does not say which rig is accepted with a warning, as `inspect` does).
struct LoadedRecipe {
  Recipe recipe;
  StereoRig rig;
  SupportPlane plane;
  InspectionInputs inputs;  // rig and plane files, their hashes and plane_rig
};
LoadedRecipe LoadRecipe(const std::filesystem::path& path);

// What a station does with the recipe, for `flatscan recipe check` (several lines).
std::string DescribeRecipe(const LoadedRecipe& loaded);

// The footprint's length: the extent of the measured rim points along their longest
// principal axis, mm.
double PartLengthMm(const InspectionResult& result);

// Why a measured part is not the recipe's part (its length outside part_length_mm), or
// nullopt when it is (or the recipe gives no range).
std::optional<std::string> WrongPartReason(const Recipe& recipe, const InspectionResult& result);

}  // namespace flatscan
