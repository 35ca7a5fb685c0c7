#pragma once
// Everything the simulator ("digital twin") needs to render an inspection station:
// the two cameras, their rig, the support plane, lighting and optics, the calibration
// board, the plane markers and the population of parts. Presets give defaults; a
// scene file (YAML or JSON, see docs/simulator.md) overrides any field.
//
// Ranges are [lo, hi] pairs sampled uniformly per part; a scalar in a scene file
// means lo = hi. Units: mm, degrees, pixels, grey levels (8-bit).
#include <array>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "flatscan/geometry/side_faces.h"

namespace flatscan {

struct Range {
  double lo = 0.0;
  double hi = 0.0;
};

struct CameraSpec {
  int width = 2592;
  int height = 1944;
  double pixel_size_um = 2.2;
  double focal_length_mm = 25.0;
  std::vector<double> distortion = {-0.08, 0.12, 0.0002, -0.0001, 0.0};  // k1 k2 p1 p2 k3 [k4 k5 k6]
  std::array<double, 2> principal_point_offset_px = {0.0, 0.0};
};

struct RigSpec {
  double baseline_mm = 60.0;
  double working_distance_mm = 200.0;  // camera centres' height above the plane centre
  std::array<double, 2> roll_deg = {0.0, 0.0};  // rotation of each camera about its axis
  // Each camera aims at the plane centre; this offsets the aim point of camera 2
  // (mm, in the plane) so the true rig is not perfectly symmetric.
  std::array<double, 2> right_aim_offset_mm = {0.0, 0.0};
};

struct PlaneSpec {
  double tilt_deg = 0.0;          // angle between the plane normal and the rig's axis
  double tilt_azimuth_deg = 0.0;  // direction of the tilt axis in the plane
};

struct LightingSpec {
  double backlight_grey = 220.0;
  double vignetting = 0.08;  // fractional fall-off of the backlight at the image corners
  double part_grey = 20.0;
  double marker_grey = 15.0;
  double board_white_grey = 200.0;
  double board_black_grey = 35.0;
  double background_grey = 60.0;  // behind the board in front-lit calibration images
};

struct OpticsSpec {
  double blur_sigma_px = 1.0;       // Gaussian lens PSF
  // The blur rendered on n x n sub-pixels per pixel, then averaged over each pixel (the
  // lens blurs the light before the pixel integrates it). 1: a Gaussian sampled at whole
  // pixels, which moves an edge with its pixel phase below about 1 px of blur
  // (docs/simulator.md, "The blur is sampled"); 3: within 0.0005 px.
  int blur_subpixels = 1;
  double noise_sigma_grey = 2.0;    // Gaussian sensor noise
};

// Defects of real backlit images, drawn per part pair (docs/simulator.md, "Image
// defects"). Every one is off by default (an ideal image); `flatscan evaluate
// --robustness` turns each on in turn within its realistic range
// (evaluation/robustness_study.h). Part images only: the calibration images stay ideal.
struct ImageEffectsSpec {
  // Backlight non-uniformity: a linear gradient in a random direction per camera, the
  // brightness factor 1 + g (r . u), r the offset from the image centre over the half
  // diagonal, u a unit direction, g drawn from this range (+-g at the corners).
  Range backlight_gradient = {0.0, 0.0};
  // Camera 2's exposure relative to camera 1's (a slow drift of one exposure or gain):
  // its image is (1 + e) times as bright, e drawn from this range.
  Range exposure_drift = {0.0, 0.0};
  // Dark specks of dust on the backlight (opaque discs on the support plane, seen by
  // both cameras): their count, diameters, and the share placed touching the part's outline.
  std::array<int, 2> dust_specks = {0, 0};
  Range dust_diameter_um = {20.0, 200.0};
  double dust_touching_fraction = 0.5;
  // Bright halo around the silhouette (backlight reflected by the metal side faces): the
  // backlight outside the part is brightened by gain * exp(-d / width), d the distance to
  // the silhouette in pixels; gain drawn from this range (0: a matte or anodised part).
  Range halo_gain = {0.0, 0.0};
  double halo_width_px = 2.0;
  // Photon (shot) noise: the noise variance is noise_sigma_grey^2 + shot_noise * I
  // (grey levels^2 per grey level of signal I; a sensor of 6000 electrons full well
  // digitised to 255 levels gives about 0.04).
  double shot_noise = 0.0;
  // The part moves between the two exposures (it is still settling or vibrating): in
  // camera 2's image it is displaced by this many micrometres, rigidly, in a random 3D
  // direction.
  Range motion_um = {0.0, 0.0};
  // Depth of field: the lenses at aperture f/N (N drawn from f_number; 0: no defocus),
  // each focused focus_error_mm (drawn per camera) beyond the support plane's depth at
  // its principal point (the image centre). The blur then varies across the part with the plane's depth
  // (simulation/image_defects.h, DefocusSigma).
  Range f_number = {0.0, 0.0};
  Range focus_error_mm = {0.0, 0.0};
};

struct MarkerSpec {
  double inner_radius_mm = 1.0;   // transparent disc
  double outer_radius_mm = 2.5;   // black ring from inner to outer radius
  // Marker centres at +-inset * the half-size of the largest centred rectangle in the
  // common field of view.
  double inset = 0.8;
};

// Chessboard pairs that the demo and `evaluate` render to calibrate a simulated station:
// as many as OpenCV's stereo_calib sample has (left01..left14), so that our calibration
// figures compare with the sample's.
constexpr int kDefaultCalibrationPoses = 14;

struct BoardSpec {
  std::array<int, 2> inner_corners = {9, 6};  // columns x rows of inner corners
  double square_mm = 2.5;
  double margin_squares = 1.0;  // white border around the squares
  int poses = 12;
  double max_tilt_deg = 25.0;
  Range distance_offset_mm = {-8.0, 8.0};  // board distance change from the working distance
};

struct PartSpec {
  Range width_mm = {12.0, 20.0};
  Range height_mm = {8.0, 18.0};
  Range corner_radius_mm = {0.3, 1.5};
  std::array<int, 2> holes = {0, 2};  // count range
  Range hole_radius_mm = {0.4, 1.2};
  std::array<int, 2> notches = {0, 2};
  Range notch_size_mm = {0.8, 2.0};
  Range thickness_mm = {0.1, 0.3};
  Range wall_height_mm = {0.0, 0.0};  // folded walls (0: none)
  // How the side faces stand: local (perpendicular to the local sheet, as a cut and
  // then warped sheet's do) or centre (along the sheet's normal at the part's centre,
  // the model of earlier versions: exact for a flat sheet only).
  SideFaceModel side_faces = SideFaceModel::kLocalNormal;
  Range bending_mm = {-0.15, 0.15};   // sag at the ends of each axis
  Range twist_mm = {-0.15, 0.15};     // corner height of the x*y term
  double random_warp_mm = 0.02;       // amplitude of each random 2nd/3rd-order term
  // If hi > 0: the warp drawn above is scaled so the part's true flatness_mm is uniform
  // in [lo, hi] (a lot with a known spread around the tolerance). Burrs (below) are
  // added afterwards: one under the rim may lift the part above its drawn flatness (the
  // truth follows it).
  Range flatness_mm = {0.0, 0.0};
  // Burrs left by the cutting (simulation/part_model.h, Burr): their count, how far each
  // stands out of the outline (or below the rim), and the share under the rim.
  std::array<int, 2> burrs = {0, 0};
  Range burr_size_um = {20.0, 50.0};
  double burr_under_rim_fraction = 0.5;
  // Waviness of the sheet (a plane wave across it, simulation/part_model.h): its
  // amplitude (0: none) and wavelength, added to the warp (not scaled by flatness_mm).
  Range waviness_um = {0.0, 0.0};
  Range waviness_wavelength_mm = {1.5, 4.0};
  Range rotation_deg = {0.0, 360.0};
  double jitter_mm = 0.1;             // placement jitter between repeated shots
  double jitter_deg = 0.2;
};

struct DatasetSpec {
  int parts = 3;
  int shots = 1;
  bool markers_in_part_images = false;
};

struct SceneConfig {
  std::string name = "paper";
  CameraSpec left_camera;
  CameraSpec right_camera;
  RigSpec rig;
  PlaneSpec plane;
  LightingSpec lighting;
  OpticsSpec optics;
  ImageEffectsSpec image_effects;
  MarkerSpec markers;
  BoardSpec board;
  PartSpec part;
  DatasetSpec dataset;
};

// Names of the built-in presets ("paper": docs/design.md section 4; "compact": a 1920x1200,
// 12 mm lens, 40 mm baseline rig with stronger distortion).
std::vector<std::string> ScenePresetNames();
// Throws InputError "unknown preset 'x' (expected one of: paper, compact)".
SceneConfig ScenePreset(const std::string& name);

// Applies a scene document to `base`. Keys mirror the struct fields (see
// docs/simulator.md); `camera` sets both cameras, `left_camera`/`right_camera` one.
// Errors name `source` (the file) and the field path, e.g.
//   "scene.yml: optics.noise_sigma_grey must be >= 0, got -1".
SceneConfig ApplySceneDocument(SceneConfig base, const nlohmann::json& doc,
                               const std::string& source);
// Reads a YAML (OpenCV FileStorage or plain block YAML) or JSON scene file; the
// document may name a base preset with `preset: NAME` (default paper).
SceneConfig LoadSceneFile(const std::filesystem::path& path);

// A varying defocus (image_effects.f_number) is blurred on whole pixels only: throws
// InputError "<source>: optics.blur_subpixels 3 with image_effects.f_number: ..." when a
// scene asks for both. Called when a scene is read and again at render time (for the
// effects a study sets rather than a file).
void CheckDefocusOnWholePixels(const std::string& source, int blur_subpixels, bool defocus);

// The fully resolved scene, for writing next to a dataset (scene.json).
nlohmann::json SceneToJson(const SceneConfig& scene);

}  // namespace flatscan
