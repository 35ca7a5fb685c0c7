#include <filesystem>
#include <iostream>
#include <optional>
#include <string>

#include <fmt/format.h>

#include "flatscan/exe/commands.h"
#include "flatscan/exe/options.h"
#include "flatscan/exe/parse_util.h"
#include "flatscan/io/output_files.h"
#include "flatscan/io/rig_file.h"
#include "flatscan/util/error.h"

namespace flatscan {
namespace {


std::pair<int, int> ParseImageSize(const std::string& text) {
  const std::optional<std::pair<int, int>> parsed = ParseTwoIntegers(text);
  if (!parsed)
    ThrowInputError("--size '{}': expected the image size in pixels as width x height, such as 640x480", text);
  return *parsed;
}

class ImportRigCommand : public Command {
 public:
  void Register(CLI::App& app) override {
    sub_ = app.add_subcommand("import-rig",
                              "Make a rig file from OpenCV stereo_calib's intrinsics.yml and extrinsics.yml "
                              "(the rectification is recomputed with flags = 0).");
    sub_->footer("Example: flatscan import-rig --intrinsics intrinsics.yml --extrinsics extrinsics.yml "
                 "--size 640x480 -o rig.yml");
    sub_->add_option("--intrinsics", intrinsics_, "intrinsics.yml (M1 D1 M2 D2)")->required();
    sub_->add_option("--extrinsics", extrinsics_, "extrinsics.yml (R T ...)")->required();
    sub_->add_option("--size", size_, "image size WxH in pixels (stereo_calib does not record it)")->required();
    AddOutputOption(sub_, &output_, "rig file to write")->required();
  }

  int Run() override {
    const auto [width, height] = ParseImageSize(size_);
    OutputFiles out({{"--intrinsics", intrinsics_}, {"--extrinsics", extrinsics_}});
    out.Declare("--output", output_);
    const StereoRig rig = ImportOpenCvStereoCalib(intrinsics_, extrinsics_, width, height);
    out.Stage("--output", [&](const std::filesystem::path& tmp) { WriteRigFile(tmp, rig); });
    out.Commit();
    std::cout << fmt::format("imported {} and {}: {}x{}, baseline {:.4f} mm\nwrote {}\n", intrinsics_, extrinsics_,
                             width, height, rig.BaselineMm(), output_);
    return 0;
  }

 private:
  std::string intrinsics_, extrinsics_, size_, output_;
};

}  // namespace

std::unique_ptr<Command> MakeImportRigCommand() { return std::make_unique<ImportRigCommand>(); }

}  // namespace flatscan
