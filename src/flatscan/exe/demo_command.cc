#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iostream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "flatscan/evaluation/simulated_station.h"
#include "flatscan/exe/commands.h"
#include "flatscan/inspection/inspect_part.h"
#include "flatscan/io/image_io.h"
#include "flatscan/simulation/dataset.h"
#include "flatscan/util/error.h"

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
    sub_->add_option("-o,--output", output_, "dataset folder (written, then used)")->default_val("flatscan-demo");
    sub_->add_option("--seed", seed_, "random seed")->default_val(1);
    sub_->add_option("--parts", parts_, "number of parts")->default_val(6)->check(CLI::PositiveNumber);
    sub_->add_option("--tolerance", tolerance_, "flatness tolerance, mm")->default_val(0.1);
    sub_->add_option("--preset", preset_, "simulated station: paper or compact")->default_val("paper");
    sub_->add_flag("--no-thickness-correction", no_correction_, "inspect as if the sheet had no thickness (to see what the correction removes)");
  }

  int Run() override {
    const auto start = std::chrono::steady_clock::now();
    SimulateOptions options;
    options.scene = ScenePreset(preset_);
    options.scene.dataset.parts = parts_;
    options.scene.part.flatness_mm = {0.02, 0.18};  // about half pass a 0.1 mm tolerance
    options.scene.board.poses = 14;
    options.seed = seed_;
    options.output_dir = output_;
    SimulateDataset(options, [](const std::string& s) { spdlog::info("rendering {}", s); });
    const std::filesystem::path dir = output_;
    std::cout << fmt::format("1. simulated {} ({} preset: 2 x {} x {} px, 14 chessboard pairs, marker pair, {} parts) in {:.1f} s\n",
                             output_, preset_, options.scene.left_camera.width, options.scene.left_camera.height, parts_,
                             Seconds(start));

    const auto step = std::chrono::steady_clock::now();
    const CalibratedStation station = CalibrateSimulatedStation(options.scene, dir);
    const RigCalibrationReport& rig_report = station.rig_report;
    std::cout << fmt::format("2. calibrated the rig from {} pairs: RMS {:.3f} px, epipolar {:.3f} px, baseline {:.3f} mm -> rig_calibrated.yml\n",
                             rig_report.views.size(), rig_report.rms_px, rig_report.epipolar_px, rig_report.rig.BaselineMm());
    std::cout << fmt::format("3. calibrated the support plane from {} markers: residual RMS {:.4f} mm -> plane_calibrated.yml ({:.1f} s for both)\n",
                             station.plane_report.matched.size(), station.plane_report.tls.RmsMm(), Seconds(step));

    const nlohmann::json truth = nlohmann::json::parse(std::ifstream(dir / "truth.json"));
    std::cout << fmt::format("4. inspected every part with the calibrated rig and plane (tolerance {:.3f} mm):\n", tolerance_);
    std::cout << fmt::format("   {:<10} {:>9} {:>10} {:>10} {:>9} {:>7} {:>9} {:>9}\n", "part", "true_mm", "measured", "error_um",
                             "coverage", "truth", "verdict", "time_ms");
    int agree = 0, measured = 0;
    std::vector<double> errors, times;
    for (const auto& part : truth["parts"]) {
      const auto& shot = part["shots"][0];
      InspectionParams params;
      params.thickness_mm = part["geometry"]["thickness_mm"].get<double>() + part["geometry"]["wall_height_mm"].get<double>();
      params.tolerance_mm = tolerance_;
      params.thickness_correction = !no_correction_;
      const double true_flatness = part["flatness_mm"].get<double>();
      const std::string expected = true_flatness > tolerance_ ? "fail" : "pass";
      try {
        const cv::Mat1b l = ReadGreyImage((dir / shot["left"].get<std::string>()).string());
        const cv::Mat1b r = ReadGreyImage((dir / shot["right"].get<std::string>()).string());
        const auto t0 = std::chrono::steady_clock::now();
        const InspectionResult res = InspectPart(station.rig(), station.plane(), l, r, params);
        const double ms = 1000 * Seconds(t0);
        const std::string verdict = res.pass ? "pass" : "fail";
        ++measured;
        errors.push_back(std::abs(res.values.flatness_mm - true_flatness));
        times.push_back(ms);
        agree += verdict == expected;
        std::cout << fmt::format("   {:<10} {:>9.4f} {:>10.4f} {:>+10.1f} {:>9.3f} {:>7} {:>9} {:>9.1f}\n", part["id"].get<std::string>(),
                                 true_flatness, res.values.flatness_mm, 1000 * (res.values.flatness_mm - true_flatness),
                                 res.coverage, expected, verdict, ms);
      } catch (const InputError& e) {
        std::cout << fmt::format("   {:<10} {:>9.4f} {:>10} {:>10} {:>9} {:>7} {:>9}   {}\n", part["id"].get<std::string>(),
                                 true_flatness, "-", "-", "-", expected, "-", e.what());
      }
    }
    std::cout << fmt::format("{} of {} parts measured, {} verdicts agree with the truth; total {:.1f} s\n", measured,
                             truth["parts"].size(), agree, Seconds(start));
    if (!errors.empty()) {
      std::sort(errors.begin(), errors.end());
      std::sort(times.begin(), times.end());
      const size_t p95 = std::min(errors.size() - 1, static_cast<size_t>(std::ceil(0.95 * errors.size())) - 1);
      std::cout << fmt::format("|flatness error|: median {:.1f} um, 95th percentile {:.1f} um, max {:.1f} um; "
                               "inspection time per part: median {:.1f} ms\n",
                               1000 * errors[errors.size() / 2], 1000 * errors[p95], 1000 * errors.back(), times[times.size() / 2]);
    }
    return measured == static_cast<int>(truth["parts"].size()) ? 0 : 2;
  }

 private:
  std::string output_ = "flatscan-demo";
  uint64_t seed_ = 1;
  int parts_ = 6;
  double tolerance_ = 0.1;
  std::string preset_ = "paper";
  bool no_correction_ = false;
};

}  // namespace

std::unique_ptr<Command> MakeDemoCommand() { return std::make_unique<DemoCommand>(); }

}  // namespace flatscan
