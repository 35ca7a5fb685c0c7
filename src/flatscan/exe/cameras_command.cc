#include <fstream>
#include <iostream>
#include <string>

#include <fmt/format.h>

#include "flatscan/acquisition/aravis_camera.h"
#include "flatscan/exe/commands.h"
#include "flatscan/io/output_files.h"
#include "flatscan/util/error.h"

namespace flatscan {
namespace {

class CamerasCommand : public Command {
 public:
  void Register(CLI::App& app) override {
    sub_ = app.add_subcommand("cameras", "List the GenICam cameras (GigE Vision, USB3 Vision) through Aravis, or "
                                         "grab a few frames from one: size, pixel format, frame rate and grey levels "
                                         "(the backlight check).");
    sub_->footer("Example: flatscan cameras\n         flatscan cameras --test Basler-21234567 --frames 20\n"
                 "Setting up two cameras: docs/cameras.md.");
    json_option_ = sub_->add_option("--json", json_, "the list as JSON, to this file or standard output")->expected(0, 1);
    sub_->add_option("--test", test_, "grab frames from the camera with this id or serial number");
    sub_->add_option("--frames", frames_, "frames to grab with --test")->default_val(frames_)->check(CLI::Range(1, 10000));
    sub_->add_option("--timeout", timeout_ms_, "milliseconds to wait for each frame with --test")
        ->default_val(timeout_ms_)
        ->check(CLI::Range(1, 600000));
    sub_->add_option("--interfaces", interfaces_,
                     "where to look: a comma-separated list of gige (GigE Vision discovery, a broadcast on every "
                     "network interface), usb3, fake (Aravis's in-process fake camera, id Fake_1)")
        ->default_val(interfaces_);
    sub_->add_flag("--include-fake", include_fake_, "also the fake camera (as --interfaces gige,usb3,fake)");
  }

  int Run() override {
    if (!test_.empty()) return Test();
    const std::vector<CameraInfo> cameras = ListCameras(Interfaces());
    if (json_option_->count() > 0) return WriteJson(cameras);
    if (cameras.empty()) {
      std::cout << "no GenICam camera found (GigE Vision: same subnet as a network interface, see docs/cameras.md; "
                   "USB3 Vision: udev rules)\n";
      return 0;
    }
    std::cout << fmt::format("{:<32} {:<12} {:<20} {:<16} {:<11} {}\n", "id", "vendor", "model", "serial", "protocol",
                             "address");
    for (const CameraInfo& c : cameras)
      std::cout << fmt::format("{:<32} {:<12} {:<20} {:<16} {:<11} {}\n", c.id, c.vendor, c.model, c.serial,
                               c.protocol, c.address);
    return 0;
  }

 private:
  int WriteJson(const std::vector<CameraInfo>& cameras) {
    nlohmann::json list = nlohmann::json::array();
    for (const CameraInfo& c : cameras) list.push_back(CameraInfoToJson(c));
    const std::string text = list.dump(2) + "\n";
    if (cameras.empty()) std::cerr << "no GenICam camera found\n";
    if (json_.empty() || json_ == "-") {
      std::cout << text;
      return 0;
    }
    OutputFiles out({});
    out.Declare("--json", json_);
    out.Stage("--json", [&](const std::filesystem::path& tmp) {
      std::ofstream os(tmp, std::ios::binary);
      os << text;
      if (!os.flush()) ThrowInputError("{}: cannot write", json_);
    });
    out.Commit();
    return 0;
  }

  int Test() {
    const auto camera = AravisCamera::Open(test_, Interfaces());
    const GrabStatistics s = camera->TestGrab(frames_, std::chrono::milliseconds(timeout_ms_));
    std::cout << fmt::format(
        "camera {}\n  frames: {} complete, {} incomplete, {} timed out\n  size: {} x {}, {}\n  frame rate: {:.1f} "
        "frames/s\n  grey: mean {:.1f}, saturated (255) {:.2f}%, dark (< 13) {:.2f}%\n",
        camera->Name(), s.frames, s.incomplete, s.timeouts, s.width, s.height, s.pixel_format, s.frames_per_second,
        s.mean_grey, 100 * s.saturated_share, 100 * s.dark_share);
    return 0;
  }

  CameraInterfaces Interfaces() const {
    CameraInterfaces i = ParseCameraInterfaces(interfaces_, "--interfaces");
    i.fake = i.fake || include_fake_;
    return i;
  }

  CLI::Option* json_option_ = nullptr;
  std::string json_, test_, interfaces_ = "gige,usb3";
  int frames_ = 10, timeout_ms_ = 2000;
  bool include_fake_ = false;
};

}  // namespace

std::unique_ptr<Command> MakeCamerasCommand() { return std::make_unique<CamerasCommand>(); }

}  // namespace flatscan
