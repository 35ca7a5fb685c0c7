#include <chrono>
#include <iostream>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "flatscan/evaluation/flatness_study.h"
#include "flatscan/evaluation/simulated_station.h"
#include "flatscan/exe/commands.h"
#include "flatscan/exe/options.h"
#include "flatscan/simulation/dataset.h"

namespace flatscan {
namespace {

double Seconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

// The main job on the embedded default: simulate a small paper-preset dataset,
// calibrate the rig from its chessboards and the plane from its markers, inspect
// every part with those calibrations and compare with the truth.
class DemoCommand : public Command {
 public:
  void Register(CLI::App& app) override {
    sub_ = app.add_subcommand("demo", "Simulate a paper-preset station, calibrate it, inspect every part and compare "
                                      "with the truth.");
    sub_->footer("Example: flatscan demo -o flatscan-demo");
    AddOutputOption(sub_, &output_, "dataset folder (written, then used)")->default_val(output_);
    AddForceFlag(sub_, &force_);
    AddSeedOption(sub_, &seed_);
    sub_->add_option("--parts", parts_, "number of parts")->default_val(parts_)->check(IntegerIn(1, 100000));
    Fills(AddToleranceOption(sub_, &options_.tolerance_mm), "tolerance_mm");
    sub_->add_option("--preset", preset_, "simulated station: paper or compact")->default_val(preset_);
    AddNoThicknessCorrectionFlag(sub_, &no_correction_);
  }

  int Run() override {
    CheckFlatnessSpec({options_.tolerance_mm});
    const auto start = std::chrono::steady_clock::now();
    SimulateOptions simulate;
    simulate.scene = ScenePreset(preset_);
    simulate.scene.dataset.parts = parts_;
    simulate.scene.part.flatness_mm = {0.02, 0.18};  // about half pass a 0.1 mm tolerance
    simulate.scene.board.poses = kDefaultCalibrationPoses;
    simulate.seed = seed_;
    simulate.output_dir = output_;
    simulate.replace_any_folder = force_;
    SimulateDataset(simulate, [](const std::string& s) { spdlog::info("rendering {}", s); });
    std::cout << fmt::format("1. simulated {} ({} preset: 2 x {} x {} px, {} chessboard pairs, marker pair, {} parts) in {:.1f} s\n",
                             output_, preset_, simulate.scene.left_camera.width, simulate.scene.left_camera.height,
                             kDefaultCalibrationPoses, parts_, Seconds(start));

    const auto step = std::chrono::steady_clock::now();
    const CalibratedStation station = CalibrateSimulatedStation(simulate.scene, output_);
    const RigCalibrationReport& rig_report = station.rig_report;
    std::cout << fmt::format("2. calibrated the rig from {} pairs: RMS {:.3f} px, epipolar {:.3f} px, baseline {:.3f} mm -> rig_calibrated.yml\n",
                             rig_report.views.size(), rig_report.rms_px, rig_report.epipolar_px, rig_report.rig.BaselineMm());
    std::cout << fmt::format("3. calibrated the support plane from {} markers: residual RMS {:.4f} mm -> plane_calibrated.yml ({:.1f} s for both)\n",
                             station.plane_report.matched.size(), station.plane_report.tls.RmsMm(), Seconds(step));

    options_.seed = seed_;
    options_.inspection.thickness_correction = !no_correction_;
    const DatasetStudy study = RunDatasetStudy(station, output_, options_);
    std::cout << fmt::format("4. inspected every part with the calibrated rig and plane (tolerance {:.3f} mm):\n",
                             options_.tolerance_mm);
    std::cout << fmt::format("   {:<10} {:>9} {:>10} {:>10} {:>6} {:>9} {:>7} {:>9} {:>9}\n", "part", "true_mm", "measured",
                             "error_um", "U_um", "coverage", "truth", "verdict", "time_ms");
    for (const PartMeasurement& m : study.parts) {
      const char* truth = VerdictName(Judge(m.true_flatness_mm, {options_.tolerance_mm}).verdict);
      if (m.measured)
        std::cout << fmt::format("   {:<10} {:>9.4f} {:>10.4f} {:>+10.1f} {:>6.1f} {:>9.3f} {:>7} {:>9} {:>9.1f}\n", m.id,
                                 m.true_flatness_mm, m.values.flatness_mm, 1000 * m.ErrorMm(),
                                 1000 * m.uncertainty.expanded_mm, m.coverage, truth, m.pass ? "pass" : "fail",
                                 m.inspect_ms);
      else
        std::cout << fmt::format("   {:<10} {:>9.4f} {:>10} {:>10} {:>6} {:>9} {:>7} {:>9}   {}\n", m.id, m.true_flatness_mm,
                                 "-", "-", "-", "-", truth, "-", m.error);
    }
    std::cout << fmt::format("{} of {} parts measured, {} verdicts agree with the truth; total {:.1f} s\n",
                             study.errors.count, study.parts.size(), study.agree, Seconds(start));
    if (study.errors.count > 0)
      std::cout << fmt::format("|flatness error|: median {:.1f} um, 95th percentile {:.1f} um, max {:.1f} um; "
                               "inspection time per part (one thread's CPU time): median {:.1f} ms\n",
                               1000 * study.errors.median_abs_mm, 1000 * study.errors.p95_abs_mm,
                               1000 * study.errors.max_abs_mm, study.median_inspect_ms);
    return study.errors.count == static_cast<int>(study.parts.size()) ? 0 : 2;
  }

 private:
  std::string output_ = "flatscan-demo";
  uint64_t seed_ = 1;
  int parts_ = 6;
  std::string preset_ = "paper";
  bool no_correction_ = false;
  bool force_ = false;
  StudyOptions options_;
};

}  // namespace

std::unique_ptr<Command> MakeDemoCommand() { return std::make_unique<DemoCommand>(); }

}  // namespace flatscan
