#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <optional>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "flatscan/evaluation/calibration_share.h"
#include "flatscan/evaluation/flatness_study.h"
#include "flatscan/evaluation/gauge_twin.h"
#include "flatscan/evaluation/study_report.h"
#include "flatscan/evaluation/uncertainty_validation.h"
#include "flatscan/exe/commands.h"
#include "flatscan/exe/options.h"
#include "flatscan/io/atomic_output.h"
#include "flatscan/io/image_io.h"
#include "flatscan/report/html_page.h"
#include "flatscan/simulation/scene_config.h"
#include "flatscan/util/error.h"

namespace flatscan {
namespace {

// Progress lines on stderr: about every 5% and at the end.
StudyProgress ProgressLogger(const std::string& what) {
  return [what, start = std::chrono::steady_clock::now()](int done, int total, const PartMeasurement& m) {
    const int step = std::max(1, total / 20);
    if (done % step != 0 && done != total) return;
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    spdlog::info("{} {}/{} ({:.0f} s, about {:.0f} s left); last: {} true {:.4f} mm, {}", what, done, total, s,
                 s / done * (total - done), m.id, m.true_flatness_mm,
                 m.measured ? fmt::format("measured {:.4f} mm", m.values.flatness_mm) : "not measured");
  };
}

// flatscan evaluate: the paper's Tables 1 and 2 on a simulated station.
class EvaluateCommand : public Command {
 public:
  void Register(CLI::App& app) override {
    sub_ = app.add_subcommand("evaluate",
                              "Reproduce the paper's Table 1 (--repeat) and Table 2 (--batch N) on a simulated station "
                              "calibrated from its own simulated images; markdown, JSON and PNG charts.");
    sub_->footer("Example: flatscan evaluate --repeat --batch 1000 -o eval-paper\n"
                 "         flatscan evaluate --scene my_rig.yml --batch 200 -o eval-my-rig");
    AddSceneOptions(sub_, &preset_, &scene_file_);
    AddOutputOption(sub_, &output_, "output folder (replaced if it exists)")->default_val(output_);
    AddForceFlag(sub_, &force_);
    AddSeedOption(sub_, &seed_);
    sub_->add_flag("--repeat", repeat_, "Table 1: one part shot --shots times");
    Fills(sub_->add_option("--shots", repeat_options_.shots, "shots of the repeat study")
              ->default_val(repeat_options_.shots)
              ->check(IntegerIn(2, 100000)),
          "repeat.shots");
    Fills(sub_->add_option("--structured-light-shots", structured_light_shots_,
                           "measure the structured-light peer (Table 1's row) on the first N shots of the repeat study "
                           "(0: none)")
              ->default_val(structured_light_shots_)
              ->check(IntegerIn(0, 100000)),
          "repeat.structured_light_shots");
    Fills(sub_->add_option("--true-flatness", repeat_options_.flatness_mm, "true flatness of the repeat study's part, mm")
              ->default_val(repeat_options_.flatness_mm)
              ->check(PositiveReal(5)),
          "repeat.flatness_mm");
    Fills(sub_->add_option("--batch", batch_options_.parts, "Table 2: number of different parts")->check(IntegerIn(1, 1000000)),
          "batch.parts");
    Fills(AddToleranceOption(sub_, &tolerance_), "tolerance_mm");
    Fills(sub_->add_option("--beyond", batch_options_.lot.beyond_fraction, "fraction of the lot beyond the tolerance")
              ->default_val(batch_options_.lot.beyond_fraction)
              ->check(RealIn(0.01, 0.99)),
          "lot.beyond_fraction");
    Fills(sub_->add_option("--lot-spread", batch_options_.lot.log_spread,
                           "standard deviation of ln(flatness) in the lot (smaller: more parts near the tolerance)")
              ->default_val(batch_options_.lot.log_spread)
              ->check(RealIn(0.05, 3)),
          "lot.log_spread");
    Fills(sub_->add_option("--rotation-step", rotation_options_.step_deg,
                           "coverage against rotation: parts turned 0 to --rotation-max degrees to the camera baseline "
                           "in steps of this many degrees")
              ->check(RealIn(0.1, 360)),
          "rotation.step_deg");
    Fills(sub_->add_option("--rotation-max", rotation_options_.max_deg, "largest rotation of the rotation study, degrees")
              ->default_val(rotation_options_.max_deg)
              ->check(RealIn(0, 360)),
          "rotation.max_deg");
    Fills(sub_->add_option("--rotation-parts", rotation_options_.parts, "parts of the rotation study (the same at every angle)")
              ->default_val(rotation_options_.parts)
              ->check(IntegerIn(1, 100000)),
          "rotation.parts");
    AddCalibrationPosesOption(sub_, &calib_poses_);
    Fills(sub_->add_option("--calibrations", calibrations_,
                           "validate each part's uncertainty_mm on the batch study repeated with this many stations, "
                           "each calibrated from its own images (seeds --seed, --seed + 1, ...)")
              ->check(IntegerIn(1, 100))
              ->default_val(calibrations_),
          "calibrations");
    sub_->add_option("--distortion-model", distortion_model_,
                     "the distortion coefficients each station's rig calibration fits (calibrate-rig --model): standard "
                     "(k1 k2 p1 p2 k3), rational or two-radial (k3 held at 0: narrow-field lenses)")
        ->default_val(distortion_model_);
    Fills(sub_->add_option("--robustness", robustness_options_.parts,
                           "robustness to the defects of real images: this many parts, rendered ideal and with each "
                           "image effect in turn (backlight non-uniformity, exposure drift, dust, halo, shot noise, "
                           "motion between the exposures)")
              ->check(IntegerIn(1, 100000)),
          "robustness.parts");
    Fills(sub_->add_option("--gauge", gauge_options_.parts,
                           "the gauge studies on the twin (docs/gauge.md): gauge R&R of this many parts drawn like "
                           "the lot, --gauge-trials placements each, on --gauge-stations stations; type 1 (one part, "
                           "50 placements) and linearity (5 parts over 0.2-1.8 x the tolerance, 10 placements each)")
              ->check(IntegerIn(5, 1000)),
          "gauge.parts");
    Fills(sub_->add_option("--gauge-trials", gauge_options_.trials, "placements of each part in the gauge R&R")
              ->check(IntegerIn(2, 100))
              ->default_val(gauge_options_.trials),
          "gauge.trials");
    Fills(sub_->add_option("--gauge-stations", gauge_stations_,
                           "stations standing as the gauge R&R's appraisers, each calibrated from its own images "
                           "(seeds --seed, --seed + 1, ...); 1: parts x trials")
              ->check(IntegerIn(1, 10))
              ->default_val(gauge_stations_),
          "gauge.stations");
    sub_->add_option("--save-worst", save_worst_,
                     "write the image pairs and truth of the N batch parts (OUT/worst/) and repeat shots "
                     "(OUT/worst_repeat/) with the largest |error| (and any not measured), to look at with `flatscan inspect`")
        ->default_val(0)->check(IntegerIn(0, 1000));
    AddNoThicknessCorrectionFlag(sub_, &no_correction_);
    AddSideFacesOption(sub_, &side_faces_);
    sub_->add_flag("--true-calibration", true_calibration_,
                   "diagnostic: inspect with the simulator's true rig and plane instead of the calibrated ones, to "
                   "separate the calibration's share of the error from the inspection's");
  }

  int Run() override {
    const bool rotation = rotation_options_.step_deg > 0;
    if (!repeat_ && batch_options_.parts <= 0 && !rotation && robustness_options_.parts <= 0 && gauge_options_.parts <= 0)
      ThrowInputError("evaluate: expected --repeat, --batch N, --rotation-step DEG, --robustness N and/or --gauge N "
                      "(for example: flatscan evaluate --repeat --batch 1000)");
    DistortionModel distortion_model = DistortionModel::kStandard;
    try {
      distortion_model = ParseDistortionModel(distortion_model_);
    } catch (const InputError& e) {
      throw InputError("--distortion-model", e.what());
    }
    if (calibrations_ > 1 && batch_options_.parts <= 0)
      ThrowInputError("evaluate: --calibrations {} validates the batch study's uncertainties: give --batch N too",
                      calibrations_);
    if (batch_options_.parts > 0) CheckLotSpec(batch_options_.lot, tolerance_);
    SceneConfig scene = LoadScene(preset_, scene_file_);
    scene.board.poses = calib_poses_;
    rotation_options_.lot = batch_options_.lot;
    robustness_options_.lot = batch_options_.lot;
    gauge_options_.lot = batch_options_.lot;
    for (StudyOptions* o : {static_cast<StudyOptions*>(&repeat_options_), static_cast<StudyOptions*>(&batch_options_),
                            static_cast<StudyOptions*>(&rotation_options_), static_cast<StudyOptions*>(&robustness_options_),
                            static_cast<StudyOptions*>(&gauge_options_)}) {
      o->tolerance_mm = tolerance_;
      o->seed = seed_;
      o->inspection.thickness_correction = !no_correction_;
      o->inspection.side_faces = side_faces_;
    }
    const auto start = std::chrono::steady_clock::now();
    StagedDirectory dir(output_, force_);
    const std::filesystem::path root = dir.path();
    spdlog::info("simulating and calibrating the station '{}'", scene.name);
    // A station calibrated from its own simulated images (or, diagnostic, the truth).
    auto make_station = [&](uint64_t seed, const std::filesystem::path& dir) {
      CalibratedStation s =
          SimulateAndCalibrateStation(scene, seed, dir, [](const std::string& line) { spdlog::info("rendering {}", line); },
                                      distortion_model);
      if (true_calibration_) {
        s.rig_report.rig = s.truth.rig;
        s.plane_report.plane = s.truth.plane;
      }
      return s;
    };
    const CalibratedStation station = make_station(seed_, root / "station");
    std::string md = fmt::format("## flatscan evaluate: scene '{}', seed {}, side faces rendered {} and measured {}{}{}\n\n",
                                 scene.name, seed_, SideFaceModelName(scene.part.side_faces),
                                 SideFaceModelName(side_faces_), no_correction_ ? ", thickness correction OFF" : "",
                                 true_calibration_ ? ", TRUE rig and plane (diagnostic, not a calibrated station)" : "");
    md += CalibrationMarkdown(station) + "\n";
    nlohmann::json json = {{"scene", SceneToJson(scene)}, {"seed", seed_}, {"thickness_correction", !no_correction_},
                           {"side_faces", SideFaceModelName(side_faces_)},
                           {"true_calibration", true_calibration_},
                           {"calibration", CalibrationJson(station)}};
    std::cout << md << std::flush;
    std::string html = MarkdownToHtml(md);  // report.html's body: the same text, the charts inside
    // Each study's section: on the terminal as it completes, in report.md, report.html and the JSON.
    auto add_section = [&](const char* key, const std::string& markdown, nlohmann::json section) {
      std::cout << markdown << "\n" << std::flush;
      md += markdown + "\n";
      html += MarkdownToHtml(markdown);
      json[key] = std::move(section);
    };
    // A chart: a PNG file beside report.md, and inside report.html after its section.
    auto add_chart = [&](const std::string& name, const cv::Mat& chart) {
      const std::filesystem::path file = root / name;
      WriteImage(file.string(), chart);
      std::ifstream in(file, std::ios::binary);
      const std::string png((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
      html += fmt::format("<p><img alt=\"{0}\" src=\"{1}\"><br><span class=\"note\">{0}</span></p>\n", name,
                          DataUri("image/png", png));
    };
    if (repeat_) {
      const RepeatStudy study = RunRepeatStudy(station, repeat_options_, ProgressLogger("repeat: shot"));
      std::optional<StructuredLightStudy> structured_light;
      if (structured_light_shots_ > 0) {
        std::vector<ShotJob> jobs = RepeatJobs(station.truth, repeat_options_);
        jobs.resize(std::min<size_t>(jobs.size(), structured_light_shots_));
        spdlog::info("repeat: the structured-light peer on the first {} shots", jobs.size());
        structured_light = RunStructuredLightStudy(station.truth, jobs);
      }
      const StructuredLightStudy* peer = structured_light ? &*structured_light : nullptr;
      add_section("repeat", RepeatMarkdown(study, repeat_options_, peer), RepeatJson(study, repeat_options_, peer));
      add_chart("repeat_shots.png", RepeatShotsChart(study));
      if (save_worst_ > 0)
        SaveWorstParts(station, study.shots, save_worst_, seed_, root / "worst_repeat",
                       [&](int i) { return RenderRepeatShot(station, repeat_options_, i); });
      add_chart("repeat_error_histogram.png",
                 ErrorHistogramChart(study.shots, 2 * std::sqrt(study.variance_mm2), "Repeat study: flatness error of each shot"));
    }
    if (batch_options_.parts > 0) {
      const BatchStudy study = RunBatchStudy(station, batch_options_, ProgressLogger("batch: part"));
      add_section("batch", BatchMarkdown(study, batch_options_), BatchJson(study, batch_options_));
      add_chart("batch_measured_vs_true.png", MeasuredVsTrueChart(study, tolerance_));
      if (save_worst_ > 0)
        SaveWorstParts(station, study.parts, save_worst_, seed_, root / "worst",
                       [&](int i) { return RenderBatchPart(station, batch_options_, i); });
      add_chart("batch_error_histogram.png",
                 ErrorHistogramChart(study.parts, study.uncertainty_mm, "Batch: flatness error of each part"));
      // Each part's uncertainty against its error, over --calibrations stations.
      // With calibrated stations, each calibration's own error where the parts lie, too.
      std::vector<std::vector<PartMeasurement>> stations = {study.parts};
      std::vector<uint64_t> seeds = {seed_};
      std::vector<CalibrationShare> shares;
      if (!true_calibration_) shares.push_back(MeasureCalibrationShare(station, seed_));
      for (int k = 1; k < calibrations_; ++k) {
        seeds.push_back(seed_ + k);
        spdlog::info("uncertainty: station {} of {} (seed {})", k + 1, calibrations_, seeds.back());
        BatchStudyOptions options = batch_options_;
        options.seed = seeds.back();
        const CalibratedStation other = make_station(seeds.back(), root / fmt::format("station_{}", seeds.back()));
        stations.push_back(RunBatchStudy(other, options, ProgressLogger("uncertainty: part")).parts);
        if (!true_calibration_) shares.push_back(MeasureCalibrationShare(other, seeds.back()));
      }
      const UncertaintyValidation validation = ValidateUncertainty(stations, seeds);
      add_section("uncertainty", UncertaintyMarkdown(validation), UncertaintyJson(validation));
      if (!shares.empty())
        add_section("calibration_share", CalibrationShareMarkdown(shares), CalibrationShareJson(shares));
    }
    if (rotation) {
      const RotationStudy study = RunRotationStudy(station, rotation_options_, ProgressLogger("rotation: part"));
      add_section("rotation", RotationMarkdown(study, rotation_options_), RotationJson(study, rotation_options_));
      add_chart("rotation_coverage.png", RotationChart(study));
    }
    if (robustness_options_.parts > 0) {
      const RobustnessStudy study =
          RunRobustnessStudy(station, robustness_options_, RealisticImageEffects(), ProgressLogger("robustness: part"));
      add_section("robustness", RobustnessMarkdown(study, robustness_options_), RobustnessJson(study, robustness_options_));
    }
    if (gauge_options_.parts > 0) {
      // The appraisers: this station and --gauge-stations - 1 more, each calibrated from its own images.
      std::vector<CalibratedStation> others;
      std::vector<const CalibratedStation*> appraisers = {&station};
      std::vector<std::string> names = {fmt::format("station_{}", seed_)};
      others.reserve(gauge_stations_);
      for (int k = 1; k < gauge_stations_; ++k) {
        others.push_back(make_station(seed_ + k, root / fmt::format("station_{}", seed_ + k)));
        appraisers.push_back(&others.back());
        names.push_back(fmt::format("station_{}", seed_ + k));
      }
      const TwinGaugeStudy study = RunTwinGaugeStudy(appraisers, names, gauge_options_, ProgressLogger("gauge: trial"));
      add_section("gauge", TwinGaugeMarkdown(study, gauge_options_), TwinGaugeJson(study, gauge_options_));
    }
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    json["total_time_s"] = seconds;
    WriteTextFileAtomically(root / "report.md", md);
    WriteTextFileAtomically(root / "report.html", HtmlPage("flatscan evaluate: " + scene.name, html));
    WriteTextFileAtomically(root / "evaluation.json", json.dump(1) + "\n");
    dir.Commit();
    std::cout << fmt::format("wrote {}/ (report.md, report.html, evaluation.json, charts, station/) in {:.1f} s\n", output_, seconds);
    return 0;
  }

 private:
  std::string preset_ = "paper";
  std::string scene_file_;
  std::string output_ = "flatscan-evaluate";
  uint64_t seed_ = 1;
  bool repeat_ = false;
  int structured_light_shots_ = 20;
  bool force_ = false;
  bool no_correction_ = false;
  SideFaceModel side_faces_ = SideFaceModel::kLocalNormal;
  bool true_calibration_ = false;
  double tolerance_ = FlatnessSpec::kDefaultToleranceMm;
  int calib_poses_ = kDefaultCalibrationPoses;
  int save_worst_ = 0;
  int calibrations_ = 1;
  std::string distortion_model_ = "standard";

  RepeatStudyOptions repeat_options_;
  RotationStudyOptions rotation_options_ = [] {
    RotationStudyOptions o;
    o.step_deg = 0;  // off unless --rotation-step
    return o;
  }();
  BatchStudyOptions batch_options_ = [] {
    BatchStudyOptions o;
    o.parts = 0;
    return o;
  }();
  BatchStudyOptions robustness_options_ = batch_options_;  // off unless --robustness
  TwinGaugeOptions gauge_options_ = [] {
    TwinGaugeOptions o;
    o.parts = 0;  // off unless --gauge
    return o;
  }();
  int gauge_stations_ = 1;
};

}  // namespace

std::unique_ptr<Command> MakeEvaluateCommand() { return std::make_unique<EvaluateCommand>(); }

}  // namespace flatscan
