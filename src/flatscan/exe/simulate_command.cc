#include <chrono>
#include <iostream>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "flatscan/exe/commands.h"
#include "flatscan/exe/options.h"
#include "flatscan/simulation/dataset.h"
#include "flatscan/util/error.h"

namespace flatscan {
namespace {

class SimulateCommand : public Command {
 public:
  void Register(CLI::App& app) override {
    sub_ = app.add_subcommand("simulate", "Render a simulated inspection dataset (the digital twin): true rig, "
                                          "calibration pairs, marker pair, part pairs and truth.json.");
    sub_->footer("Example: flatscan simulate --preset paper --parts 5 --shots 3 --seed 7 -o data/paper");
    AddSceneOptions(sub_, &preset_, &scene_file_);
    AddOutputOption(sub_, &output_, "dataset folder to write (replaced if it exists)");
    sub_->add_flag("--print-scene", print_scene_, "print the resolved scene as JSON (a starting point for a scene file) and exit");
    AddForceFlag(sub_, &force_);
    AddSeedOption(sub_, &seed_);
    // The same bounds as the scene file's keys (simulation/scene_config.cc).
    sub_->add_option("--parts", parts_, "number of parts (overrides the scene)")->check(IntegerIn(0, 100000));
    sub_->add_option("--shots", shots_, "repeated shots of each part: fresh noise and placement jitter")
        ->check(IntegerIn(1, 10000));
    sub_->add_option("--calib-poses", calib_poses_, "number of chessboard pairs (overrides the scene)")
        ->check(IntegerIn(0, 200));
    sub_->add_flag("--no-calibration", no_calibration_, "skip the calibration pairs");
    sub_->add_flag("--no-markers", no_markers_, "skip the marker pair");
  }

  int Run() override {
    SimulateOptions options;
    options.scene = LoadScene(preset_, scene_file_);
    if (parts_ >= 0) options.scene.dataset.parts = parts_;
    if (shots_ > 0) options.scene.dataset.shots = shots_;
    if (calib_poses_ >= 0) options.scene.board.poses = calib_poses_;
    if (print_scene_) {
      std::cout << SceneToJson(options.scene).dump(2) << "\n";
      return 0;
    }
    if (output_.empty()) ThrowInputError("simulate: --output is required (the dataset folder to write)");
    options.seed = seed_;
    options.output_dir = output_;
    options.replace_any_folder = force_;
    options.calibration_images = !no_calibration_ && options.scene.board.poses > 0;
    options.marker_images = !no_markers_;
    const auto start = std::chrono::steady_clock::now();
    const SimulateSummary summary =
        SimulateDataset(options, [](const std::string& s) { spdlog::info("rendering {}", s); });
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::cout << fmt::format("wrote {} ({} files: {} calibration pairs, {} parts, {} part pairs) in {:.1f} s\n",
                             summary.output_dir.string(), summary.files.size(), summary.calibration_pairs,
                             summary.parts, summary.part_pairs, seconds);
    for (const std::string& f : summary.files) std::cout << "  " << f << "\n";
    return 0;
  }

 private:
  std::string preset_ = "paper";
  std::string scene_file_;
  std::string output_;
  uint64_t seed_ = 1;
  int parts_ = -1;
  int shots_ = 0;
  int calib_poses_ = -1;
  bool no_calibration_ = false;
  bool force_ = false;
  bool no_markers_ = false;
  bool print_scene_ = false;
};

}  // namespace

std::unique_ptr<Command> MakeSimulateCommand() { return std::make_unique<SimulateCommand>(); }

}  // namespace flatscan
