#include "flatscan/simulation/dataset.h"

#include <cmath>
#include <fstream>

#include <Eigen/Geometry>
#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "flatscan/io/atomic_output.h"
#include "flatscan/io/pairs_csv.h"
#include "flatscan/io/rig_file.h"
#include "flatscan/simulation/coverage_renderer.h"
#include "flatscan/simulation/image_defects.h"
#include "flatscan/simulation/image_formation.h"
#include "flatscan/simulation/truth_file.h"
#include "flatscan/util/error.h"
#include "flatscan/util/sha256.h"

namespace flatscan {
namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr double kImageMarginPx = 24.0;  // parts and boards stay this far from the border

// The camera whose every pixel is divided into n x n sub-pixels (optics.blur_subpixels):
// sub-pixel U of row pixel u is U = n u + j, j = 0..n-1, centred at u + (j - (n - 1) / 2) / n.
Camera Subdivided(const Camera& cam, int n) {
  Camera c = cam;
  c.width *= n;
  c.height *= n;
  c.fx *= n;
  c.fy *= n;
  c.cx = n * cam.cx + (n - 1) / 2.0;
  c.cy = n * cam.cy + (n - 1) / 2.0;
  return c;
}

// The camera the radiance is rendered with (docs/simulator.md, "The blur is sampled").
Camera RenderingCamera(const Station& st, RigSide camera) {
  return Subdivided(st.GetCamera(camera), st.scene.optics.blur_subpixels);
}

// Linear radiance (at the rendering camera's resolution) -> blurred, averaged over
// each pixel's sub-pixels, lit (vignetting and the defects' non-uniformity), noisy
// 8-bit image.
cv::Mat1b FinishImage(const Station& st, RigSide camera, cv::Mat1f& radiance, const std::vector<cv::Rect>& regions,
                      uint64_t noise_seed, const ImageDefects& defects = {}) {
  const Camera& cam = st.GetCamera(camera);
  const int side = camera == RigSide::kLeft ? 0 : 1;  // the defects' per-camera index
  const int n = st.scene.optics.blur_subpixels;
  const double sigma0 = st.scene.optics.blur_sigma_px;
  if (defects.f_number > 0) {
    const CameraSpec& lens = side == 0 ? st.scene.left_camera : st.scene.right_camera;
    const double focus_error = defects.focus_error_mm[side];
    BlurRegionsVarying(radiance, [&](const cv::Rect& rect) {
      return DefocusSigma(cam, st.CamFromSupport(camera), lens, sigma0, defects.f_number, focus_error, rect);
    }, regions);
  } else {
    BlurRegions(radiance, n * sigma0, regions);
  }
  if (n > 1) {
    cv::Mat1f pixels;
    cv::resize(radiance, pixels, cv::Size(cam.width, cam.height), 0, 0, cv::INTER_AREA);  // n x n block means
    radiance = pixels;
  }
  const double vignetting = st.scene.lighting.vignetting;
  if (defects.Any())
    cv::multiply(radiance, IlluminationImage(cam.width, cam.height, vignetting, defects, side),
                 radiance);
  else
    cv::multiply(radiance, BacklightImage(cam.width, cam.height, 1.0, vignetting), radiance);
  return QuantizeWithNoise(radiance, st.scene.optics.noise_sigma_grey, noise_seed, defects.shot_noise);
}

std::vector<std::unique_ptr<Occluder>> MarkerOccluders(const Station& st) {
  std::vector<std::unique_ptr<Occluder>> out;
  const double r_in = st.scene.markers.inner_radius_mm, r_out = st.scene.markers.outer_radius_mm;
  for (const Eigen::Vector2d& c : st.markers) {
    std::vector<Eigen::Vector2d> outline;
    for (double sx : {-1.0, 1.0})
      for (double sy : {-1.0, 1.0}) outline.push_back(c + r_out * Eigen::Vector2d(sx, sy));
    out.push_back(std::make_unique<PlanarOccluder>(
        Rigid3d(), [c, r_in, r_out](const Eigen::Vector2d& p) { return AnnulusSdf(p, c, r_in, r_out); }, outline));
  }
  return out;
}

PlanarOccluder SpeckOccluder(const DustSpeck& s) {
  const Eigen::Vector2d c = s.centre_mm;
  const double r = s.radius_mm;
  return PlanarOccluder(Rigid3d(), [c, r](const Eigen::Vector2d& p) { return CircleSdf(p, c, r); },
                        {c + Eigen::Vector2d(-r, -r), c + Eigen::Vector2d(r, -r), c + Eigen::Vector2d(r, r),
                         c + Eigen::Vector2d(-r, r)});
}

void DrawOccluder(const Station& st, RigSide camera, const Occluder& occ, double grey, cv::Mat1f& radiance,
                  std::vector<cv::Rect>& regions) {
  const CoverageTile tile = RenderCoverage(RenderingCamera(st, camera), st.CamFromSupport(camera), occ);
  BlendCoverage(radiance, tile, grey);
  if (!tile.roi.empty()) regions.push_back(tile.roi);
}

void WritePng(const std::filesystem::path& path, const cv::Mat1b& image) {
  WriteFileAtomically(path, [&](const std::filesystem::path& tmp) {
    if (!cv::imwrite(tmp.string(), image, {cv::IMWRITE_PNG_COMPRESSION, 1}))
      ThrowInputError("cannot write image '{}'", path.string());
  });
}

// 3D outline of a part pose, for visibility checks.
std::vector<Eigen::Vector3d> PartOutline(const PartGeometry& g, const Rigid3d& support_from_part) {
  std::vector<Eigen::Vector3d> out;
  for (const Eigen::Vector2d& p : g.SampleOuterOutline(0.5)) {
    out.push_back(support_from_part * g.RimPoint(p));
    out.push_back(support_from_part * g.SheetPoint(p, g.thickness));
  }
  return out;
}

bool ClearOfMarkers(const Station& st, const PartGeometry& g, const Rigid3d& support_from_part) {
  if (!st.scene.dataset.markers_in_part_images) return true;
  const double keep = st.scene.markers.outer_radius_mm + 1.0;
  for (const Eigen::Vector2d& m : st.markers) {
    const Eigen::Vector3d local = support_from_part.Inverse() * Eigen::Vector3d(m.x(), m.y(), 0);
    if (g.OuterSdf(local.head<2>()) < keep) return false;
  }
  return true;
}

}  // namespace

SimulatedPart SampleSimulatedPart(const Station& st, int id, Random& rng) {
  PartGeometry geometry = SamplePartGeometry(st.scene.part, rng);
  return PlaceSimulatedPart(st, id, std::move(geometry), rng);
}

SimulatedPart PlaceSimulatedPart(const Station& st, int id, PartGeometry geometry, Random& rng) {
  SimulatedPart part;
  part.id = id;
  const PartSpec& spec = st.scene.part;
  // Burrs from a seed peeked from `rng` without advancing it: the placement below makes
  // the same random draws with and without them (the same placement unless a burr
  // changes whether a candidate position keeps the part in view).
  // The waviness likewise, from its own seed.
  Random peek = rng;
  const uint64_t part_seed = peek.NextU64();
  part.geometry = WithWaviness(WithBurrs(std::move(geometry), spec, Random::DeriveSeed(part_seed, 0xB0AAull)), spec,
                               Random::DeriveSeed(part_seed, 0x3A7Eull));
  const PartGeometry& g = part.geometry;
  // Nominal placement: random rotation, random position where the whole part is seen
  // by both cameras.
  const double rotation = rng.Uniform(spec.rotation_deg.lo, spec.rotation_deg.hi);
  const PartTruth centred = RestAndPlacePart(g, rotation, Eigen::Vector2d::Zero());
  if (!st.VisibleInBoth(PartOutline(g, centred.support_from_part), kImageMarginPx))
    ThrowInputError("part: a {:.2f} x {:.2f} mm part does not fit in the common field of view of the two cameras "
                    "(about {:.1f} x {:.1f} mm; expected part.width_mm and part.height_mm to fit inside it)",
                    2 * g.half_width, 2 * g.half_height, 2 * st.common_half_size.x(), 2 * st.common_half_size.y());
  Eigen::Vector2d position = Eigen::Vector2d::Zero();
  for (int tries = 0; tries < 200; ++tries) {
    const Eigen::Vector2d candidate(rng.Uniform(-1, 1) * st.common_half_size.x(),
                                    rng.Uniform(-1, 1) * st.common_half_size.y());
    Rigid3d shift;
    shift.translation = Eigen::Vector3d(candidate.x(), candidate.y(), 0);
    const Rigid3d pose = shift * centred.support_from_part;
    if (st.VisibleInBoth(PartOutline(g, pose), kImageMarginPx) && ClearOfMarkers(st, g, pose)) {
      position = candidate;
      break;
    }
  }
  for (int s = 0; s < st.scene.dataset.shots; ++s) {
    PlacedShot shot;
    shot.rotation_deg = rotation;
    shot.position = position;
    if (s > 0) {  // repeated shots: the part is picked up and put back
      shot.rotation_deg += rng.Normal(0.0, spec.jitter_deg);
      shot.position += Eigen::Vector2d(rng.Normal(0.0, spec.jitter_mm), rng.Normal(0.0, spec.jitter_mm));
    }
    shot.truth = RestAndPlacePart(g, shot.rotation_deg, shot.position);
    if (!st.VisibleInBoth(PartOutline(g, shot.truth.support_from_part), kImageMarginPx / 2)) {
      shot.rotation_deg = rotation;  // jitter pushed it out of view: keep the nominal pose
      shot.position = position;
      shot.truth = RestAndPlacePart(g, rotation, position);
    }
    part.shots.push_back(std::move(shot));
  }
  return part;
}

cv::Mat1b RenderPartImage(const Station& st, RigSide camera, const PartGeometry& geometry,
                          const Rigid3d& support_from_part, uint64_t noise_seed, bool with_markers,
                          const ImageDefects& defects) {
  // Refused before any rendering: FinishImage blurs a varying defocus on whole pixels only.
  CheckDefocusOnWholePixels("scene", st.scene.optics.blur_subpixels, defects.f_number > 0);
  const Camera cam = RenderingCamera(st, camera);
  const LightingSpec& light = st.scene.lighting;
  cv::Mat1f radiance(cam.height, cam.width, static_cast<float>(light.backlight_grey));
  std::vector<cv::Rect> regions;
  for (const DustSpeck& s : defects.specks) DrawOccluder(st, camera, SpeckOccluder(s), light.part_grey, radiance, regions);
  Rigid3d pose = support_from_part;
  if (camera == RigSide::kRight) pose.translation += defects.right_motion_mm;
  const CoverageTile part = RenderCoverage(cam, st.CamFromSupport(camera), PartOccluder(geometry, pose));
  BlendCoverage(radiance, part, light.part_grey);
  if (!part.roi.empty()) regions.push_back(part.roi);
  const cv::Rect halo = AddHalo(radiance, part, light.backlight_grey, defects.halo_gain,
                                 st.scene.optics.blur_subpixels * defects.halo_width_px);
  if (!halo.empty()) regions.push_back(halo);
  if (with_markers)
    for (const auto& m : MarkerOccluders(st)) DrawOccluder(st, camera, *m, light.marker_grey, radiance, regions);
  return FinishImage(st, camera, radiance, regions, noise_seed, defects);
}

cv::Mat1b RenderMarkerImage(const Station& st, RigSide camera, uint64_t noise_seed) {
  const Camera cam = RenderingCamera(st, camera);
  cv::Mat1f radiance(cam.height, cam.width, static_cast<float>(st.scene.lighting.backlight_grey));
  std::vector<cv::Rect> regions;
  for (const auto& m : MarkerOccluders(st)) DrawOccluder(st, camera, *m, st.scene.lighting.marker_grey, radiance, regions);
  return FinishImage(st, camera, radiance, regions, noise_seed);
}

cv::Mat1b RenderBoardImage(const Station& st, RigSide camera, const Rigid3d& support_from_board, uint64_t noise_seed) {
  const BoardSpec& b = st.scene.board;
  const int cols = b.inner_corners[0] + 1, rows = b.inner_corners[1] + 1;
  const double s = b.square_mm, m = b.margin_squares * s;
  const double w = cols * s, h = rows * s;
  const Rigid3d board_from_support = support_from_board.Inverse();
  const std::vector<Eigen::Vector2d> outline = {{-m, -m}, {w + m, -m}, {w + m, h + m}, {-m, h + m}};
  const PlanarOccluder board(board_from_support,
                             [=](const Eigen::Vector2d& p) { return RoundedRectSdf(p - Eigen::Vector2d(w / 2, h / 2), w / 2 + m, h / 2 + m, 0.0); },
                             outline);
  const PlanarOccluder squares(board_from_support,
                               [=](const Eigen::Vector2d& p) { return CheckerSdf(p, cols, rows, s); },
                               {{0, 0}, {w, 0}, {w, h}, {0, h}});
  const Camera cam = RenderingCamera(st, camera);
  const LightingSpec& light = st.scene.lighting;
  cv::Mat1f radiance(cam.height, cam.width, static_cast<float>(light.background_grey));
  std::vector<cv::Rect> regions;
  DrawOccluder(st, camera, board, light.board_white_grey, radiance, regions);
  DrawOccluder(st, camera, squares, light.board_black_grey, radiance, regions);
  return FinishImage(st, camera, radiance, regions, noise_seed);
}

std::vector<Rigid3d> SampleBoardPoses(const Station& st, Random& rng) {
  const BoardSpec& b = st.scene.board;
  const double s = b.square_mm, m = b.margin_squares * s;
  const double w = (b.inner_corners[0] + 1) * s, h = (b.inner_corners[1] + 1) * s;
  std::vector<Eigen::Vector3d> corners;
  for (double x : {-m, w + m})
    for (double y : {-m, h + m}) corners.emplace_back(x, y, 0);
  std::vector<Rigid3d> poses;
  for (int i = 0; i < b.poses; ++i) {
    bool found = false;
    for (int tries = 0; tries < 500 && !found; ++tries) {
      const double tilt = b.max_tilt_deg * std::sqrt(rng.Uniform()) * kDeg;
      const double axis_angle = rng.Uniform(0, 2 * M_PI);
      const double spin = rng.Uniform(-15, 15) * kDeg;
      Rigid3d pose;
      pose.rotation = Eigen::AngleAxisd(tilt, Eigen::Vector3d(std::cos(axis_angle), std::sin(axis_angle), 0)).toRotationMatrix() *
                      Eigen::AngleAxisd(spin, Eigen::Vector3d::UnitZ()).toRotationMatrix();
      const Eigen::Vector3d centre(rng.Uniform(-0.5, 0.5) * st.common_half_size.x(),
                                   rng.Uniform(-0.5, 0.5) * st.common_half_size.y(),
                                   -rng.Uniform(b.distance_offset_mm.lo, b.distance_offset_mm.hi));
      pose.translation = centre - pose.rotation * Eigen::Vector3d(w / 2, h / 2, 0);
      std::vector<Eigen::Vector3d> world;
      for (const Eigen::Vector3d& c : corners) world.push_back(pose * c);
      if (st.VisibleInBoth(world, kImageMarginPx)) {
        poses.push_back(pose);
        found = true;
      }
    }
    if (!found)
      ThrowInputError("board: a {:.1f} x {:.1f} mm board (with margin) does not fit in both cameras' views "
                      "(expected board.square_mm * (inner_corners + 1 + 2 * margin_squares) to fit in about {:.1f} x {:.1f} mm)",
                      w + 2 * m, h + 2 * m, 2 * st.common_half_size.x(), 2 * st.common_half_size.y());
  }
  return poses;
}

SimulateSummary SimulateDataset(const SimulateOptions& options, const std::function<void(const std::string&)>& progress) {
  const Station st = BuildStation(options.scene);
  Random rng(options.seed);
  auto report = [&](const std::string& s) {
    if (progress) progress(s);
  };
  // Sample everything first, so errors in the scene surface before any rendering.
  std::vector<Rigid3d> board_poses;
  if (options.calibration_images) board_poses = SampleBoardPoses(st, rng);
  std::vector<SimulatedPart> parts;
  for (int i = 0; i < st.scene.dataset.parts; ++i) parts.push_back(SampleSimulatedPart(st, i, rng));

  StagedDirectory dir(options.output_dir, options.replace_any_folder);
  SimulateSummary summary;
  summary.output_dir = options.output_dir;
  const std::filesystem::path root = dir.path();
  auto add = [&](const std::string& rel) { summary.files.push_back(rel); };
  uint64_t image_index = 0;
  auto next_seed = [&] { return Random::DeriveSeed(options.seed ^ 0x5EEDF00Dull, image_index++); };

  WriteRigFile(root / "rig.yml", st.rig);
  add("rig.yml");
  WritePlaneFile(root / "plane_true.yml", st.plane, Sha256HexOfFile(root / "rig.yml"));
  add("plane_true.yml");
  nlohmann::json scene_json = SceneToJson(st.scene);
  WriteTextFileAtomically(root / "scene.json", scene_json.dump(2) + "\n");
  add("scene.json");

  nlohmann::json board_json = {{"pattern", "chessboard"},
                               {"inner_corners", {st.scene.board.inner_corners[0], st.scene.board.inner_corners[1]}},
                               {"square_mm", st.scene.board.square_mm},
                               {"views", nlohmann::json::array()}};
  if (options.calibration_images) {
    std::filesystem::create_directories(root / "calib");
    for (size_t i = 0; i < board_poses.size(); ++i) {
      report(fmt::format("calibration pair {}/{}", i + 1, board_poses.size()));
      const std::string l = fmt::format("calib/left_{:02d}.png", i), r = fmt::format("calib/right_{:02d}.png", i);
      WritePng(root / l, RenderBoardImage(st, RigSide::kLeft, board_poses[i], next_seed()));
      WritePng(root / r, RenderBoardImage(st, RigSide::kRight, board_poses[i], next_seed()));
      add(l);
      add(r);
      board_json["views"].push_back({{"left", l.substr(6)}, {"right", r.substr(6)},
                                     {"cam1_from_board", PoseToJson(st.cam1_from_support * board_poses[i])}});
    }
    WriteTextFileAtomically(root / "calib" / "board.json", board_json.dump(2) + "\n");
    add("calib/board.json");
    summary.calibration_pairs = static_cast<int>(board_poses.size());
  }
  if (options.marker_images) {
    report("marker pair");
    std::filesystem::create_directories(root / "markers");
    WritePng(root / "markers/left.png", RenderMarkerImage(st, RigSide::kLeft, next_seed()));
    WritePng(root / "markers/right.png", RenderMarkerImage(st, RigSide::kRight, next_seed()));
    add("markers/left.png");
    add("markers/right.png");
  }

  nlohmann::json truth_parts = nlohmann::json::array();
  std::vector<PairEntry> pairs;
  if (!parts.empty()) std::filesystem::create_directories(root / "parts");
  for (const SimulatedPart& part : parts) {
    std::vector<ShotFiles> files;
    for (size_t s = 0; s < part.shots.size(); ++s) {
      report(fmt::format("part {}/{} shot {}/{}", part.id + 1, parts.size(), s + 1, part.shots.size()));
      const PlacedShot& shot = part.shots[s];
      const std::string stem = part.shots.size() > 1 ? fmt::format("parts/part_{:03d}_shot_{:02d}", part.id, s)
                                                     : fmt::format("parts/part_{:03d}", part.id);
      files.push_back({stem.substr(6), stem + "_left.png", stem + "_right.png"});
      const bool markers = st.scene.dataset.markers_in_part_images;
      const Rigid3d& pose = shot.truth.support_from_part;
      const ImageDefects defects = SampleImageDefects(st.scene.image_effects, part.geometry, pose,
                                                      Random::DeriveSeed(options.seed ^ 0xDEFEC75ull, summary.part_pairs));
      WritePng(root / files.back().left, RenderPartImage(st, RigSide::kLeft, part.geometry, pose, next_seed(), markers, defects));
      WritePng(root / files.back().right, RenderPartImage(st, RigSide::kRight, part.geometry, pose, next_seed(), markers, defects));
      add(files.back().left);
      add(files.back().right);
      pairs.push_back({files.back().id, files.back().left, files.back().right, part.geometry.SideHeight(), {}});
      ++summary.part_pairs;
    }
    truth_parts.push_back(PartTruthJson(st, fmt::format("part_{:03d}", part.id), part, files));
  }
  summary.parts = static_cast<int>(parts.size());
  if (!parts.empty()) {
    WriteTextFileAtomically(root / "pairs.csv", PairsCsvText(pairs));
    add("pairs.csv");
  }
  WriteTextFileAtomically(root / "truth.json", TruthFileJson(st, options.seed, std::move(truth_parts)).dump(1) + "\n");
  add("truth.json");
  dir.Commit();
  return summary;
}

}  // namespace flatscan
